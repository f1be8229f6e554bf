// Probes: the metrics of benchmarks.md, evaluated on the current state, one metrics.csv
// column each (names from the output contract). Each probe is resolved once against the
// scene and the seeded particles (its body, the material point it follows, its region);
// evaluation only reads the simulation (diagnostics/measurements.h).
#pragma once

#include <cmath>
#include <fmt/format.h>
#include <limits>
#include <string>
#include <vector>

#include "core/errors.h"
#include "diagnostics/measurements.h"
#include "simulation/simulation.h"

namespace iqmpm {

// The 2^dim dual cells nearest x: their centres bracket it, shifted inside the domain at
// walls. Returns the lowest cell of the block and x's position from that cell's centre in
// cells (in [0, 1] inside the bracket, beyond it between a wall and the first centres).
template <int dim>
IVec<dim> cells_around(const Grid<dim>& grid, const Vec<dim>& x, Vec<dim>& from_first_centre) {
  const Vec<dim> xi = grid.to_cells(x) - Vec<dim>::Constant(Real(0.5));
  IVec<dim> first;
  for (int a = 0; a < dim; ++a) {
    first[a] = std::min(std::max(int(std::floor(xi[a])), 0), grid.cells[a] - 2);
    from_first_centre[a] = xi[a] - first[a];
  }
  return first;
}

// Calls f(cell, layout index) for the 2^dim dual cells nearest a point (cells_around).
template <int dim, class F>
void for_each_cell_around(const Grid<dim>& grid, const std::vector<Real>& point, F&& f) {
  Vec<dim> x, t;
  for (int a = 0; a < dim; ++a) x[a] = point[a];
  const auto cells = grid.dual_cells();
  const IVec<dim> first = cells_around(grid, x, t);
  for_each_offset<dim, 2>([&](const IVec<dim>& offset) { f(IVec<dim>(first + offset), cells.index(first + offset)); });
}

// The pressure at x interpolated multilinearly between the centres of the cells around it
// (cells_around; linear extrapolation between a wall and the first centres). Exact for a
// pressure linear in x, such as hydrostatic water below its top cell layer; empty cells
// count as 0.
template <int dim, class Pressure>
Real interpolated_pressure(const Grid<dim>& grid, const Vec<dim>& x, Pressure&& pressure) {
  const auto cells = grid.dual_cells();
  Vec<dim> t;
  const IVec<dim> first = cells_around(grid, x, t);
  Real sum = 0;
  for_each_offset<dim, 2>([&](const IVec<dim>& offset) {
    Real weight = 1;
    for (int a = 0; a < dim; ++a) weight *= offset[a] ? t[a] : 1 - t[a];
    sum += weight * pressure(cells.index(IVec<dim>(first + offset)));
  });
  return sum;
}

// The mean of interpolated_pressure over the box of side `sensor` around the point, clipped
// to the domain, by the midpoint rule on at least two samples a cell along each axis (exact
// for a linear pressure; a checkerboard mode averages out over a box of a few cells).
template <int dim, class Pressure>
Real sensor_pressure(const Grid<dim>& grid, const std::vector<Real>& point, Real sensor, Pressure&& pressure) {
  Vec<dim> lower, size;
  IVec<dim> samples;
  for (int a = 0; a < dim; ++a) {
    lower[a] = std::max(point[a] - sensor / 2, grid.origin[a]);
    size[a] = std::min(point[a] + sensor / 2, grid.upper()[a]) - lower[a];
    samples[a] = std::max(2, int(std::ceil(2 * size[a] / grid.dx)));
  }
  const GridLayout<dim> layout(IVec<dim>::Zero(), samples);
  Real sum = 0;
  for (int k = 0; k < layout.size(); ++k) {
    const IVec<dim> s = layout.multi_index(k);
    Vec<dim> x;
    for (int a = 0; a < dim; ++a) x[a] = lower[a] + (s[a] + Real(0.5)) * size[a] / samples[a];
    sum += interpolated_pressure(grid, x, pressure);
  }
  return sum / layout.size();
}

template <int dim>
class Probes {
 public:
  // Throws InputError for a region that holds no particle of its body, or a displacement
  // point with no solid particle within dx.
  Probes(const SceneSpec& scene, const Simulation<dim>& sim);

  std::size_t size() const { return specs_.size(); }
  const std::string& name(std::size_t i) const { return specs_[i].name; }
  Real evaluate(const Simulation<dim>& sim, std::size_t i) const;
  // The SI unit of probe i's values (forces and volumes per metre of depth in 2-D).
  std::string unit(std::size_t i) const {
    switch (specs_[i].type) {
      case ProbeType::pressure: return "Pa";
      case ProbeType::wall_force:
      case ProbeType::solid_force: return dim == 2 ? "N/m" : "N";
      case ProbeType::max_speed:
      case ProbeType::solid_velocity: return "m/s";
      case ProbeType::volume:
      case ProbeType::particle_volume: return dim == 2 ? "m^2" : "m^3";
      case ProbeType::hydrostatic_pressure_error: return "1";
      case ProbeType::solid_angle: return "rad";
      default: return "m";  // front, water_height, hydrostatic_head, displacement, solid_com
    }
  }

 private:
  // A material point followed by a displacement probe: recognised by the initial
  // positions of the particles that carry it, which travel with them when particles are
  // sorted.
  struct Marker {
    Vec<dim> start = Vec<dim>::Zero();  // the material point X (initial position)
    std::vector<Vec<dim>> carriers;     // initial positions of its nearest particles
  };
  bool in_region(const Particles<dim>& solid, std::size_t p, std::size_t i) const {
    if (solid.body[p] != body_[i]) return false;
    for (const auto& shape : specs_[i].region)
      if (shape.contains(solid.initial_position[p].data(), dim)) return true;
    return false;
  }
  Vec<dim> tracked_displacement(const Simulation<dim>& sim, const Marker& marker) const;

  std::vector<ProbeSpec> specs_;
  std::vector<int> body_;         // per probe: its body's index, or -1
  std::vector<Marker> markers_;   // per probe (used by displacement probes)
  Real half_spacing_ = 0;
  Real rho_g_ = 0;
};

template <int dim>
Probes<dim>::Probes(const SceneSpec& scene, const Simulation<dim>& sim)
    : specs_(scene.probes), body_(scene.probes.size(), -1), markers_(scene.probes.size()) {
  const Particles<dim>& solid = sim.solid();
  const Real dx = sim.grid().dx;
  // Particles mark the centres of their share of volume: the fluid reaches half a spacing
  // beyond the outermost ones.
  half_spacing_ = Real(0.5) * dx / scene.particles_per_axis;
  rho_g_ = scene.fluid.density * std::abs(scene.gravity[sim.up_axis()]);
  for (std::size_t i = 0; i < specs_.size(); ++i) {
    const ProbeSpec& probe = specs_[i];
    for (std::size_t b = 0; b < scene.solids.size(); ++b)
      if (scene.solids[b].name == probe.solid) body_[i] = int(b);
    if (probe.type == ProbeType::solid_force && !probe.region.empty()) {
      int count = 0;
      for (std::size_t p = 0; p < solid.size(); ++p) count += in_region(solid, p, i);
      if (count == 0)
        throw InputError(fmt::format("scene key 'probes[{}].region': holds no particle of solid \"{}\"", i, probe.solid));
    }
    if (probe.type == ProbeType::displacement) {
      Vec<dim> x;
      for (int a = 0; a < dim; ++a) x[a] = probe.point[a];
      Real nearest = std::numeric_limits<Real>::infinity();
      for (const auto& xp : solid.position) nearest = std::min(nearest, (xp - x).norm());
      if (!(nearest <= dx))
        throw InputError(fmt::format("scene key 'probes[{}].point': a displacement probe must follow a point of a solid; "
                                     "no solid particle lies within dx of it", i));
      // The point is carried by its nearest particles (all within round-off of the nearest
      // distance, e.g. the two either side of a beam's centre line).
      markers_[i].start = x;
      for (std::size_t p = 0; p < solid.size(); ++p)
        if ((solid.position[p] - x).norm() <= nearest * (1 + 1e-9) + 1e-12 * dx) markers_[i].carriers.push_back(solid.initial_position[p]);
    }
  }
}

// The material point X moves with its carrier particles' local affine motion,
// x = x_p + F_p (X - X_p), averaged over the carriers (exact for an affine motion). A
// marker moved by the interpolated grid velocity instead lagged at a body's edge, where
// the stencil reaches empty nodes, and fell off a deflecting gate's tip.
template <int dim>
Vec<dim> Probes<dim>::tracked_displacement(const Simulation<dim>& sim, const Marker& marker) const {
  const Particles<dim>& solid = sim.solid();
  Vec<dim> sum = Vec<dim>::Zero();
  int found = 0;
  for (std::size_t p = 0; p < solid.size(); ++p)
    for (const auto& X : marker.carriers)
      if (solid.initial_position[p] == X) {
        sum += solid.position[p] + solid.deformation_gradient[p] * (marker.start - X);
        ++found;
      }
  return found > 0 ? Vec<dim>(sum / found - marker.start) : Vec<dim>::Constant(std::nan(""));
}

template <int dim>
Real Probes<dim>::evaluate(const Simulation<dim>& sim, std::size_t i) const {
  const ProbeSpec& probe = specs_[i];
  const auto& fluid = sim.fluid();
  const auto& grid = sim.grid();
  const int up = sim.up_axis();
  const Real half_spacing = half_spacing_;
  const int body = body_[i];
  switch (probe.type) {
  case ProbeType::front: {
    const Real below = probe.band < 0 ? grid.origin[up] + grid.dx : probe.band;
    Real front = -std::numeric_limits<Real>::infinity();
    for (const auto& x : fluid.position)
      if (x[up] < below) front = std::max(front, x[probe.axis]);
    return std::isfinite(front) ? front + half_spacing : std::nan("");
  }
  case ProbeType::water_height: {
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
  case ProbeType::pressure: {
    if (probe.sensor > 0)
      return sensor_pressure(grid, probe.point, probe.sensor, [&](int k) { return sim.fluid_pressure(k); });
    // Mean of the 2^dim dual cells nearest the point. The block holds cells of every Q1-P0
    // sublattice, so the checkerboard pressure mode, which moves no fluid, averages out.
    // Empty cells count as 0.
    Real sum = 0;
    for_each_cell_around(grid, probe.point, [&](const IVec<dim>&, int k) { sum += sim.fluid_pressure(k); });
    return sum / Real(1 << dim);
  }
  case ProbeType::hydrostatic_head: {
    // The same cells that hold water, each as the level of a still surface above its
    // centre: p / (rho_f |g|) + height; exact in hydrostatic water below the top cell
    // layer, wherever the point sits. NaN before the first solve or in dry cells.
    const Real rho_g = rho_g_;
    Real sum = 0;
    int wet = 0;
    for_each_cell_around(grid, probe.point, [&](const IVec<dim>& cell, int k) {
      if (!sim.has_fluid_pressure(k)) return;
      sum += sim.fluid_pressure(k) / rho_g + grid.dual_cell_centre(cell)[up] - grid.origin[up];
      ++wet;
    });
    return wet ? sum / wet : std::nan("");
  }
  case ProbeType::wall_force: return wall_force(sim, probe.wall_axis, probe.wall_side);
  case ProbeType::displacement: return tracked_displacement(sim, markers_[i])[probe.axis];
  case ProbeType::solid_force:
    if (probe.region.empty()) return body_interface_force(sim, body)[probe.axis];
    return interface_force(sim, [&](std::size_t p) { return in_region(sim.solid(), p, i); })[probe.axis];
  case ProbeType::solid_com: return body_centre_of_mass(sim, body)[probe.axis];
  case ProbeType::solid_velocity: return body_mean_velocity(sim, body)[probe.axis];
  case ProbeType::solid_angle: return probe.initial_angle + body_angle(sim, body);
  case ProbeType::max_speed: {
    Real speed = 0;
    for (const auto& v : fluid.velocity) speed = std::max(speed, v.norm());
    for (const auto& v : sim.solid().velocity) speed = std::max(speed, v.norm());
    return speed;
  }
  case ProbeType::volume: return fluid_volume(sim);
  case ProbeType::particle_volume: return fluid_particle_volume(sim);
  case ProbeType::hydrostatic_pressure_error: {
    // Relative L2 over the fluid cells of p against rho g (H - y) at the cell centre.
    const auto cells = grid.dual_cells();
    const Real rho_g = rho_g_;
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
  }
  return std::nan("");
}

}  // namespace iqmpm
