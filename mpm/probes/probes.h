// Probes: the metrics of benchmarks.md, evaluated on the current state, one metrics.csv
// column each (names from the output contract).
#pragma once

#include <cmath>
#include <limits>
#include <vector>

#include "simulation/simulation.h"

namespace iqmpm {

// Calls f(cell, layout index) for the 2^dim dual cells nearest a point: their centres
// bracket it, shifted inside the domain at walls.
template <int dim, class F>
void for_each_cell_around(const Grid<dim>& grid, const std::vector<Real>& point, F&& f) {
  Vec<dim> x;
  for (int a = 0; a < dim; ++a) x[a] = point[a];
  const auto cells = grid.dual_cells();
  const Vec<dim> xi = grid.to_cells(x);
  IVec<dim> first;
  for (int a = 0; a < dim; ++a)
    first[a] = std::min(std::max(int(std::floor(xi[a] - Real(0.5))), 0), grid.cells[a] - 2);
  for_each_offset<dim, 2>([&](const IVec<dim>& offset) { f(IVec<dim>(first + offset), cells.index(first + offset)); });
}

template <int dim>
Real evaluate_probe(const Simulation<dim>& sim, const ProbeSpec& probe) {
  const auto& fluid = sim.fluid();
  const auto& grid = sim.grid();
  const int up = sim.up_axis();
  // Particles mark the centres of their share of volume: the fluid reaches half a spacing
  // beyond the outermost ones.
  const Real half_spacing = 0.5 * grid.dx / sim.scene().particles_per_axis;
  if (probe.type == "front") {
    const Real below = probe.band < 0 ? grid.origin[up] + grid.dx : probe.band;
    Real front = -std::numeric_limits<Real>::infinity();
    for (const auto& x : fluid.position)
      if (x[up] < below) front = std::max(front, x[probe.axis]);
    return std::isfinite(front) ? front + half_spacing : std::nan("");
  }
  if (probe.type == "water_height") {
    // Top of the water column connected to the floor at each gauge (one, or one every dx
    // from position to `to`, each over half a cell either side): splashes and drops above
    // an empty cell do not count. In 3-D a gauge is a row of columns, one per cell along
    // the other horizontal axis, each with its own top: the highest particle over the whole row would
    // read the crest of any wave. One pass over the particles fills every column's rows.
    const bool range = probe.position_to != kNoRange;
    const Real half_width = range ? Real(0.5) * grid.dx : (probe.band < 0 ? grid.dx : probe.band);
    const int gauges = range ? int(std::floor((probe.position_to - probe.position) / grid.dx + 1e-9)) + 1 : 1;
    // In 3-D: the horizontal axis that is not the gauges' first axis, and the columns per gauge.
    const int across_axis = up == 1 ? 2 : 1;
    int across = 1;
    if constexpr (dim == 3) across = grid.cells[across_axis];
    const int rows = grid.cells[up];
    const int columns = gauges * across;
    std::vector<Real> row_top(std::size_t(columns) * rows, -std::numeric_limits<Real>::infinity());
    for (const auto& x : fluid.position) {
      const int g = range ? int(std::lround((x[0] - probe.position) / grid.dx)) : 0;
      if (g < 0 || g >= gauges || std::abs(x[0] - (probe.position + g * grid.dx)) > half_width) continue;
      int column = g;
      if constexpr (dim == 3)
        column = g * across + std::min(across - 1, std::max(0, int(std::floor((x[across_axis] - grid.origin[across_axis]) / grid.dx))));
      const int row = std::min(rows - 1, std::max(0, int(std::floor((x[up] - grid.origin[up]) / grid.dx))));
      Real& top = row_top[std::size_t(column) * rows + row];
      top = std::max(top, x[up]);
    }
    Real sum = 0;
    for (int c = 0; c < columns; ++c) {
      Real top = -std::numeric_limits<Real>::infinity();
      for (int row = 0; row < rows && std::isfinite(row_top[std::size_t(c) * rows + row]); ++row) top = row_top[std::size_t(c) * rows + row];
      sum += std::isfinite(top) ? top + half_spacing - grid.origin[up] : Real(0);
    }
    return sum / columns;
  }
  if (probe.type == "pressure") {
    // Mean of the 2^dim dual cells nearest the point. The block holds cells of every Q1-P0
    // sublattice, so the checkerboard pressure mode, which moves no fluid, averages out.
    // Empty cells count as 0.
    Real sum = 0;
    for_each_cell_around(grid, probe.point, [&](const IVec<dim>&, int k) { sum += sim.fluid_pressure(k); });
    return sum / Real(1 << dim);
  }
  if (probe.type == "hydrostatic_head") {
    // The same cells that hold water, each as the level of a still surface above its
    // centre: p / (rho_f |g|) + height; exact in hydrostatic water below the top cell
    // layer, wherever the point sits. NaN before the first solve or in dry cells.
    const Real rho_g = sim.scene().fluid.density * std::abs(sim.scene().gravity[up]);
    Real sum = 0;
    int wet = 0;
    for_each_cell_around(grid, probe.point, [&](const IVec<dim>& cell, int k) {
      if (!sim.has_fluid_pressure(k)) return;
      sum += sim.fluid_pressure(k) / rho_g + grid.dual_cell_centre(cell)[up] - grid.origin[up];
      ++wet;
    });
    return wet ? sum / wet : std::nan("");
  }
  if (probe.type == "wall_force") return sim.wall_force(probe.wall_axis, probe.wall_side);
  if (probe.type == "displacement") return sim.tracked_displacement(probe.name)[probe.axis];
  if (probe.type == "solid_force")
    return (probe.region.empty() ? sim.interface_force(sim.body_index(probe.solid)) : sim.region_interface_force(probe.name))[probe.axis];
  if (probe.type == "solid_com") return sim.solid_centre_of_mass(sim.body_index(probe.solid))[probe.axis];
  if (probe.type == "solid_velocity") return sim.solid_mean_velocity(sim.body_index(probe.solid))[probe.axis];
  if (probe.type == "solid_angle") return probe.initial_angle + sim.solid_angle(sim.body_index(probe.solid));
  if (probe.type == "max_speed") {
    Real speed = 0;
    for (const auto& v : fluid.velocity) speed = std::max(speed, v.norm());
    for (const auto& v : sim.solid().velocity) speed = std::max(speed, v.norm());
    return speed;
  }
  if (probe.type == "volume") return sim.fluid_volume();
  if (probe.type == "particle_volume") return sim.fluid_particle_volume();
  if (probe.type == "hydrostatic_pressure_error") {
    // Relative L2 over the fluid cells of p against rho g (H - y) at the cell centre.
    const auto cells = grid.dual_cells();
    const Real rho_g = sim.scene().fluid.density * std::abs(sim.scene().gravity[up]);
    Real error2 = 0, norm2 = 0;
    for (int k : sim.fluid_cells()) {
      const Real y = grid.dual_cell_centre(cells.multi_index(k))[up];
      const Real exact = rho_g * std::max(Real(0), probe.surface - y);
      const Real diff = sim.fluid_pressure(k) - exact;
      error2 += diff * diff;
      norm2 += exact * exact;
    }
    return norm2 > 0 ? std::sqrt(error2 / norm2) : 0;
  }
  return std::nan("");
}

}  // namespace iqmpm
