// The particle stages of the step (method.md §3 steps 1, 3, 5, 6): sorting, interface
// quadrature, P2G, G2P and the optional position correction.
#pragma once

#include <cmath>
#include <fmt/format.h>
#include <limits>
#include <string>

#include "core/errors.h"
#include "fluid/position_correction.h"
#include "simulation/simulation.h"

namespace iqmpm {

template <int dim>
void Simulation<dim>::sort_particles() {
  auto scope = timer_.scope("sort");
  // A step that may be taken again keeps its start state: the arrays the sort replaces.
  const bool keep = step_start_.requested;
  if (has_fluid()) fluid_bins_ = sort_particles_by_cell(grid_, fluid_, keep ? &step_start_.fluid : nullptr);
  if (has_solids()) solid_bins_ = sort_particles_by_cell(grid_, solid_, keep ? &step_start_.solid : nullptr);
  step_start_.kept = keep;
  step_start_.requested = false;
}

// §3 step 3: IQ points, and the massless points that carry their borrowed fluid volume
// into G^f beside the (already sorted) fluid particles.
template <int dim>
void Simulation<dim>::find_interface_quadrature() {
  auto scope = timer_.scope("interface quadrature");
  iq_points_ = find_interface_points(grid_, fluid_, fluid_bins_, solid_, options_.interface_reach);
  if (iq_points_.empty()) return;
  borrowed_points_ = borrowed_fluid_points(grid_, fluid_, solid_, iq_points_);
  borrowed_point_bins_ = sort_particles_by_cell(grid_, borrowed_points_);
}

// §3 step 1: APIC P2G; gravity (this step's, under a ramp: time_step.h) enters the grid momentum.
template <int dim>
void Simulation<dim>::particles_to_grid(Real dt) {
  auto scope = timer_.scope("p2g");
  if (has_fluid()) {
    fluid_particles_to_grid(grid_, fluid_, fluid_bins_, corner_momentum_);
    for (std::size_t k = 0; k < corner_momentum_.mass.size(); ++k)
      corner_momentum_.momentum[k] += dt * corner_momentum_.mass[k] * step_gravity_;
  }
  if (has_solids()) {
    solid_particles_to_grid(grid_, solid_, solid_bins_, node_momentum_);
    for (std::size_t k = 0; k < node_momentum_.mass.size(); ++k)
      node_momentum_.momentum[k] += dt * node_momentum_.mass[k] * step_gravity_;
  }
}

// §3 step 5.
template <int dim>
void Simulation<dim>::grid_to_particles(Real dt) {
  auto scope = timer_.scope("g2p");
  if (has_fluid()) {
    fluid_grid_to_particles(grid_, corner_velocity_, dt, fluid_);
    keep_particles_in_domain(fluid_, "fluid");
  }
  if (!has_solids()) return;
  // Solid: v_p, C_p, F_p^{n+1} = (I + dt grad v) F_p^n; J_g = 1 - p_g / lambda_g from the
  // solved matrix pressure of the particle's dual cell (before it moves); then x += dt v.
  // The midpoint rule moves F and x with the step's mean velocity (u + v^{n+1}) / 2, the
  // configuration its Newton step balanced (solid/incremental_potential.h); v_p and C_p
  // stay those of v^{n+1}.
  const bool midpoint = !node_start_velocity_.empty();
  std::vector<Vec<dim>> start_velocity;
  if (options_.estimate_solid_step_error) start_velocity = solid_.velocity;
  std::vector<Mat<dim>> velocity_gradient;
  solid_grid_to_particles(grid_, node_velocity_, solid_, midpoint ? nullptr : &velocity_gradient);
  std::vector<Vec<dim>> displacement_velocity;
  if (midpoint) {
    std::vector<Vec<dim>> mean_velocity(node_velocity_.size());
    for (std::size_t k = 0; k < mean_velocity.size(); ++k)
      mean_velocity[k] = Real(0.5) * (node_start_velocity_[k] + node_velocity_[k]);
    interpolate_solid_velocity(grid_, mean_velocity, solid_, displacement_velocity, velocity_gradient);
  }
  const std::vector<Vec<dim>>& moving_velocity = displacement_velocity.empty() ? solid_.velocity : displacement_velocity;
  const GridLayout<dim> cells = grid_.dual_cells();
  const int n = int(solid_.size());
  Real min_J = std::numeric_limits<Real>::infinity();
#pragma omp parallel for schedule(static) reduction(min : min_J)
  for (int p = 0; p < n; ++p) {
    solid_.deformation_gradient[p] = (Mat<dim>::Identity() + dt * velocity_gradient[p]) * solid_.deformation_gradient[p];
    min_J = std::min(min_J, solid_.deformation_gradient[p].determinant());
    const int cell = cells.index(dual_cell_of<dim>(grid_.to_cells(solid_.position[p])));
    solid_.ghost_J[p] = 1 - ghost_pressure(cell) / ghost_stiffness_[solid_.body[p]];
    solid_.position[p] += dt * moving_velocity[p];
  }
  last_.solid_min_J = min_J;
  if (!(min_J > 0))
    throw NumericalFailure(fmt::format("a solid particle inverted (det F = {:.3g} <= 0): the step was too large for the "
                                       "solid's stiffness; lower dt_max or cfl", min_J));
  keep_particles_in_domain(solid_, "solid");
  if (options_.estimate_solid_step_error) {
    solid_step_error_ = measure_solid_step_error(solid_, start_velocity, dt, solid_step_error_, int(materials_.size()),
                                                 Real(0.1) * grid_.dx);
    last_.solid_step_error = solid_step_error_.relative;
  }
}

// §3 step 6 (fluid/position_correction.h). Without solids the correction's constraints
// are the rows of this step's system (p_f and walls, with the same M^f), so its matrix is
// A / dt and the pressure solve's factor serves it: A lambda = -target gives the
// displacement d = -dt M^-1 D^T lambda with D d = target (method.md#position-correction).
// With solids the correction has rows of its own (faces towards the body) and one more
// system is built after the particles moved. A corner moves at most half the particle
// spacing a step: the mass-weighted correction puts its displacement on the lightest
// corners, which without a bound pushed a particle a cell through a wall.
template <int dim>
void Simulation<dim>::correct_fluid_positions() {
  auto scope = timer_.scope("position correction");
  const Real largest_step = Real(0.5) * grid_.dx / scene_.particles_per_axis;
  if (has_solids()) {
    last_.correction_unknowns =
        iqmpm::correct_fluid_positions<dim>(grid_, fluid_, solid_, slip_, options_.walls_on_corners, options_.fluid_density,
                                            options_.position_correction, largest_step, options_.pressure_solver, cell_ordering_);
  } else {
    const std::vector<Real> target =
        position_correction_targets(grid_, ops_, ops_.interior, smoothed_particle_volume_per_cell(grid_, fluid_, false), options_.position_correction);
    Eigen::VectorXd rhs = Eigen::VectorXd::Zero(system_.size());
    for (int i = 0; i < ops_.pressure_unknowns(); ++i)
      if (!system_.vacant(layout_.pressure + i)) rhs[layout_.pressure + i] = -target[i];
    Eigen::VectorXd multipliers = Eigen::VectorXd::Zero(system_.size());
    const LinearSolveStats stats = pressure_solver_->solve_again(system_.matrix(), rhs, multipliers);
    if (!stats.converged || !multipliers.allFinite())
      throw NumericalFailure(fmt::format("position correction solve ({}) did not converge (relative residual {:.3g})",
                                         stats.method, stats.relative_residual));
    displace_fluid_particles(grid_, ops_, system_.corrected_velocity(Eigen::VectorXd::Zero(velocity_star_.size()), multipliers),
                             fluid_column_offset_, largest_step, fluid_);
  }
  keep_particles_in_domain(fluid_, "fluid");
}

// A particle pushed through a slip wall by round-off or a large step is put back just
// inside; one more than a cell beyond any side, or beyond a side without a wall, means the
// step was unstable and the run stops (method.md §9).
template <int dim>
void Simulation<dim>::keep_particles_in_domain(Particles<dim>& particles, const char* kind) {
  const Vec<dim> lower = grid_.origin, upper = grid_.upper();
  const Real margin = 1e-4 * grid_.dx;
  // Clamps particle p; false if it cannot be kept (not finite, or out through a side that
  // is not a slip wall or by more than a cell), with the reason in `why` if given.
  auto keep = [&](int p, int& clamps, std::string* why) {
    Vec<dim>& x = particles.position[p];
    if (!x.allFinite() || !particles.velocity[p].allFinite()) {
      if (why) *why = fmt::format("{} particle {} has a non-finite position or velocity (NaN): the step was unstable", kind, p);
      return false;
    }
    for (int a = 0; a < dim; ++a)
      for (int s = 0; s < 2; ++s) {
        const Real wall = s == 0 ? lower[a] : upper[a];
        const Real outside = s == 0 ? wall - x[a] : x[a] - wall;
        if (outside < -margin) continue;
        if (!slip_[a][s] || outside > grid_.dx) {
          if (why)
            *why = fmt::format("{} particle {} left the domain through side {}{} at {:.4g} m (wall at {:.4g} m){}", kind, p,
                               "xyz"[a], s == 0 ? '-' : '+', x[a], wall,
                               slip_[a][s] ? ": more than a cell beyond the wall in one step, lower cfl" : "");
          return false;
        }
        x[a] = s == 0 ? wall + margin : wall - margin;
        ++clamps;
      }
    return true;
  };
  // On the threads; a failure is reported for the first particle that fails, by index, as
  // one loop over the particles finds it (a failed step is undone or ends the run). Its
  // sides kept before the failing one are at the wall again, so a second pass over it
  // stops at the same side.
  const int n = int(particles.size());
  int first_failure = n, clamps = 0;
#pragma omp parallel for schedule(static) reduction(min : first_failure) reduction(+ : clamps)
  for (int p = 0; p < n; ++p)
    if (!keep(p, clamps, nullptr)) first_failure = std::min(first_failure, p);
  last_.wall_clamps += clamps;
  if (first_failure == n) return;
  std::string why;
  int ignored = 0;
  keep(first_failure, ignored, &why);
  throw NumericalFailure(why);
}

}  // namespace iqmpm
