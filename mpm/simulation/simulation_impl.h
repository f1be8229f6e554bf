// Implementation of Simulation<dim>; instantiated for 2 and 3 in simulation_2d.cpp and
// simulation_3d.cpp.
#pragma once

#include <cmath>
#include <fmt/format.h>

#include "core/errors.h"
#include "simulation/seeding.h"
#include "simulation/simulation.h"

namespace iqmpm {

template <int dim>
Simulation<dim>::Simulation(const SceneSpec& scene) : scene_(scene) {
  Vec<dim> lower, upper;
  for (int a = 0; a < dim; ++a) {
    lower[a] = scene.domain_min[a];
    upper[a] = scene.domain_max[a];
    gravity_[a] = scene.gravity[a];
  }
  grid_ = Grid<dim>(lower, upper, scene.dx);
  gravity_.cwiseAbs().maxCoeff(&up_axis_);
  for (int a = 0; a < dim; ++a)
    for (int s = 0; s < 2; ++s) slip_[a][s] = scene.walls[a][s] == "slip";
  fluid_density_ = scene.fluid.density;
  Vec<dim> v0;
  for (int a = 0; a < dim; ++a) v0[a] = scene.fluid.initial_velocity[a];
  seed_particles<dim>(grid_, scene.fluid.shapes, scene.particles_per_axis, scene.jitter, scene.seed,
                      fluid_density_, v0, fluid_);
  if (fluid_.empty())
    throw InputError("scene key 'fluid.shapes': no particle was seeded (the shapes lie outside the domain or are thinner than a particle spacing)");
  for (const auto& x : fluid_.position)
    if (!grid_.dual_cells().contains(dual_cell_of<dim>(grid_.to_cells(x))))
      throw InputError("scene key 'fluid.shapes': a shape reaches outside the domain");
}

template <int dim>
Real Simulation<dim>::stable_dt() const {
  Real max_speed = 0;
  for (const auto& v : fluid_.velocity) max_speed = std::max(max_speed, v.norm());
  // A particle at rest gains sqrt(|g| dx) falling one cell: the floor keeps the first steps safe.
  const Real speed = std::max(max_speed, std::sqrt(gravity_.norm() * grid_.dx));
  Real dt = speed > 0 ? scene_.cfl * grid_.dx / speed : scene_.dt_max;
  return std::min(dt, scene_.dt_max);
}

template <int dim>
void Simulation<dim>::step(Real dt) {
  if (dt < scene_.dt_min)
    throw NumericalFailure(fmt::format("time step {:.3g} s below dt_min {:.3g} s", dt, scene_.dt_min));
  sort_particles();
  particles_to_grid(dt);
  build_fluid_operators();
  assemble_pressure_system(dt);
  solve_pressure_system();
  update_grid_velocities();
  grid_to_particles(dt);
  if (scene_.fluid.position_correction > 0) correct_particle_positions();
}

template <int dim>
void Simulation<dim>::sort_particles() {
  auto scope = timer_.scope("sort");
  fluid_bins_ = sort_particles_by_cell(grid_, fluid_);
}

// §3 step 1: APIC P2G; gravity enters the grid momentum.
template <int dim>
void Simulation<dim>::particles_to_grid(Real dt) {
  auto scope = timer_.scope("p2g");
  fluid_particles_to_grid(grid_, fluid_, fluid_bins_, corner_momentum_);
  for (std::size_t k = 0; k < corner_momentum_.mass.size(); ++k)
    corner_momentum_.momentum[k] += dt * corner_momentum_.mass[k] * gravity_;
}

template <int dim>
void Simulation<dim>::build_fluid_operators() {
  auto scope = timer_.scope("fluid operators");
  ops_ = iqmpm::build_fluid_operators<dim>(grid_, fluid_, fluid_bins_, corner_momentum_, fluid_density_, slip_,
                                                scene_.fluid.surface_quadrature == "centre");
}

// §5: blocks p_f (G^fT) and y (B); the solid blocks are added here when a scene has solids.
template <int dim>
void Simulation<dim>::assemble_pressure_system(Real dt) {
  auto scope = timer_.scope("assembly");
  const int nv = ops_.velocity_dofs();
  Eigen::VectorXd inverse_mass(nv * dim);
  velocity_star_.resize(nv * dim);
  for (int d = 0; d < nv; ++d) {
    const int corner = ops_.corner_of_dof[d];
    // v^n from the APIC transfer (momentum / transferred mass); M^f from the quadrature.
    const Vec<dim> v = corner_momentum_.momentum[corner] / corner_momentum_.mass[corner];
    for (int a = 0; a < dim; ++a) {
      inverse_mass[d * dim + a] = 1 / ops_.mass[d];
      velocity_star_[d * dim + a] = v[a];
    }
  }
  system_.reset(inverse_mass);
  system_.add_block("p_f", ops_.pressure_unknowns(), ops_.gradient_transpose);
  if (!ops_.wall_faces.empty()) system_.add_block("y", int(ops_.wall_faces.size()), ops_.wall_rows);
  system_.assemble(dt);
  last_.pressure_unknowns = system_.unknowns();
  last_.velocity_unknowns = nv * dim;
}

template <int dim>
void Simulation<dim>::solve_pressure_system() {
  auto scope = timer_.scope("solve");
  const Eigen::VectorXd rhs = system_.rhs(velocity_star_);
  // Warm start from the previous step's solution, matched by dual cell and wall face.
  const int np = ops_.pressure_unknowns();
  Eigen::VectorXd x(system_.unknowns());
  for (int i = 0; i < np; ++i)
    x[i] = previous_pressure_.empty() ? 0 : previous_pressure_[ops_.cell_of_pressure[i]];
  for (std::size_t f = 0; f < ops_.wall_faces.size(); ++f) {
    const auto& face = ops_.wall_faces[f];
    auto it = previous_wall_.find({face.dual_cell, face.wall.axis * 2 + face.wall.side});
    x[np + f] = it == previous_wall_.end() ? 0 : it->second;
  }
  auto solver = make_linear_solver(scene_.solver, system_.unknowns(), dim);
  last_.linear = solver->solve(system_.matrix(), rhs, x);
  if (!last_.linear.converged || !x.allFinite())
    throw NumericalFailure(fmt::format(
        "pressure solve ({}) did not converge: relative residual {:.3g} after {} iterations (tolerance {:.1g}, {} unknowns); "
        "try solver.method=cholmod, a smaller cfl, or a larger solver.max_iterations",
        last_.linear.method, last_.linear.relative_residual, last_.linear.iterations, scene_.solver.tolerance,
        system_.unknowns()));
  lambda_ = x;
  previous_pressure_.assign(grid_.dual_cells().size(), 0);
  for (int i = 0; i < np; ++i) previous_pressure_[ops_.cell_of_pressure[i]] = x[i];
  previous_wall_.clear();
  for (std::size_t f = 0; f < ops_.wall_faces.size(); ++f) {
    const auto& face = ops_.wall_faces[f];
    previous_wall_[{face.dual_cell, face.wall.axis * 2 + face.wall.side}] = x[np + f];
  }
}

// §5: v^{n+1} = v* - dt M^-1 D^T lambda.
template <int dim>
void Simulation<dim>::update_grid_velocities() {
  auto scope = timer_.scope("velocity update");
  velocity_next_ = system_.corrected_velocity(velocity_star_, lambda_);
  corner_velocity_.assign(grid_.corners().size(), Vec<dim>::Zero());
  for (int d = 0; d < ops_.velocity_dofs(); ++d)
    for (int a = 0; a < dim; ++a) corner_velocity_[ops_.corner_of_dof[d]][a] = velocity_next_[d * dim + a];
}

// §3 step 5.
template <int dim>
void Simulation<dim>::grid_to_particles(Real dt) {
  auto scope = timer_.scope("g2p");
  fluid_grid_to_particles(grid_, corner_velocity_, dt, fluid_);
  keep_particles_in_domain();
}

// A particle pushed through a slip wall by round-off or a large step is put back just
// inside; one more than a cell beyond any side, or beyond a side without a wall, means the
// step was unstable and the run stops (method.md §9).
template <int dim>
void Simulation<dim>::keep_particles_in_domain() {
  const Vec<dim> lower = grid_.origin, upper = grid_.upper();
  const Real margin = 1e-4 * grid_.dx;
  int clamps = 0;
  for (std::size_t p = 0; p < fluid_.size(); ++p) {
    Vec<dim>& x = fluid_.position[p];
    if (!x.allFinite() || !fluid_.velocity[p].allFinite())
      throw NumericalFailure(fmt::format("fluid particle {} has a non-finite position or velocity (NaN): the step was unstable", p));
    for (int a = 0; a < dim; ++a)
      for (int s = 0; s < 2; ++s) {
        const Real wall = s == 0 ? lower[a] : upper[a];
        const Real outside = s == 0 ? wall - x[a] : x[a] - wall;
        if (outside < -margin) continue;
        if (!slip_[a][s] || outside > grid_.dx)
          throw NumericalFailure(fmt::format(
              "fluid particle {} left the domain through side {}{} at {:.4g} m (wall at {:.4g} m){}", p, "xyz"[a],
              s == 0 ? '-' : '+', x[a], wall, slip_[a][s] ? ": more than a cell beyond the wall in one step, lower cfl" : ""));
        x[a] = s == 0 ? wall + margin : wall - margin;
        ++clamps;
      }
  }
  last_.wall_clamps = clamps;
}

// Optional position correction (method.md §3 step 6): particles drift into clusters and
// gaps because the projection makes the grid velocity divergence-free, not the particle
// flow. One extra solve with the same operators finds the smallest (mass-weighted)
// displacement field d of the corners with
//   integral over cell i of div d = relaxation (phi_i - 1) dx^dim,  B d = 0,
// phi_i the particles' volume fraction in cell i; cells next to empty space are only
// expanded (phi > 1), never compressed, since they may be partly empty. Particles then
// move by the N1 interpolation of d. The wall rows keep them off the walls.
template <int dim>
void Simulation<dim>::correct_particle_positions() {
  auto scope = timer_.scope("position correction");
  fluid_bins_ = sort_particles_by_cell(grid_, fluid_);
  fluid_particles_to_grid(grid_, fluid_, fluid_bins_, corner_momentum_);
  const FluidOperators<dim> ops = iqmpm::build_fluid_operators<dim>(grid_, fluid_, fluid_bins_, corner_momentum_,
                                                                    fluid_density_, slip_, false);
  const int nv = ops.velocity_dofs(), np = ops.pressure_unknowns();
  const Real cell_volume = grid_.cell_volume();
  std::vector<Real> target(np + ops.wall_faces.size(), 0);
  for (int i = 0; i < np; ++i) {
    const int cell = ops.cell_of_pressure[i];
    Real volume = 0;
    for (int p = fluid_bins_.begin(cell); p < fluid_bins_.end(cell); ++p) volume += fluid_.initial_volume[p];
    Real excess = volume / cell_volume - 1;
    if (!ops.interior[i]) excess = std::max(excess, Real(0));
    // G^fT d = -integral of div d.
    target[i] = -scene_.fluid.position_correction * excess * cell_volume;
  }
  Eigen::VectorXd inverse_mass(nv * dim);
  for (int d = 0; d < nv; ++d)
    for (int a = 0; a < dim; ++a) inverse_mass[d * dim + a] = 1 / ops.mass[d];
  PressureSystem correction;
  correction.reset(inverse_mass);
  correction.add_block("p_f", np, ops.gradient_transpose);
  if (!ops.wall_faces.empty()) correction.add_block("y", int(ops.wall_faces.size()), ops.wall_rows);
  correction.assemble(1);
  // d = 0 - M^-1 D^T q with A q = -target gives D d = target.
  Eigen::VectorXd rhs = -Eigen::Map<const Eigen::VectorXd>(target.data(), Eigen::Index(target.size()));
  Eigen::VectorXd q;
  auto solver = make_linear_solver(scene_.solver, correction.unknowns(), dim);
  const auto stats = solver->solve(correction.matrix(), rhs, q);
  if (!stats.converged || !q.allFinite())
    throw NumericalFailure(fmt::format("position correction solve did not converge (relative residual {:.3g})", stats.relative_residual));
  const Eigen::VectorXd displacement = correction.corrected_velocity(Eigen::VectorXd::Zero(nv * dim), q);
  std::vector<Vec<dim>> corner_displacement(grid_.corners().size(), Vec<dim>::Zero());
  for (int d = 0; d < nv; ++d)
    for (int a = 0; a < dim; ++a) corner_displacement[ops.corner_of_dof[d]][a] = displacement[d * dim + a];
  const GridLayout<dim> corners = grid_.corners();
  const int n = int(fluid_.size());
#pragma omp parallel for schedule(static)
  for (int p = 0; p < n; ++p) {
    const auto stencil = linear_stencil<dim>(grid_.to_cells(fluid_.position[p]), grid_.dx);
    Vec<dim> shift = Vec<dim>::Zero();
    for_each_offset<dim, 2>([&](const IVec<dim>& offset) { shift += stencil.weight(offset) * corner_displacement[corners.index(stencil.base + offset)]; });
    fluid_.position[p] += shift;
  }
  keep_particles_in_domain();
}

template <int dim>
Real Simulation<dim>::fluid_pressure(int dual_cell) const {
  if (ops_.pressure_of_cell.empty() || lambda_.size() == 0) return 0;
  const int i = ops_.pressure_of_cell[dual_cell];
  return i >= 0 ? lambda_[i] : 0;
}

template <int dim>
Real Simulation<dim>::wall_force(int axis, int side) const {
  if (lambda_.size() == 0) return 0;
  // Force on the wall = sum_k y_k |face_k| n_k (n: outward normal of the fluid).
  const Real face_area = grid_.cell_volume() / grid_.dx;
  const int np = ops_.pressure_unknowns();
  Real force = 0;
  for (std::size_t f = 0; f < ops_.wall_faces.size(); ++f)
    if (ops_.wall_faces[f].wall.axis == axis && ops_.wall_faces[f].wall.side == side)
      force += lambda_[np + f] * face_area * (side == 0 ? -1 : 1);
  return force;
}

template <int dim>
std::vector<Real> Simulation<dim>::fluid_particle_pressure() const {
  std::vector<Real> out(fluid_.size(), 0);
  const auto cells = grid_.dual_cells();
  for (std::size_t p = 0; p < fluid_.size(); ++p) {
    const IVec<dim> c = dual_cell_of<dim>(grid_.to_cells(fluid_.position[p]));
    if (cells.contains(c)) out[p] = fluid_pressure(cells.index(c));
  }
  return out;
}

template <int dim>
Real Simulation<dim>::fluid_volume() const {
  const auto cells = grid_.dual_cells();
  std::vector<Real> volume(cells.size(), 0);
  for (std::size_t p = 0; p < fluid_.size(); ++p) {
    const IVec<dim> c = dual_cell_of<dim>(grid_.to_cells(fluid_.position[p]));
    if (cells.contains(c)) volume[cells.index(c)] += fluid_.initial_volume[p];
  }
  const Real cell_volume = grid_.cell_volume();
  Real total = 0;
  for (Real v : volume) total += std::min(v, cell_volume);
  return total;
}

}  // namespace iqmpm
