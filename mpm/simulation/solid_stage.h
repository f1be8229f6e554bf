// §3 step 2: v_s^n -> v_s* by projected Newton on the incremental potential
// (solid/incremental_potential.h, solid/projected_newton.h) of the scene's time
// integration (implicit Euler or the midpoint rule, method.md#solid-time-integration).
#pragma once

#include <fmt/format.h>

#include "core/errors.h"
#include "simulation/simulation.h"
#include "solid/solid_step.h"

namespace iqmpm {

// Clamped nodes are Dirichlet; a node whose quadratic support reaches through a slip wall
// (the outermost two node layers) and that moves into the wall has its normal component
// held at zero: free slip, no penetration, and separation allowed (method.md §1 walls).
// The held components stay held in the pressure solve (zero inverse mass).
template <int dim>
void Simulation<dim>::solve_solid_momentum(Real dt) {
  auto scope = timer_.scope("newton");
  const GridLayout<dim> nodes = grid_.nodes();
  SolidNodes<dim> state;
  state.mass = node_momentum_.mass;
  state.velocity.assign(nodes.size(), Vec<dim>::Zero());
  state.clamped = clamped_node_;
  state.fixed_axes.assign(nodes.size(), 0);
  for (int k = 0; k < nodes.size(); ++k) {
    if (!(state.mass[k] > 0)) continue;
    const Vec<dim> v = node_momentum_.momentum[k] / state.mass[k];
    state.velocity[k] = v;
    const IVec<dim> i = nodes.multi_index(k);
    for (int a = 0; a < dim; ++a) {
      if (slip_[a][0] && i[a] <= 0 && v[a] <= 0) state.fixed_axes[k] |= std::uint8_t(1u << a);
      if (slip_[a][1] && i[a] >= grid_.cells[a] - 1 && v[a] >= 0) state.fixed_axes[k] |= std::uint8_t(1u << a);
    }
  }
  // Weak nodes by extrapolation (method.md#weak-solid-nodes): in the midpoint rule's start
  // velocity and Newton here, in the pressure solve (assemble_pressure_system) and in the
  // final velocities (update_grid_velocities).
  weak_solid_nodes_ = options_.extend_weak_solid_nodes
                          ? find_weak_solid_nodes<dim>(grid_, solid_, state.mass, state.clamped, state.fixed_axes)
                          : WeakSolidNodes{};
  last_.extended_solid_nodes = weak_solid_nodes_.size();
  // The midpoint rule's start velocity: v^n before this step's gravity (P2G added dt g to
  // every node's momentum), the wall-held components at zero; a clamped node's is its
  // prescribed velocity, zero here (the scene's clamps hold still), as G2P's mean needs.
  const bool midpoint = options_.solid_time_integration == SolidTimeIntegration::midpoint;
  node_start_velocity_.clear();
  if (midpoint) {
    node_start_velocity_.assign(nodes.size(), Vec<dim>::Zero());
    for (int k = 0; k < nodes.size(); ++k) {
      if (!(state.mass[k] > 0) || (!state.clamped.empty() && state.clamped[k])) continue;
      node_start_velocity_[k] = state.velocity[k] - dt * step_gravity_;
      for (int a = 0; a < dim; ++a)
        if (state.fixed_axes[k] & (1u << a)) node_start_velocity_[k][a] = 0;
    }
    weak_solid_nodes_.extend(node_start_velocity_);
    state.start_velocity = node_start_velocity_;
  }
  // Every node with mass clamped (a fixed obstacle): nothing to solve, v* = 0.
  bool any_free = false;
  for (int k = 0; k < nodes.size() && !any_free; ++k) {
    const bool clamped = !state.clamped.empty() && state.clamped[k];
    any_free = state.mass[k] > 0 && !clamped;
  }
  solid_hessian_nodes_.clear();
  if (!any_free) {
    node_velocity_star_.assign(nodes.size(), Vec<dim>::Zero());
    wall_held_axes_ = std::move(state.fixed_axes);
    return;
  }
  SolidLinearisation linearisation;
  const NewtonResult result = solid_step(grid_, solid_, materials_, solid_.body, state, dt, options_.newton, node_velocity_star_,
                                         options_.solid_stiffness_in_solve ? &linearisation : nullptr,
                                         options_.solid_time_integration, &weak_solid_nodes_);
  last_.newton_iterations = result.iterations;
  last_.newton_cg_iterations = result.cg_iterations;
  if (!result.converged)
    throw NumericalFailure(fmt::format("solid Newton step did not converge: {}; try a smaller dt_max or cfl, or a "
                                       "larger newton.max_iterations", result.summary()));
  wall_held_axes_ = std::move(state.fixed_axes);
  // The linearisation of the step at v* for the coupled solve (pressure_system.h).
  solid_hessian_ = std::move(linearisation.hessian);
  solid_hessian_nodes_ = std::move(linearisation.nodes);
}

}  // namespace iqmpm
