// Fluid operators of the pressure-only system (method.md §4): the lumped mass M^f on the
// active cell corners, the gradient G^f (Q1-P0) on the dual cells that hold fluid, and the
// free-slip wall operator B. Empty dual cells get no unknown, which is the free surface
// (p = 0 holds weakly).
#pragma once

#include <Eigen/SparseCore>
#include <array>
#include <cstdint>
#include <vector>

#include "core/types.h"
#include "grid/grid.h"
#include "grid/kernels.h"
#include "particles/particles.h"
#include "transfer/apic.h"

namespace iqmpm {

using Triplet = Eigen::Triplet<Real>;

// One domain side: axis and side (0 = lower, 1 = upper).
struct DomainSide {
  int axis;
  int side;
};

template <int dim>
struct WallFace {
  int dual_cell;  // fluid dual cell (layout index) next to the wall
  DomainSide wall;
};

template <int dim>
struct FluidOperators {
  // Velocity unknowns: active corners (mass > 0), dim components each, dof-major.
  std::vector<int> dof_of_corner;  // -1 where inactive
  std::vector<int> corner_of_dof;
  Eigen::VectorXd mass;            // M^f per dof (not per component), from the fluid quadrature
  std::vector<char> exact_mass;    // per dof: M^f only from the exact rule (every cell of the corner interior, none at a solid)
  // Pressure unknowns: dual cells holding fluid particles.
  std::vector<int> pressure_of_cell;  // -1 where no fluid
  std::vector<int> cell_of_pressure;
  std::vector<char> interior;         // per pressure unknown: exact one-point quadrature used
  std::vector<WallFace<dim>> wall_faces;
  std::vector<Triplet> gradient_transpose;  // rows: pressure unknowns; columns: velocity components
  std::vector<Triplet> wall_rows;           // rows: wall faces; columns: velocity components
  // Per velocity dof: bit 2 axis + side is set when the corner lies on that slip wall
  // (fluid.wall_constraint = corners holds that component; docs/method.md#walls-on-corners).
  std::vector<std::uint8_t> on_wall;
  // G^fT entries of corners that are not fluid unknowns because they lie inside a solid
  // (interface quadrature without interior fluid corners): (row, corner, coefficients).
  struct CornerEntry {
    int row;
    int corner;
    Vec<dim> coefficient;
  };
  std::vector<CornerEntry> solid_corner_gradient;

  int velocity_dofs() const { return int(corner_of_dof.size()); }
  int pressure_unknowns() const { return int(cell_of_pressure.size()); }
  // The slip walls the corner of `dof` lies on across `axis`: bit 0 the lower, bit 1 the upper.
  unsigned wall_sides(int dof, int axis) const { return (on_wall[dof] >> (2 * axis)) & 3u; }
};

// Whether a neighbour of `cell` in its 3^dim block, inside the domain, passes `test` (by
// layout index); the cell itself does not count.
template <int dim, class Test>
bool any_neighbour_cell(const GridLayout<dim>& cells, const IVec<dim>& cell, Test test) {
  bool found = false;
  for_each_offset<dim, 3>([&](const IVec<dim>& offset) {
    const IVec<dim> neighbour = cell + offset - IVec<dim>::Ones();
    if (neighbour != cell && cells.contains(neighbour) && test(cells.index(neighbour))) found = true;
  });
  return found;
}

// A dual cell holding fluid is interior when no neighbour in its 3^dim block is an empty
// cell inside the domain (`holds_fluid` by layout index): it is then full of fluid (method.md §4).
template <int dim, class HoldsFluid>
bool is_interior_cell(const GridLayout<dim>& cells, const IVec<dim>& cell, HoldsFluid holds_fluid) {
  return !any_neighbour_cell<dim>(cells, cell, [&](int k) { return !holds_fluid(k); });
}

// How the fluid quadrature is laid out near free surfaces and solids.
template <int dim>
struct FluidQuadratureOptions {
  // Surface cells use one point at the cell centre weighted by their particles' volume
  // (scene key fluid.surface_quadrature = "centre") instead of the particles themselves,
  // except a lone drop (one particle, no fluid next to it).
  bool surface_cells_at_centre = false;
  // With interface quadrature: the bins of the real fluid particles; corners touching no
  // real fluid cell lie inside a solid and are left to the caller (it gives them the
  // solid's velocity).
  const ParticleBins<dim>* real_fluid_bins = nullptr;
  // With real_fluid_bins: corners that move with a solid even if fluid particles lie in
  // their cells (coupling.solid_corner_fraction); dense over the corners, or null.
  const std::vector<std::uint8_t>* solid_corners = nullptr;
  // Massless points that extend G^f (and the pressure unknowns) into the interface cells:
  // the IQ points' borrowed volume (coupling.borrowed_fluid = "volume"), with their bins.
  const Particles<dim>* volume_points = nullptr;
  const ParticleBins<dim>* volume_point_bins = nullptr;
};

// slip[axis][side] says whether that domain side is a free-slip wall.
template <int dim>
FluidOperators<dim> build_fluid_operators(const Grid<dim>& grid, const Particles<dim>& particles,
                                          const ParticleBins<dim>& bins,
                                          const GridMomentum<dim>& corner_momentum, Real density,
                                          const std::array<std::array<bool, 2>, dim>& slip,
                                          const FluidQuadratureOptions<dim>& options = {}) {
  const bool surface_cells_at_centre = options.surface_cells_at_centre;
  const ParticleBins<dim>* real_fluid_bins = options.real_fluid_bins;
  FluidOperators<dim> ops;
  const GridLayout<dim> corners = grid.corners();
  const GridLayout<dim> cells = grid.dual_cells();

  // Quadrature points of a cell: the particles, then the massless volume points if any.
  const Particles<dim>* extra = options.volume_points;
  const ParticleBins<dim>* extra_bins = options.volume_point_bins;
  auto points_in = [&](int k) { return bins.count(k) + (extra ? extra_bins->count(k) : 0); };
  auto for_each_volume_point = [&](int k, auto&& f) {  // f(position, volume)
    for (int p = bins.begin(k); p < bins.end(k); ++p) f(particles.position[p], particles.initial_volume[p]);
    if (extra)
      for (int p = extra_bins->begin(k); p < extra_bins->end(k); ++p) f(extra->position[p], extra->initial_volume[p]);
  };

  // Pressure unknowns: dual cells with at least one quadrature point.
  number_cells_where(cells.size(), [&](int k) { return points_in(k) > 0; }, ops.pressure_of_cell, ops.cell_of_pressure);

  // A cell is interior when no neighbour (3^dim block) is an empty cell inside the
  // domain: it is then full of fluid and the exact one-point rule applies (method.md §4).
  // The loops over rows and corners below run on the threads where each iteration writes
  // only its own entry (the same arithmetic as in one loop); chunks are handed out as
  // threads come free, so a busy core does not hold the others (issue 21 item 4).
  const int np = ops.pressure_unknowns();
  ops.interior.assign(np, 0);
#pragma omp parallel for schedule(dynamic, 1024)
  for (int row = 0; row < np; ++row)
    ops.interior[row] = is_interior_cell<dim>(cells, cells.multi_index(ops.cell_of_pressure[row]),
                                              [&](int k) { return points_in(k) > 0; });

  // M^f from the same quadrature as G^f (method.md §4): exact in interior cells, the
  // particles elsewhere. Using one quadrature for both keeps fluid at rest in hydrostatic
  // balance even when particles are unevenly spread. Corners with mass are the unknowns.
  std::vector<Real> corner_mass(corners.size(), 0);
  std::vector<char> corner_inexact(corners.size(), 0);  // M^f has a part that is not the exact share
  const Real cell_volume = grid.cell_volume();
  // Fluid volume held by a cell's particles, capped at the cell volume (surface cells
  // with the one-point rule at the centre, option fluid.surface_quadrature = "centre").
  // M^f counts the points' mass, G^f their volume: IQ points that only extend the
  // divergence quadrature (coupling.borrowed_fluid = "volume") have volume but no mass.
  auto cell_fluid_volume = [&](int row) {
    Real volume = 0;
    const int cell_index = ops.cell_of_pressure[row];
    for_each_volume_point(cell_index, [&](const Vec<dim>&, Real v) { volume += v; });
    return std::min(volume, cell_volume);
  };
  auto cell_fluid_mass = [&](int row) {
    Real mass = 0;
    const int cell_index = ops.cell_of_pressure[row];
    for (int p = bins.begin(cell_index); p < bins.end(cell_index); ++p) mass += particles.mass[p];
    return std::min(mass, density * cell_volume);
  };
  const Real corner_share = density * cell_volume / Real(1 << dim);
  // The one-point rule at the centre stands for the water of a surface cell that belongs
  // to a body of water, not for a drop: a cell holding a single fluid particle with no
  // fluid in its 3^dim block (spray, a drop running down a wall) keeps that particle as
  // its quadrature point, the one-point rule at its water's centroid (method.md#fluid-quadrature).
  auto lone_drop = [&](int k) {
    return bins.count(k) == 1 && !(extra && extra_bins->count(k) > 0) &&
           !any_neighbour_cell<dim>(cells, cells.multi_index(k), [&](int j) { return points_in(j) > 0; });
  };
  std::vector<char> at_centre(np, 0);
#pragma omp parallel for schedule(dynamic, 1024)
  for (int row = 0; row < np; ++row)
    at_centre[row] = ops.interior[row] || (surface_cells_at_centre && !lone_drop(ops.cell_of_pressure[row]));
  for (int row = 0; row < np; ++row) {
    const int cell_index = ops.cell_of_pressure[row];
    const IVec<dim> cell = cells.multi_index(cell_index);
    // A cell that holds borrowed volume lies at a solid: its fluid fills only a part of it.
    const bool exact = ops.interior[row] && !(extra && extra_bins->count(cell_index) > 0);
    if (!exact) for_each_offset<dim, 2>([&](const IVec<dim>& offset) { corner_inexact[corners.index(cell + offset)] = 1; });
    if (at_centre[row]) {
      const Real share = ops.interior[row] ? corner_share : cell_fluid_mass(row) / Real(1 << dim);
      for_each_offset<dim, 2>([&](const IVec<dim>& offset) { corner_mass[corners.index(cell + offset)] += share; });
      continue;
    }
    for (int p = bins.begin(cell_index); p < bins.end(cell_index); ++p) {
      const auto stencil = linear_stencil<dim>(grid.to_cells(particles.position[p]), grid.dx);
      const Real quadrature_mass = particles.mass[p];
      for_each_offset<dim, 2>([&](const IVec<dim>& offset) {
        corner_mass[corners.index(stencil.base + offset)] += quadrature_mass * stencil.weight(offset);
      });
    }
  }
  Real largest_mass = 0;
#pragma omp parallel for schedule(static) reduction(max : largest_mass)
  for (int k = 0; k < corners.size(); ++k) largest_mass = std::max(largest_mass, corner_mass[k]);
  ops.dof_of_corner.assign(corners.size(), -1);
  // With interface quadrature (real_fluid_bins given), a corner is a fluid unknown only when
  // one of its cells holds a real fluid particle: corners reached only by fluid borrowed at
  // IQ points lie inside the solid; left free they let the fluid leak through the per-cell
  // interface constraint, so the caller gives them the solid's velocity (docs/method.md#interior-corners).
  // So do the corners in `solid_corners`, well inside a solid: a fluid particle that strays
  // there must not free them, or the leak feeds itself.
  auto touches_real_fluid = [&](int k) {
    if (!real_fluid_bins) return true;
    if (options.solid_corners && (*options.solid_corners)[k]) return false;
    const IVec<dim> corner = corners.multi_index(k);
    bool found = false;
    for_each_offset<dim, 2>([&](const IVec<dim>& offset) {
      const IVec<dim> cell = corner - offset;
      if (cells.contains(cell) && real_fluid_bins->count(cells.index(cell)) > 0) found = true;
    });
    return found;
  };
  std::vector<char> is_unknown(corners.size(), 0);
#pragma omp parallel for schedule(dynamic, 4096)
  for (int k = 0; k < corners.size(); ++k)
    is_unknown[k] = corner_mass[k] > 1e-12 * largest_mass && corner_momentum.mass[k] > 0 && touches_real_fluid(k);
  for (int k = 0; k < corners.size(); ++k)
    if (is_unknown[k]) {
      ops.dof_of_corner[k] = int(ops.corner_of_dof.size());
      ops.corner_of_dof.push_back(k);
    }
  ops.mass.resize(ops.velocity_dofs());
  ops.exact_mass.resize(ops.velocity_dofs());
  for (int d = 0; d < ops.velocity_dofs(); ++d) {
    ops.mass[d] = corner_mass[ops.corner_of_dof[d]];
    ops.exact_mass[d] = !corner_inexact[ops.corner_of_dof[d]];
  }
  ops.on_wall.assign(ops.velocity_dofs(), 0);
  for (int d = 0; d < ops.velocity_dofs(); ++d) {
    const IVec<dim> corner = corners.multi_index(ops.corner_of_dof[d]);
    for (int axis = 0; axis < dim; ++axis) {
      if (slip[axis][0] && corner[axis] == 0) ops.on_wall[d] |= std::uint8_t(1u << (2 * axis));
      if (slip[axis][1] && corner[axis] == grid.cells[axis]) ops.on_wall[d] |= std::uint8_t(1u << (2 * axis + 1));
    }
  }

  // G^fT rows: -(sum over quadrature of V grad N1_c) for the corners c of the cell; the
  // integrals on the threads, the rows in order after.
  std::vector<Eigen::Matrix<Real, dim, (1 << dim)>> integrals(np);
#pragma omp parallel for schedule(dynamic, 256)
  for (int row = 0; row < np; ++row) {
    const IVec<dim> cell = cells.multi_index(ops.cell_of_pressure[row]);
    Eigen::Matrix<Real, dim, (1 << dim)>& integral = integrals[row];
    integral.setZero();
    auto accumulate = [&](const Vec<dim>& x, Real volume) {
      const auto stencil = linear_stencil<dim>(grid.to_cells(x), grid.dx);
      int corner = 0;
      for_each_offset<dim, 2>([&](const IVec<dim>& offset) { integral.col(corner++) += volume * stencil.gradient(offset); });
    };
    if (ops.interior[row]) {
      accumulate(grid.dual_cell_centre(cell), cell_volume);
    } else if (at_centre[row]) {
      accumulate(grid.dual_cell_centre(cell), cell_fluid_volume(row));
    } else {
      for_each_volume_point(ops.cell_of_pressure[row], accumulate);
    }
  }
  // The rows' entries are counted, then written on the threads, each row at its place.
  std::vector<int> row_start(np + 1, 0);
#pragma omp parallel for schedule(dynamic, 1024)
  for (int row = 0; row < np; ++row) {
    const IVec<dim> cell = cells.multi_index(ops.cell_of_pressure[row]);
    int count = 0;
    for_each_offset<dim, 2>([&](const IVec<dim>& offset) { count += ops.dof_of_corner[corners.index(cell + offset)] >= 0 ? dim : 0; });
    row_start[row + 1] = count;
  }
  for (int row = 0; row < np; ++row) row_start[row + 1] += row_start[row];
  ops.gradient_transpose.resize(row_start[np]);
#pragma omp parallel for schedule(dynamic, 1024)
  for (int row = 0; row < np; ++row) {
    const IVec<dim> cell = cells.multi_index(ops.cell_of_pressure[row]);
    const Eigen::Matrix<Real, dim, (1 << dim)>& integral = integrals[row];
    int corner = 0, entry = row_start[row];
    for_each_offset<dim, 2>([&](const IVec<dim>& offset) {
      const int dof = ops.dof_of_corner[corners.index(cell + offset)];
      if (dof >= 0)
        for (int a = 0; a < dim; ++a) ops.gradient_transpose[entry++] = Triplet(row, dof * dim + a, -integral(a, corner));
      ++corner;
    });
  }
  // Corners inside a solid: their velocity is the solid's (the caller maps them).
  if (real_fluid_bins)
    for (int row = 0; row < np; ++row) {
      const IVec<dim> cell = cells.multi_index(ops.cell_of_pressure[row]);
      int corner = 0;
      for_each_offset<dim, 2>([&](const IVec<dim>& offset) {
        const int k = corners.index(cell + offset);
        if (ops.dof_of_corner[k] < 0) ops.solid_corner_gradient.push_back({row, k, -integrals[row].col(corner)});
        ++corner;
      });
    }

  // B rows: one face quadrature point per face between a fluid cell and a slip wall,
  // weight dx^(dim-1), outward normal of the fluid; N1 at the face centre is 2^(1-dim)
  // for each of the face's corners.
  const Real face_weight = cell_volume / grid.dx / Real(1 << (dim - 1));
  for (int row = 0; row < np; ++row) {
    const IVec<dim> cell = cells.multi_index(ops.cell_of_pressure[row]);
    for (int axis = 0; axis < dim; ++axis)
      for (int side = 0; side < 2; ++side) {
        const bool at_wall = side == 0 ? cell[axis] == 0 : cell[axis] == grid.cells[axis] - 1;
        if (!at_wall || !slip[axis][side]) continue;
        // A face none of whose corners is a fluid unknown (an interface cell whose corners
        // move with a solid touching the wall) has nothing to constrain: an empty row would
        // make the system singular.
        const int face_row = int(ops.wall_faces.size());
        const Real normal = side == 0 ? -1 : 1;
        const std::size_t before = ops.wall_rows.size();
        for_each_offset<dim, 2>([&](const IVec<dim>& offset) {
          if (offset[axis] != side) return;
          const int dof = ops.dof_of_corner[corners.index(cell + offset)];
          if (dof >= 0) ops.wall_rows.emplace_back(face_row, dof * dim + axis, face_weight * normal);
        });
        if (ops.wall_rows.size() > before) ops.wall_faces.push_back({ops.cell_of_pressure[row], {axis, side}});
      }
  }
  return ops;
}

}  // namespace iqmpm
