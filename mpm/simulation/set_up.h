// Building a simulation from its scene: the options the step uses (resolved here once),
// the grid, and the seeded particles. Input errors found here surface before any output
// is written.
#pragma once

#include <cmath>
#include <fmt/format.h>
#include <limits>

#include "core/errors.h"
#include "grid/nested_dissection.h"
#include "simulation/seeding.h"
#include "simulation/simulation.h"

namespace iqmpm {

inline StepOptions resolve_step_options(const SceneSpec& scene) {
  StepOptions o;
  o.fluid_density = scene.fluid.density;
  o.surface_cells_at_centre = scene.fluid.surface_quadrature == SurfaceQuadrature::centre ||
                              (scene.fluid.surface_quadrature == SurfaceQuadrature::automatic && !scene.solids.empty());
  // auto: faces in 2-D, where the corners made the dam break's splashes faster (the
  // direct solve does not need the conditioning; docs/method.md#walls-on-corners).
  o.walls_on_corners = scene.fluid.wall_constraint == WallConstraint::corners ||
                       (scene.fluid.wall_constraint == WallConstraint::automatic && scene.dim == 3);
  // auto: transfer without solids; with them it moved the floating block's draft by -2.6 %
  // and did not calm the obstacle's force (docs/method.md#fluid-inertia).
  o.inertia_from_transfer = scene.fluid.inertia == FluidInertia::transfer ||
                            (scene.fluid.inertia == FluidInertia::automatic && scene.solids.empty());
  o.trapped_air = scene.experimental.trapped_air;
  o.position_correction = scene.experimental.position_correction;
  o.unilateral = scene.coupling.interface == InterfaceConstraint::unilateral;
  o.max_contact_rounds = scene.experimental.max_contact_rounds;
  o.solid_stiffness_in_solve = scene.experimental.solid_response == SolidResponse::stiffness;
  o.solid_corner_fraction = scene.coupling.solid_corner_fraction;
  o.interface_reach = scene.coupling.interface_reach;
  o.pressure_solver = scene.solver;
  // The bordered system with the solid's stiffness is quasi-definite: only LDL^T solves it
  // (the scene reader accepts it with ldlt, or auto in 2-D).
  if (o.solid_stiffness_in_solve) o.pressure_solver.method = LinearSolverMethod::ldlt;
  o.pressure_solver.simplicial = o.unilateral || o.solid_stiffness_in_solve;
  o.newton.relative_tolerance = scene.newton.relative_tolerance;
  o.newton.cg_relative_tolerance = scene.newton.cg_relative_tolerance;
  o.newton.absolute_tolerance = scene.newton.absolute_tolerance;
  o.newton.max_iterations = scene.newton.max_iterations;
  o.newton.cg_max_iterations = scene.newton.cg_max_iterations;
  o.newton.project_hessian = scene.newton.project_hessian;
  o.solid_time_integration = scene.solid_time_integration;
  o.extend_weak_solid_nodes = scene.extend_weak_solid_nodes;
  o.estimate_solid_step_error = scene.solid_step_error > 0;
  o.gravity_ramp = scene.gravity_ramp;
  o.newton.direct = scene.newton.direction == NewtonDirection::direct ||
                    (scene.newton.direction == NewtonDirection::automatic && scene.dim == 2);
  return o;
}

template <int dim>
Simulation<dim>::Simulation(const SceneSpec& scene) : scene_(scene), options_(resolve_step_options(scene)) {
  Vec<dim> lower, upper;
  for (int a = 0; a < dim; ++a) {
    lower[a] = scene.domain_min[a];
    upper[a] = scene.domain_max[a];
    gravity_[a] = scene.gravity[a];
  }
  grid_ = Grid<dim>(lower, upper, scene.dx);
  gravity_.cwiseAbs().maxCoeff(&up_axis_);
  for (int a = 0; a < dim; ++a)
    for (int s = 0; s < 2; ++s) slip_[a][s] = scene.slip_walls[a][s];
  warm_start_ = WarmStart(scene.warm_start, dim, std::vector<int>(grid_.cells.data(), grid_.cells.data() + dim));
  if (options_.pressure_solver.ordering == DirectOrdering::grid)
    cell_ordering_ = CellOrdering<dim>::whole_grid(grid_.dual_cells(), grid_.cells);
  else if (options_.pressure_solver.ordering == DirectOrdering::cells)
    cell_ordering_ = CellOrdering<dim>::occupied_cells(grid_.dual_cells());
  seed_fluid();
  seed_solids();
}

template <int dim>
void Simulation<dim>::seed_fluid() {
  if (!scene_.fluid.shapes.empty()) {
    Vec<dim> v0;
    for (int a = 0; a < dim; ++a) v0[a] = scene_.fluid.initial_velocity[a];
    Particles<dim> seeded;
    seed_particles<dim>(grid_, scene_.fluid.shapes, scene_.particles_per_axis, scene_.jitter, scene_.seed,
                        options_.fluid_density, v0, seeded);
    // A solid displaces the fluid it is placed in.
    for (std::size_t p = 0; p < seeded.size(); ++p) {
      bool inside_solid = false;
      for (const auto& solid : scene_.solids)
        for (const auto& shape : solid.shapes) inside_solid = inside_solid || shape.contains(seeded.position[p].data(), dim);
      if (!inside_solid) fluid_.add(seeded.position[p], seeded.velocity[p], seeded.mass[p], seeded.initial_volume[p]);
    }
    if (fluid_.empty())
      throw InputError("scene key 'fluid.shapes': no particle was seeded (the shapes lie outside the domain or are thinner than a particle spacing)");
  }
  for (const auto& x : fluid_.position)
    if (!grid_.dual_cells().contains(dual_cell_of<dim>(grid_.to_cells(x))))
      throw InputError("scene key 'fluid.shapes': a shape reaches outside the domain");
}

// solids[].initial_pressure = hydrostatic: the still-water level, the top of the fluid
// particles (the highest one plus half a particle spacing), as a height against gravity.
template <int dim>
Real Simulation<dim>::still_water_level(const std::string& key) const {
  if (fluid_.empty() || !(gravity_.norm() > 0))
    throw InputError(fmt::format("scene key '{}.initial_pressure' = \"hydrostatic\": needs fluid and gravity; accepted "
                                 "without them: \"zero\"", key));
  Real top = -std::numeric_limits<Real>::infinity();
  for (const auto& x : fluid_.position) top = std::max(top, height(x));
  return top + Real(0.5) * grid_.dx / scene_.particles_per_axis;
}

// Solid particles: F = I, one body index per solid; clamped nodes from the clamp regions.
// The ghost matrix starts unstressed (J_g = 1) or, with solids[].initial_pressure =
// hydrostatic, at the still water's pressure rho_f |g| (level - height), so that a body at
// rest in still water starts in balance with it instead of being squeezed through its
// soft ghost matrix in the first steps (docs/method.md#hydrostatic-start).
template <int dim>
void Simulation<dim>::seed_solids() {
  for (std::size_t b = 0; b < scene_.solids.size(); ++b) {
    const SolidSpec& spec = scene_.solids[b];
    const std::string key = fmt::format("solids[{}]", b);
    SolidMaterial<dim> material;
    material.model = spec.model;
    material.mu = spec.mu;
    material.lambda = spec.lambda;
    materials_.push_back(material);
    ghost_stiffness_.push_back(spec.ghost_stiffness);
    Vec<dim> v0;
    for (int a = 0; a < dim; ++a) v0[a] = spec.initial_velocity[a];
    Particles<dim> seeded;
    seed_particles<dim>(grid_, spec.shapes, spec.particles_per_axis, scene_.jitter, scene_.seed + unsigned(b) + 1,
                        spec.density, v0, seeded);
    if (seeded.empty())
      throw InputError(fmt::format("scene key '{}.shapes': no particle was seeded (outside the domain or thinner than a particle spacing)", key));
    const bool hydrostatic = spec.initial_pressure == InitialPressure::hydrostatic;
    const Real level = hydrostatic ? still_water_level(key) : 0;
    for (std::size_t p = 0; p < seeded.size(); ++p) {
      if (!grid_.dual_cells().contains(dual_cell_of<dim>(grid_.to_cells(seeded.position[p]))))
        throw InputError(fmt::format("scene key '{}.shapes': a shape reaches outside the domain", key));
      solid_.add(seeded.position[p], seeded.velocity[p], seeded.mass[p], seeded.initial_volume[p]);
      solid_.deformation_gradient.push_back(Mat<dim>::Identity());
      const Real pressure = hydrostatic ? options_.fluid_density * gravity_.norm() * std::max(Real(0), level - height(seeded.position[p])) : 0;
      if (!(pressure < spec.ghost_stiffness))
        throw InputError(fmt::format("scene key '{}.initial_pressure' = \"hydrostatic\": the water pressure {:.4g} Pa "
                                     "reaches the ghost stiffness {:.4g} Pa (J_g would not be positive); raise '{}.ghost_stiffness'",
                                     key, pressure, spec.ghost_stiffness, key));
      solid_.ghost_J.push_back(1 - pressure / spec.ghost_stiffness);
      solid_.body.push_back(int(b));
      solid_.initial_position.push_back(seeded.position[p]);
    }
    if (!spec.clamps.empty()) mark_clamped_nodes(spec, key);
  }
}

// A node is fixed when its centre lies in a clamp region or within dx/2 of it along an
// axis: the quadratic B-spline velocity then vanishes on the whole region when its edges
// lie on cell faces (a node reaches 1.5 dx), and nowhere outside it, so a clamped beam's
// free length is the scene's, not one cell longer or shorter.
template <int dim>
void Simulation<dim>::mark_clamped_nodes(const SolidSpec& spec, const std::string& key) {
  const GridLayout<dim> nodes = grid_.nodes();
  if (clamped_node_.empty()) clamped_node_.assign(nodes.size(), 0);
  int count = 0;
  const Real reach = Real(0.5) * grid_.dx * (1 + 1e-9);
  for (int k = 0; k < nodes.size(); ++k) {
    const Vec<dim> centre = grid_.dual_cell_centre(nodes.multi_index(k));
    bool inside = false;
    for (const auto& clamp : spec.clamps) {
      inside = inside || clamp.contains(centre.data(), dim);
      for (int a = 0; a < dim && !inside; ++a)
        for (Real shift : {-reach, reach}) {
          Vec<dim> x = centre;
          x[a] += shift;
          inside = inside || clamp.contains(x.data(), dim);
        }
    }
    if (inside && !clamped_node_[k]) {
      clamped_node_[k] = 1;
      ++count;
    }
  }
  if (count == 0)
    throw InputError(fmt::format("scene key '{}.clamps': no velocity node (dual-cell centre) lies inside the clamp regions", key));
}

}  // namespace iqmpm
