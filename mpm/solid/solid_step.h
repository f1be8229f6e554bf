// The implicit solid step of method.md §3 step 2: v_s^n -> v_s* by projected Newton on the
// incremental potential (incremental_potential.h, projected_newton.h). The simulation's
// Newton stage (simulation/solid_stage.h) calls it.
//
// In the time step (the caller wires):
//   1. solid P2G (transfer/apic.h: solid_particles_to_grid) -> SolidNodes::mass, and
//      SolidNodes::velocity = momentum / mass (+ dt gravity) on nodes with mass > 0;
//      clamped / clamped_velocity for Dirichlet nodes (e.g. the top of the gate);
//   2. solid_step(...) -> dense node velocities v*, and the result (check result.converged);
//   3. after the coupled pressure solve, G2P (solid_grid_to_particles) with the final
//      velocities and F_p^{n+1} = (I + dt grad v(x_p)) F_p^n, the same F_p(v) as the energy;
//      with the midpoint rule, F and x move with the step's mean velocity (u + v^{n+1}) / 2
//      (incremental_potential.h), the particle keeps v^{n+1}.
// The particles' positions and F^n must not change between steps 1 and 2.
#pragma once

#include <vector>

#include "solid/incremental_potential.h"
#include "solid/projected_newton.h"
#include "solid/weak_node_extension.h"

namespace iqmpm {

// The step's linearisation at v*, for a coupled solve that sees the solid's stiffness: the
// projected Hessian M + dt tau K (incremental_potential.h) and the dense node of each of its dim-row groups.
struct SolidLinearisation {
  Eigen::SparseMatrix<Real, Eigen::RowMajor, int> hessian;
  std::vector<int> nodes;
};

// Minimises the incremental potential starting from v^n and writes v* dense over
// Grid::nodes() (clamped nodes: their prescribed velocity; inactive nodes: v^n unchanged).
// Particle p uses materials[material_of_particle[p]] (empty: materials[0]). With
// `linearisation`, also the Hessian at v*. `rule`: the potential's time integration (the
// midpoint rule reads nodes.start_velocity). `weak_nodes` (null or empty: none): nodes whose
// velocity is the extrapolation of their block's (weak_node_extension.h); Newton then runs
// over the other nodes. The linearisation is the un-extended potential's.
template <int dim, class Material>
NewtonResult solid_step(const Grid<dim>& grid, const Particles<dim>& particles, std::vector<Material> materials,
                        std::vector<int> material_of_particle, const SolidNodes<dim>& nodes, Real dt,
                        const ProjectedNewtonOptions& options, std::vector<Vec<dim>>& node_velocity,
                        SolidLinearisation* linearisation = nullptr,
                        SolidTimeIntegration rule = SolidTimeIntegration::implicit_euler,
                        const WeakSolidNodes* weak_nodes = nullptr) {
  using Potential = SolidIncrementalPotential<dim, Material>;
  const Potential potential(grid, particles, std::move(materials), std::move(material_of_particle), nodes, dt, rule);
  auto v = potential.initial_velocity();
  NewtonResult result;
  if (weak_nodes && !weak_nodes->empty()) {
    const WeakNodeExtension extension = weak_node_extension<dim>(*weak_nodes, potential.free_numbers());
    const ExtendedPotential<Potential> extended(potential, extension);
    auto x = extended.initial_velocity();
    result = minimize_projected_newton(extended, x, options);
    v = extended.expand(x);
  } else {
    result = minimize_projected_newton(potential, v, options);
  }
  potential.scatter(v, node_velocity);
  if (linearisation && result.converged) {
    linearisation->hessian = potential.hessian(v, true);
    linearisation->nodes.clear();
    for (int r = 0; r * dim < potential.unknowns(); ++r) linearisation->nodes.push_back(potential.dense_node(r));
  }
  return result;
}

// One material for every particle.
template <int dim, class Material>
NewtonResult solid_step(const Grid<dim>& grid, const Particles<dim>& particles, const Material& material,
                        const SolidNodes<dim>& nodes, Real dt, const ProjectedNewtonOptions& options,
                        std::vector<Vec<dim>>& node_velocity) {
  return solid_step(grid, particles, std::vector<Material>{material}, {}, nodes, dt, options, node_velocity);
}

}  // namespace iqmpm
