// Optional position correction of the fluid particles (experimental.position_correction;
// method.md §3 step 6): particles drift into clusters and gaps because the projection
// makes the grid velocity divergence-free, not the particle flow. One extra solve with the
// same operators finds the smallest (mass-weighted) displacement field d of the corners with
//   integral over cell i of div d = relaxation (phi_i - 1) dx^dim,  B d = 0,
// phi_i the particles' volume fraction in cell i, spread with multilinear weights
// (smoothed_particle_volume_per_cell) and, in interior cells, averaged over the interior
// cells around with weights 1-2-1 per axis; cells next to empty space are only expanded
// (phi > 1), never compressed, since they may be partly empty. Particles then move by the
// N1 interpolation of d. The wall rows keep them off the walls.
// Why both filters: D cannot produce a checkerboard of cell volumes (Q1-P0), so the
// smallest d asked for one is as large as A is nearly singular; a count per cell, which
// jumps as particles cross faces, feeds such patterns back every step. Without them the
// correction ran away at a/64 within ten steps (method.md#position-correction).
// With solids, phi counts the solid particles' current volume too (the reference code
// does the same), so water crowded against or into a body is spread back out, and a
// fluid cell's face towards a cell that is at least half solid and holds no fluid gets a
// wall row (no displacement through it), so the correction never pushes water into a body:
// correct_fluid_positions builds that system. Without solids the rows are the pressure
// system's own, and the simulation solves them with the step's factor
// (Simulation::correct_fluid_positions, method.md#position-correction).
#pragma once

#include <algorithm>
#include <array>
#include <fmt/format.h>
#include <vector>

#include "core/errors.h"
#include "fluid/fluid_operators.h"
#include "grid/nested_dissection.h"
#include "linear_solver/linear_solver.h"
#include "particles/volume_per_cell.h"
#include "pressure/pressure_system.h"
#include "transfer/apic.h"

namespace iqmpm {

// Per pressure row of `ops`: the target of G^fT d = -integral of div d over the cell,
// -relaxation (phi - 1) dx^dim, phi the volume in the cell (`volume`, per dual cell) over
// the cell's. In a full cell (`full`, per pressure row: no empty space in its 3^dim block)
// phi - 1 is the 1-2-1 weighted mean over the full cells of its block, which has no
// checkerboard part; cells next to empty space may be partly empty: their own phi - 1,
// only expanded, never compressed.
template <int dim>
std::vector<Real> position_correction_targets(const Grid<dim>& grid, const FluidOperators<dim>& ops,
                                              const std::vector<char>& full, const std::vector<Real>& volume,
                                              Real relaxation) {
  const Real cell_volume = grid.cell_volume();
  const int np = ops.pressure_unknowns();
  std::vector<Real> excess(np);
#pragma omp parallel for schedule(static)
  for (int i = 0; i < np; ++i) excess[i] = volume[ops.cell_of_pressure[i]] / cell_volume - 1;
  const GridLayout<dim> cells = grid.dual_cells();
  std::vector<Real> target(np, 0);
#pragma omp parallel for schedule(dynamic, 1024)
  for (int i = 0; i < np; ++i) {
    Real e = 0;
    if (full[i]) {
      const IVec<dim> cell = cells.multi_index(ops.cell_of_pressure[i]);
      Real weight_sum = 0;
      for_each_offset<dim, 3>([&](const IVec<dim>& o) {
        const IVec<dim> neighbour = cell + o - IVec<dim>::Ones();
        if (!cells.contains(neighbour)) return;
        const int j = ops.pressure_of_cell[cells.index(neighbour)];
        if (j < 0 || !full[j]) return;
        Real w = 1;
        for (int a = 0; a < dim; ++a) w *= o[a] == 1 ? 2 : 1;
        e += w * excess[j], weight_sum += w;
      });
      e /= weight_sum;
    } else {
      e = std::max(excess[i], Real(0));
    }
    target[i] = -relaxation * e * cell_volume;
  }
  return target;
}

// Moves each fluid particle by the N1 interpolation of the corner displacement d, stacked
// per fluid velocity unknown of `ops` from `offset` on, each corner's at most
// `largest_step` long.
// A corner without an unknown does not move; the particles' corners are found through
// ops.dof_of_corner, not a displacement array over the whole grid (zeroing and filling
// one took as long as moving the particles at a/128).
template <int dim>
void displace_fluid_particles(const Grid<dim>& grid, const FluidOperators<dim>& ops, const Eigen::VectorXd& displacement,
                              int offset, Real largest_step, Particles<dim>& fluid) {
  const GridLayout<dim> corners = grid.corners();
  std::vector<Vec<dim>> dof_displacement(ops.velocity_dofs());
#pragma omp parallel for schedule(static)
  for (int d = 0; d < ops.velocity_dofs(); ++d) {
    Vec<dim>& step = dof_displacement[d];
    for (int a = 0; a < dim; ++a) step[a] = displacement[offset + d * dim + a];
    if (step.norm() > largest_step) step *= largest_step / step.norm();
  }
  const int n = int(fluid.size());
#pragma omp parallel for schedule(static)
  for (int p = 0; p < n; ++p) {
    const auto stencil = linear_stencil<dim>(grid.to_cells(fluid.position[p]), grid.dx);
    Vec<dim> shift = Vec<dim>::Zero();
    for_each_offset<dim, 2>([&](const IVec<dim>& o) {
      const int d = ops.dof_of_corner[corners.index(stencil.base + o)];
      if (d >= 0) shift += stencil.weight(o) * dof_displacement[d];
    });
    fluid.position[p] += shift;
  }
}

// Moves the fluid particles (and sorts them by cell), each corner by at most
// `largest_step`; the caller keeps them in the domain. With `walls_on_corners` a wall
// corner's normal displacement is held (zero inverse mass) instead of a row per wall face,
// as in the step's own system (method.md#walls-on-corners): in 3-D the face rows made the
// correction's CG take 7x the iterations of the pressure solve. A direct solve eliminates
// the unknowns in `cell_ordering`'s order of their cells (as the step's own solve; empty:
// AMD on each new pattern). Returns the number of unknowns of its system.
template <int dim>
int correct_fluid_positions(const Grid<dim>& grid, Particles<dim>& fluid, const Particles<dim>& solid,
                            const std::array<std::array<bool, 2>, dim>& slip, bool walls_on_corners, Real density,
                            Real relaxation, Real largest_step, const LinearSolverOptions& solver_options,
                            const CellOrdering<dim>& cell_ordering) {
  const ParticleBins<dim> bins = sort_particles_by_cell(grid, fluid);
  GridMomentum<dim> momentum;
  fluid_particles_to_grid(grid, fluid, bins, momentum);
  const FluidOperators<dim> ops = build_fluid_operators<dim>(grid, fluid, bins, momentum, density, slip);
  const int nv = ops.velocity_dofs(), np = ops.pressure_unknowns();
  const Real cell_volume = grid.cell_volume();
  const GridLayout<dim> cells = grid.dual_cells();
  const bool has_solids = !solid.empty();
  const std::vector<Real> solid_volume = has_solids ? particle_volume_per_cell(grid, solid, true) : std::vector<Real>();
  // A cell the solids fill at least half: a wall for the water (its faces get rows) and, for
  // the filter, a full cell.
  const auto mostly_solid = [&](int k) { return solid_volume[k] >= Real(0.5) * cell_volume; };
  // Faces between a fluid cell and a (mostly) solid cell without fluid: no displacement.
  std::vector<Triplet> solid_face_rows;
  std::vector<int> solid_face_cell;  // the fluid cell of each solid face row
  int solid_faces = 0;
  if (has_solids) {
    const GridLayout<dim> corners = grid.corners();
    const Real face_weight = cell_volume / grid.dx / Real(1 << (dim - 1));
    for (int i = 0; i < np; ++i) {
      const IVec<dim> cell = cells.multi_index(ops.cell_of_pressure[i]);
      for (int axis = 0; axis < dim; ++axis)
        for (int side = 0; side < 2; ++side) {
          IVec<dim> neighbour = cell;
          neighbour[axis] += side == 0 ? -1 : 1;
          if (!cells.contains(neighbour)) continue;
          const int k = cells.index(neighbour);
          if (ops.pressure_of_cell[k] >= 0 || !mostly_solid(k)) continue;
          const Real normal = side == 0 ? -1 : 1;
          const std::size_t before = solid_face_rows.size();
          for_each_offset<dim, 2>([&](const IVec<dim>& offset) {
            if (offset[axis] != side) return;
            const int dof = ops.dof_of_corner[corners.index(cell + offset)];
            if (dof >= 0) solid_face_rows.emplace_back(solid_faces, dof * dim + axis, face_weight * normal);
          });
          if (solid_face_rows.size() > before) {  // an empty row would be singular
            ++solid_faces;
            solid_face_cell.push_back(ops.cell_of_pressure[i]);
          }
        }
    }
  }
  std::vector<Real> volume = smoothed_particle_volume_per_cell(grid, fluid, false);
  if (has_solids) {
    const std::vector<Real> smoothed_solid_volume = smoothed_particle_volume_per_cell(grid, solid, true);
    for (std::size_t k = 0; k < volume.size(); ++k) volume[k] += smoothed_solid_volume[k];
  }
  // A cell next to the body is full, not partly empty: phi counts the body's volume. Left
  // one-sided (expanded only) it pushed water off the body every step and never drew it
  // back, so the body rode on a depleted layer, more so the more steps a second
  // (method.md#position-correction).
  std::vector<char> full = ops.interior;
  if (has_solids) {
    const auto occupied = [&](int k) { return ops.pressure_of_cell[k] >= 0 || mostly_solid(k); };
    for (int i = 0; i < np; ++i) full[i] = is_interior_cell<dim>(cells, cells.multi_index(ops.cell_of_pressure[i]), occupied);
  }
  std::vector<Real> target = position_correction_targets(grid, ops, full, volume, relaxation);
  const int wall_rows = walls_on_corners ? 0 : int(ops.wall_faces.size());
  target.resize(np + wall_rows + solid_faces, 0);
  Eigen::VectorXd inverse_mass(nv * dim);
  for (int d = 0; d < nv; ++d)
    for (int a = 0; a < dim; ++a) {
      const bool held = walls_on_corners && ops.wall_sides(d, a) != 0;
      inverse_mass[d * dim + a] = held ? 0 : 1 / ops.mass[d];
    }
  PressureSystem correction;
  correction.reset(inverse_mass);
  correction.add_block("p_f", np, ops.gradient_transpose);
  if (wall_rows > 0) correction.add_block("y", wall_rows, ops.wall_rows);
  if (solid_faces > 0) correction.add_block("solid faces", solid_faces, solid_face_rows);
  correction.assemble(1);
  // d = 0 - M^-1 D^T q with A q = -target gives D d = target.
  Eigen::VectorXd rhs = -Eigen::Map<const Eigen::VectorXd>(target.data(), Eigen::Index(target.size()));
  Eigen::VectorXd q;
  auto solver = make_linear_solver(solver_options, correction.unknowns(), dim);
  if (solver->kind() != LinearSolverKind::pcg && !cell_ordering.empty()) {
    // The cell of each unknown: p_f rows, then wall rows, then solid-face rows.
    std::vector<int> cell_of_unknown(ops.cell_of_pressure.begin(), ops.cell_of_pressure.end());
    for (int k = 0; k < wall_rows; ++k) cell_of_unknown.push_back(ops.wall_faces[k].dual_cell);
    cell_of_unknown.insert(cell_of_unknown.end(), solid_face_cell.begin(), solid_face_cell.end());
    solver->suggest_order(cell_ordering.order(cell_of_unknown));
  }
  const auto stats = solver->solve(correction.matrix(), rhs, q);
  if (!stats.converged || !q.allFinite())
    throw NumericalFailure(fmt::format("position correction solve did not converge (relative residual {:.3g})", stats.relative_residual));
  displace_fluid_particles(grid, ops, correction.corrected_velocity(Eigen::VectorXd::Zero(nv * dim), q), 0, largest_step,
                           fluid);
  return correction.unknowns();
}

}  // namespace iqmpm
