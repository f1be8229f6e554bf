// One time step of IQ-MPM (method.md §3). Each stage is a member that times itself and
// calls into its concept's folder: transfer_stages.h (particles), solid_stage.h (Newton),
// pressure_stages.h (operators, the coupled pressure solve, velocities). A stage the
// scene does not need is skipped (method.md §8).
#pragma once

#include <cmath>

#include "simulation/pressure_stages.h"
#include "simulation/set_up.h"
#include "simulation/solid_stage.h"
#include "simulation/transfer_stages.h"

namespace iqmpm {

template <int dim>
void Simulation<dim>::step(Real dt) {
  last_ = StepStats{};
  time_ += dt;
  // gravity_ramp: gravity grows smoothly to its full value, (1 - cos(pi t / T)) / 2, a
  // quasi-static load (method.md#gravity-ramp); the factor at the step's middle.
  const Real middle = time_ - Real(0.5) * dt;
  const Real ramp = middle < options_.gravity_ramp
                        ? Real(0.5) * (1 - std::cos(Real(M_PI) * middle / options_.gravity_ramp))
                        : Real(1);
  step_gravity_ = ramp * gravity_;

  // Particles sorted by dual cell: the bins of P2G, the spatial hash of the IQ search.
  sort_particles();

  // §3 step 3: solid particles near the fluid become interface quadrature points and
  // borrow fluid volume.
  if (has_fluid() && has_solids()) find_interface_quadrature();

  // §3 step 1: APIC P2G of both materials, gravity in the grid momentum.
  particles_to_grid(dt);

  // §3 step 2: the solid's elastic step alone, v_s^n -> v_s*, by projected Newton.
  if (has_solids()) solve_solid_momentum(dt);

  // §4: G^f, M^f, B; G^s, S; H^s, H^f (and the pockets of trapped air, if asked for).
  build_operators();

  // §5: the pressure-only system A = dt D M^-1 D^T + C in (p_g, p_f, y, h[, p_a]) ...
  assemble_pressure_system(dt);

  // ... solved under the interface constraint (bilateral, or unilateral by active sets).
  solve_with_interface_constraint();

  // §5: v^{n+1} = v* - dt M^-1 D^T lambda on both grids.
  update_grid_velocities();

  // §7: the force of the fluid on each solid particle, before the particles move.
  if (has_solids()) measure_interface_forces();

  // §3 step 5: G2P, advection, F and the ghost matrix's J_g.
  grid_to_particles(dt);

  // §3 step 6 (experimental): even out the fluid particles.
  if (has_fluid() && options_.position_correction > 0) correct_fluid_positions();
}

}  // namespace iqmpm
