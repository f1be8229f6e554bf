// The projection (method.md §4, §5): the operators of both materials and the interface,
// the pressure-only system A = dt D M^-1 D^T + C, its solve under the interface
// constraint, and the velocities it gives.
#pragma once

#include <fmt/format.h>

#include <algorithm>
#include <cassert>
#include <utility>

#include "core/errors.h"
#include "grid/nested_dissection.h"
#include "interface/interface_force.h"
#include "interface/solid_corners.h"
#include "simulation/simulation.h"

namespace iqmpm {

// §4: G^f, M^f, B (fluid); G^s, S (ghost matrix); H^s, H^f (interface), after both
// materials' dofs are numbered.
template <int dim>
void Simulation<dim>::build_operators() {
  if (has_fluid()) {
    auto scope = timer_.scope("fluid operators");
    FluidQuadratureOptions<dim> quadrature;
    quadrature.surface_cells_at_centre = options_.surface_cells_at_centre;
    solid_corners_.clear();
    if (!iq_points_.empty()) {
      // Corners reached only by borrowed fluid lie inside a solid and move with it, and so
      // do those well inside a solid (docs/method.md#solid-corners).
      quadrature.real_fluid_bins = &fluid_bins_;
      solid_corners_ = solid_corners<dim>(grid_, solid_, slip_, options_.solid_corner_fraction);
      if (!solid_corners_.empty()) quadrature.solid_corners = &solid_corners_;
      quadrature.volume_points = &borrowed_points_;
      quadrature.volume_point_bins = &borrowed_point_bins_;
    }
    ops_ = build_fluid_operators<dim>(grid_, fluid_, fluid_bins_, corner_momentum_, options_.fluid_density, slip_, quadrature);
  }
  if (has_solids()) {
    auto scope = timer_.scope("solid operators");
    solid_ops_ = build_solid_operators<dim>(grid_, solid_, solid_bins_, node_momentum_.mass, ghost_stiffness_);
  }
  if (!iq_points_.empty()) {
    auto scope = timer_.scope("interface quadrature");
    iq_ops_ = build_interface_operators(grid_, iq_points_, solid_, mass_reflected_across_walls<dim>(grid_, node_momentum_.mass, slip_),
                                        solid_ops_.dof_of_node, ops_.dof_of_corner, solid_ops_.velocity_dofs() * dim);
  }
  trapped_air_ = {};
  if (options_.trapped_air && has_fluid()) {
    auto scope = timer_.scope("fluid operators");
    const GridLayout<dim> cells = grid_.dual_cells();
    const bool solids = has_solids();
    auto holds_solid = [&](int cell) { return solids && solid_ops_.pressure_of_cell[cell] >= 0; };
    auto is_air = [&](int cell) { return ops_.pressure_of_cell[cell] < 0 && !holds_solid(cell); };
    // A boundary corner that is no fluid unknown moves with a solid when one of its cells
    // holds solid particles; otherwise it lies on a wall.
    auto moves_with_solid = [&](int corner) {
      bool found = false;
      const IVec<dim> c = grid_.corners().multi_index(corner);
      for_each_offset<dim, 2>([&](const IVec<dim>& offset) {
        const IVec<dim> cell = c - offset;
        if (cells.contains(cell) && holds_solid(cells.index(cell))) found = true;
      });
      return found;
    };
    const DomainSide up{up_axis_, gravity_[up_axis_] < 0 ? 1 : 0};
    trapped_air_ = find_trapped_air<dim>(grid_, ops_, up, is_air, moves_with_solid);
  }
  last_.air_pockets = trapped_air_.size();
  last_.air_pocket_cells = trapped_air_.largest();
}

// Row entries on fluid corners that move with a solid (no fluid unknowns), spread over the
// solid's velocity nodes by their N2 weights at the corner (stacked columns).
template <int dim>
std::vector<Triplet> entries_on_solid_nodes(const Grid<dim>& grid, const std::vector<typename FluidOperators<dim>::CornerEntry>& entries,
                                            const std::vector<int>& solid_dof_of_node) {
  std::vector<Triplet> on_solid;
  for (const auto& entry : entries)
    for_each_solid_weight(grid, grid.corners().multi_index(entry.corner), solid_dof_of_node, [&](int dof, Real weight) {
      for (int a = 0; a < dim; ++a) on_solid.emplace_back(entry.row, dof * dim + a, weight * entry.coefficient[a]);
    });
  return on_solid;
}

// §5: the stacked velocities are the solid nodes' (v_s*, after Newton) then the fluid
// corners' (v_f^n); the blocks are p_g (ghost matrix, G^sT with compliance S/dt and offset
// S p_g^n/dt), p_f (G^fT), y (B) and h (H^f v_f - H^s v_s), each present only when the
// scene needs it. A clamped node, or a component held by a wall, gets zero inverse mass:
// the solve cannot move it. With fluid.wall_constraint = corners a fluid corner on a slip
// wall is held likewise along the wall's normal, and there is no y block: the wall's
// force is the momentum it holds (docs/method.md#walls-on-corners).
template <int dim>
void Simulation<dim>::assemble_pressure_system(Real dt) {
  auto scope = timer_.scope("assembly");
  const int ns = has_solids() ? solid_ops_.velocity_dofs() : 0;
  const int nf = has_fluid() ? ops_.velocity_dofs() : 0;
  fluid_column_offset_ = ns * dim;
  Eigen::VectorXd inverse_mass((ns + nf) * dim);
  velocity_star_.resize((ns + nf) * dim);
  for (int d = 0; d < ns; ++d) {
    const int node = solid_ops_.node_of_dof[d];
    const bool clamped = !clamped_node_.empty() && clamped_node_[node];
    const Vec<dim>& v = node_velocity_star_[node];
    for (int a = 0; a < dim; ++a) {
      // A wall-held component is exactly zero after Newton and must stay so.
      const bool held = clamped || (wall_held_axes_[node] & (1u << a));
      inverse_mass[d * dim + a] = held ? 0 : 1 / node_momentum_.mass[node];
      velocity_star_[d * dim + a] = v[a];
    }
  }
  wall_holds_.clear();
  for (int d = 0; d < nf; ++d) {
    const int corner = ops_.corner_of_dof[d];
    // v^n from the APIC transfer (momentum / transferred mass); M^f from the quadrature.
    const Real transferred = corner_momentum_.mass[corner];
    Vec<dim> v = corner_momentum_.momentum[corner] / transferred;
    Real mass = ops_.mass[d];
    if (options_.inertia_from_transfer && ops_.exact_mass[d] && transferred > mass) {
      // Crowded particles (more mass at the corner than the water that fills its cells):
      // the corner's inertia is the mass they carry, so G2P hands them the impulse the
      // projection computed rather than transferred / M^f times it, which fed the
      // splashes. Gravity stays dt M^f g, which hydrostatic pressure balances exactly
      // however the particles lie (docs/method.md#fluid-inertia).
      v += dt * (mass / transferred - 1) * step_gravity_;
      mass = transferred;
    }
    for (int a = 0; a < dim; ++a) {
      const int column = fluid_column_offset_ + d * dim + a;
      const unsigned sides = options_.walls_on_corners ? ops_.wall_sides(d, a) : 0u;
      inverse_mass[column] = sides ? 0 : 1 / mass;
      velocity_star_[column] = sides ? 0 : v[a];
      if (sides) wall_holds_.push_back({column, a, sides & 1u ? 0 : 1, mass * v[a] / dt});
    }
  }
  auto weak_columns = weak_solid_node_columns(inverse_mass);
  system_.reset(inverse_mass);
  if (!weak_columns.empty()) system_.set_column_extension(std::move(weak_columns));
  if (!solid_hessian_nodes_.empty()) set_solid_mass_block();
  layout_ = SolutionLayout{};
  if (has_solids()) {
    std::vector<Real> compliance(solid_ops_.pressure_unknowns()), offset(solid_ops_.pressure_unknowns());
    for (int j = 0; j < solid_ops_.pressure_unknowns(); ++j) {
      compliance[j] = solid_ops_.compliance[j] / dt;
      offset[j] = solid_ops_.compliance[j] * solid_ops_.previous_pressure[j] / dt;
    }
    layout_.ghost = system_.unknowns();
    system_.add_block("p_g", solid_ops_.pressure_unknowns(), solid_ops_.gradient_transpose, compliance, offset);
  }
  if (has_fluid()) {
    layout_.pressure = system_.unknowns();
    const int block = system_.add_block("p_f", ops_.pressure_unknowns(), ops_.gradient_transpose, {}, {}, fluid_column_offset_);
    // Fluid corners inside a solid take the solid's velocity: their G^fT entries act on it.
    system_.add_entries(block, entries_on_solid_nodes(grid_, ops_.solid_corner_gradient, solid_ops_.dof_of_node));
    if (!options_.walls_on_corners && !ops_.wall_faces.empty()) {
      layout_.wall = system_.unknowns();
      system_.add_block("y", int(ops_.wall_faces.size()), ops_.wall_rows, {}, {}, fluid_column_offset_);
    }
  }
  if (!iq_points_.empty()) {  // rows H^f v_f - H^s v_s, columns already stacked
    layout_.interface = system_.unknowns();
    system_.add_block("h", iq_ops_.multipliers(), iq_ops_.rows);
  }
  if (trapped_air_.size() > 0) {  // rows -(d/dt of each pocket's volume), on fluid corners and solid nodes
    layout_.air = system_.unknowns();
    const int block = system_.add_block("p_a", trapped_air_.size(), trapped_air_.rows, {}, {}, fluid_column_offset_);
    system_.add_entries(block, entries_on_solid_nodes(grid_, trapped_air_.solid_corner_rows, solid_ops_.dof_of_node));
  }
  system_.assemble(dt);
  last_.pressure_unknowns = system_.unknowns();
  last_.velocity_unknowns = (ns + nf) * dim;
}

// The weak solid nodes (method.md#weak-solid-nodes): a weak node's velocity is its block's
// extrapolation, so the constraints' columns of a weak node move to its block nodes
// (PressureSystem::set_column_extension) and the block nodes carry the weak nodes' mass,
// lumped by the weights: m_j + sum_i e_ij m_i, the row sums of E^T M E, with which the
// solve changes the solid's momentum by exactly the constraints' impulse. A block node whose
// lumped mass would fall below half its own (large negative weights on a heavy weak node)
// takes m_j + sum_i e_ij^2 m_i instead, the diagonal of E^T M E, which is positive (there
// the momentum change is the impulse only approximately).
template <int dim>
std::vector<std::vector<std::pair<int, Real>>> Simulation<dim>::weak_solid_node_columns(Eigen::VectorXd& inverse_mass) const {
  std::vector<std::vector<std::pair<int, Real>>> columns;
  const WeakSolidNodes& weak = weak_solid_nodes_;
  if (weak.empty() || !has_solids()) return columns;
  assert(solid_hessian_nodes_.empty() && "solid_weak_nodes = extended with the solid's stiffness in the solve (scene.cpp rejects it)");
  const int ns = solid_ops_.velocity_dofs();
  columns.resize(std::size_t(ns) * dim);
  std::vector<Real> lumped(ns, 0), squared(ns, 0);
  std::vector<char> block(ns, 0);
  for (int i = 0; i < weak.size(); ++i) {
    const int w = solid_ops_.dof_of_node[weak.node[i]];
    assert(w >= 0);
    const Real m = node_momentum_.mass[weak.node[i]];
    for (int j = weak.parent_start[i]; j < weak.parent_start[i + 1]; ++j) {
      const int d = solid_ops_.dof_of_node[weak.parent[j]];
      assert(d >= 0);
      block[d] = 1;
      lumped[d] += weak.weight[j] * m;
      squared[d] += weak.weight[j] * weak.weight[j] * m;
      for (int a = 0; a < dim; ++a) columns[w * dim + a].emplace_back(d * dim + a, weak.weight[j]);
    }
    for (int a = 0; a < dim; ++a) inverse_mass[w * dim + a] = 0;
  }
  for (int d = 0; d < ns; ++d) {
    if (!block[d]) continue;
    const Real own = node_momentum_.mass[solid_ops_.node_of_dof[d]];
    const Real mass = own + (own + lumped[d] >= Real(0.5) * own ? lumped[d] : squared[d]);
    for (int a = 0; a < dim; ++a) inverse_mass[d * dim + a] = 1 / mass;  // block nodes hold no component
  }
  return columns;
}

// experimental.solid_response = stiffness: the free solid velocity entries take the Newton
// Hessian M^s + dt^2 K at v* as their mass in the solve (pressure_system.h). A component
// held by a wall stays out: its inverse mass is zero, the solve cannot move it.
template <int dim>
void Simulation<dim>::set_solid_mass_block() {
  const int n = int(solid_hessian_nodes_.size()) * dim;
  std::vector<int> reduced(n, -1), columns;
  for (int k = 0; k < n; ++k) {
    const int node = solid_hessian_nodes_[k / dim], a = k % dim;
    if (wall_held_axes_[node] & (1u << a)) continue;
    reduced[k] = int(columns.size());
    columns.push_back(solid_ops_.dof_of_node[node] * dim + a);
  }
  std::vector<Triplet> entries;
  for (int row = 0; row < n; ++row)
    for (typename decltype(solid_hessian_)::InnerIterator it(solid_hessian_, row); it; ++it)
      if (reduced[row] >= 0 && reduced[it.col()] >= 0) entries.emplace_back(reduced[row], reduced[it.col()], it.value());
  SparseMatrix mass(int(columns.size()), int(columns.size()));
  mass.setFromTriplets(entries.begin(), entries.end());
  system_.set_mass_block(std::move(columns), std::move(mass));
}

// §5 with the interface constraint: one solve (bilateral), or active-set rounds
// (unilateral, interface/unilateral_contact.h). The first starts from the warm start
// (solver.warm_start, pressure/warm_start.h), each later round from the round before.
template <int dim>
void Simulation<dim>::solve_with_interface_constraint() {
  if (options_.unilateral) {
    std::vector<int> p_rows_on_solid;
    for (const auto& entry : ops_.solid_corner_gradient) p_rows_on_solid.push_back(entry.row);
    contact_.start(system_, layout_.interface, iq_ops_.cell_of_multiplier, layout_.pressure, p_rows_on_solid, ops_.cell_of_pressure);
  }
  unknown_locations_ = locate_unknowns();
  Eigen::VectorXd rhs = system_.rhs(velocity_star_);
  // solver.ordering = cells or grid: the order for this step's pattern, which its rounds keep.
  const bool direct = linear_solver_kind(options_.pressure_solver, system_.size(), dim) != LinearSolverKind::pcg;
  if (direct && !cell_ordering_.empty() && !system_.has_mass_block()) {
    auto scope = timer_.scope("solve");  // the order is part of the direct solve's cost
    direct_order_ = cell_ordering_.order(dual_cell_of_unknowns());
  }
  if (direct) {
    lambda_.setZero(system_.size());  // a direct solve needs no guess
  } else {
    auto scope = timer_.scope("warm start");
    warm_start_.guess(unknown_locations_, system_.matrix(), rhs, time_, lambda_);
  }
  solve_pressure_system(rhs);
  while (options_.unilateral && contact_.update(system_, velocity_star_, lambda_, grid_.dual_cells().size())) {
    if (last_.contact_rounds == options_.max_contact_rounds) {
      last_.contact_settled = false;  // keep the last solve's (consistent) solution
      break;
    }
    ++last_.contact_rounds;
    system_.release(contact_.released_rows());  // same matrix pattern, released rows decoupled
    // The next solve's matrix differs from the last one in these rows only (an LDL^T
    // solver modifies its factor instead of factorising).
    pressure_solver_->expect_row_changes(contact_.take_newly_released(), contact_.take_newly_restored());
    rhs = system_.rhs(velocity_star_);
    solve_pressure_system(rhs);
  }
  warm_start_.remember(unknown_locations_, lambda_, time_);
}

// Where the unknowns of this step's system live on the grid (pressure/warm_start.h).
template <int dim>
UnknownLocations Simulation<dim>::locate_unknowns() const {
  const int cells = grid_.dual_cells().size();
  UnknownLocations where;
  where.offset = {layout_.ghost, layout_.pressure, layout_.wall, layout_.interface};
  where.locations = {cells, cells, cells * 2 * dim, cells};
  where.location[ghost_block] = solid_ops_.cell_of_pressure;
  where.location[pressure_block] = ops_.cell_of_pressure;
  where.location[interface_block] = iq_ops_.cell_of_multiplier;
  if (layout_.wall >= 0)
    for (const auto& face : ops_.wall_faces)
      where.location[wall_block].push_back(face.dual_cell * 2 * dim + face.wall.axis * 2 + face.wall.side);
  return where;
}

// One solve from lambda_ as the first guess; the solution replaces it.
template <int dim>
void Simulation<dim>::solve_pressure_system(const Eigen::VectorXd& rhs) {
  auto scope = timer_.scope("solve");
  // One solver kept across solves: a direct one reuses its symbolic analysis while the
  // pattern repeats (the active-set rounds of a step).
  if (!pressure_solver_ || pressure_solver_->kind() != linear_solver_kind(options_.pressure_solver, system_.size(), dim))
    pressure_solver_ = make_linear_solver(options_.pressure_solver, system_.size(), dim);
  if (!direct_order_.empty()) {
    pressure_solver_->suggest_order(std::move(direct_order_));
    direct_order_.clear();
  }
  // BoomerAMG on S A S (solver.amg_checkerboard_flip): the signs of this system's unknowns,
  // O(unknowns), against a hierarchy set up on every solve anyway.
  if (pressure_solver_->wants_checkerboard_signs()) pressure_solver_->suggest_checkerboard_signs(checkerboard_signs_of_unknowns());
  last_.linear = pressure_solver_->solve(system_.matrix(), rhs, lambda_);
  last_.modified_solves += last_.linear.modified_rows > 0;
  if (!last_.linear.converged || !lambda_.allFinite())
    throw NumericalFailure(fmt::format(
        "pressure solve ({}) did not converge: relative residual {:.3g} after {} iterations (tolerance {:.1g}, {} unknowns); "
        "try solver.method=cholmod, a smaller cfl, or a larger solver.max_iterations",
        last_.linear.method, last_.linear.relative_residual, last_.linear.iterations, options_.pressure_solver.tolerance,
        system_.unknowns()));
}

// §5: v^{n+1} = v* - dt M^-1 D^T lambda.
template <int dim>
void Simulation<dim>::update_grid_velocities() {
  auto scope = timer_.scope("velocity update");
  const Eigen::VectorXd constraint_force = system_.constraint_force(lambda_);
  velocity_next_ = system_.corrected_velocity(velocity_star_, lambda_, constraint_force);
  measure_wall_forces(constraint_force);
  if (has_fluid()) {
    corner_velocity_.assign(grid_.corners().size(), Vec<dim>::Zero());
    for (int d = 0; d < ops_.velocity_dofs(); ++d)
      for (int a = 0; a < dim; ++a)
        corner_velocity_[ops_.corner_of_dof[d]][a] = velocity_next_[fluid_column_offset_ + d * dim + a];
  }
  if (has_solids()) {
    node_velocity_ = node_velocity_star_;
    for (int d = 0; d < solid_ops_.velocity_dofs(); ++d)
      for (int a = 0; a < dim; ++a) node_velocity_[solid_ops_.node_of_dof[d]][a] = velocity_next_[d * dim + a];
    if (!weak_solid_nodes_.empty()) {  // the weak nodes' v^{n+1} is their blocks' (v* + nothing in the solve)
      weak_solid_nodes_.extend(node_velocity_);
      for (int k : weak_solid_nodes_.node)
        for (int a = 0; a < dim; ++a) velocity_next_[solid_ops_.dof_of_node[k] * dim + a] = node_velocity_[k][a];
    }
    // A fluid particle that strayed inside a solid takes the solid's velocity from the
    // corners that move with it (coupling.solid_corner_fraction).
    if (has_fluid() && !solid_corners_.empty()) {
      const GridLayout<dim> corners = grid_.corners();
      for (int k = 0; k < corners.size(); ++k) {
        if (!solid_corners_[k] || ops_.dof_of_corner[k] >= 0) continue;
        Vec<dim> v = Vec<dim>::Zero();
        for_each_solid_weight(grid_, corners.multi_index(k), solid_ops_.dof_of_node,
                              [&](int dof, Real weight) { v += weight * node_velocity_[solid_ops_.node_of_dof[dof]]; });
        corner_velocity_[k] = v;
      }
    }
  }
}

// §7 (interface/interface_force.h): the coupling rows' force, before the particles move.
template <int dim>
void Simulation<dim>::measure_interface_forces() {
  if (layout_.interface < 0) {
    particle_force_.assign(solid_.size(), Vec<dim>::Zero());
    return;
  }
  const Eigen::VectorXd acting = system_.acting_multipliers(lambda_);
  Eigen::VectorXd coupling = Eigen::VectorXd::Zero(system_.unknowns());
  coupling.segment(layout_.interface, iq_ops_.multipliers()) = acting.segment(layout_.interface, iq_ops_.multipliers());
  if (!ops_.solid_corner_gradient.empty())
    coupling.segment(layout_.pressure, ops_.pressure_unknowns()) = acting.segment(layout_.pressure, ops_.pressure_unknowns());
  if (layout_.air >= 0 && !trapped_air_.solid_corner_rows.empty())  // trapped air pushing on a solid
    coupling.segment(layout_.air, trapped_air_.size()) = acting.segment(layout_.air, trapped_air_.size());
  const Eigen::VectorXd nodal = -(system_.constraint().transpose() * coupling);
  particle_force_ = interface_force_on_particles(grid_, solid_, node_momentum_.mass, solid_ops_, nodal);
}

// (-1)^(i+j[+k]) of each unknown's dual cell (docs/method.md#linear-solver: the Q1-P0
// checkerboard becomes smooth in S A S). An unknown of a cell (p_g, p_f, a wall face's y, the
// interface's h) takes its cell's sign; one without a cell (a solid velocity row) +1.
template <int dim>
std::vector<signed char> Simulation<dim>::checkerboard_signs_of_unknowns() const {
  const std::vector<int> cell = dual_cell_of_unknowns();
  const GridLayout<dim> cells = grid_.dual_cells();
  std::vector<signed char> signs(cell.size(), 1);
  for (std::size_t u = 0; u < cell.size(); ++u)
    if (cell[u] >= 0 && cells.multi_index(cell[u]).sum() % 2 != 0) signs[u] = -1;
  return signs;
}

template <int dim>
std::vector<int> Simulation<dim>::dual_cell_of_unknowns() const {
  std::vector<int> cell(system_.size(), -1);
  auto place = [&](int offset, const std::vector<int>& cells) {
    if (offset >= 0) std::copy(cells.begin(), cells.end(), cell.begin() + offset);
  };
  place(layout_.ghost, solid_ops_.cell_of_pressure);
  place(layout_.pressure, ops_.cell_of_pressure);
  if (layout_.wall >= 0)
    for (std::size_t f = 0; f < ops_.wall_faces.size(); ++f) cell[layout_.wall + f] = ops_.wall_faces[f].dual_cell;
  place(layout_.interface, iq_ops_.cell_of_multiplier);
  place(layout_.air, trapped_air_.cell_of_pocket());
  return cell;
}

template <int dim>
bool Simulation<dim>::has_fluid_pressure(int dual_cell) const {
  return layout_.pressure >= 0 && !ops_.pressure_of_cell.empty() && lambda_.size() > 0 && ops_.pressure_of_cell[dual_cell] >= 0;
}

template <int dim>
Real Simulation<dim>::fluid_pressure(int dual_cell) const {
  if (layout_.pressure < 0 || ops_.pressure_of_cell.empty() || lambda_.size() == 0) return 0;
  const int i = ops_.pressure_of_cell[dual_cell];
  return i >= 0 ? lambda_[layout_.pressure + i] : 0;
}

template <int dim>
Real Simulation<dim>::ghost_pressure(int dual_cell) const {
  if (layout_.ghost < 0 || solid_ops_.pressure_of_cell.empty() || lambda_.size() == 0) return 0;
  const int j = solid_ops_.pressure_of_cell[dual_cell];
  return j >= 0 ? lambda_[layout_.ghost + j] : 0;
}

// The force of the fluid on each slip wall along its axis. Walls on the corners: a held
// component's momentum balance m v^{n+1} = m v* - dt (D^T lambda) + dt R with v^{n+1} = 0
// gives the wall's reaction R, and the fluid pushes with -R = m v*/dt - D^T lambda. Wall
// faces: sum_k y_k |face_k| n_k (n: the fluid's outward normal).
template <int dim>
void Simulation<dim>::measure_wall_forces(const Eigen::VectorXd& constraint_force) {
  for (auto& sides : wall_force_) sides = {0, 0};
  if (!has_fluid() || lambda_.size() == 0) return;
  if (options_.walls_on_corners) {
    if (wall_holds_.empty()) return;
    for (const auto& hold : wall_holds_) wall_force_[hold.axis][hold.side] += hold.force_to_stop - constraint_force[hold.column];
    return;
  }
  if (layout_.wall < 0) return;
  const Real face_area = grid_.cell_volume() / grid_.dx;
  for (std::size_t f = 0; f < ops_.wall_faces.size(); ++f) {
    const DomainSide wall = ops_.wall_faces[f].wall;
    wall_force_[wall.axis][wall.side] += lambda_[layout_.wall + int(f)] * face_area * (wall.side == 0 ? -1 : 1);
  }
}

}  // namespace iqmpm
