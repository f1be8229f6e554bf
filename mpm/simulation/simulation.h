// One IQ-MPM simulation in `dim` dimensions. step() reads like the algorithm of
// method.md §3; each stage is timed. The fluid half is complete; solids (Newton step,
// ghost matrix) and the interface blocks plug into the same pressure system.
#pragma once

#include <array>
#include <map>
#include <vector>

#include "core/stage_timer.h"
#include "core/types.h"
#include "fluid/fluid_operators.h"
#include "grid/grid.h"
#include "linear_solver/linear_solver.h"
#include "particles/particles.h"
#include "pressure/pressure_system.h"
#include "scene/scene.h"
#include "transfer/apic.h"

namespace iqmpm {

struct StepStats {
  int pressure_unknowns = 0;
  int velocity_unknowns = 0;
  LinearSolveStats linear;
  int wall_clamps = 0;  // particles pushed back inside a slip wall this step
};

template <int dim>
class Simulation {
 public:
  explicit Simulation(const SceneSpec& scene);

  // Advances by dt (method.md §3). Throws NumericalFailure with a diagnosis.
  void step(Real dt);
  // dt = cfl dx / max(particle speed, sqrt(|g| dx)), clamped to [dt_min, dt_max].
  Real stable_dt() const;

  const Grid<dim>& grid() const { return grid_; }
  const Particles<dim>& fluid() const { return fluid_; }
  Particles<dim>& fluid() { return fluid_; }
  const SceneSpec& scene() const { return scene_; }
  const StageTimer& timer() const { return timer_; }
  const StepStats& last_step() const { return last_; }
  int up_axis() const { return up_axis_; }
  // Fluid pressure of a dual cell (layout index) from the last solve; 0 where no fluid.
  Real fluid_pressure(int dual_cell) const;
  // Force of the fluid on a domain wall along its axis, from the wall multipliers y.
  Real wall_force(int axis, int side) const;
  // Pressure of the cell holding each fluid particle (for output frames).
  std::vector<Real> fluid_particle_pressure() const;
  // Volume estimate: sum over dual cells of min(dx^dim, particle volume in the cell).
  Real fluid_volume() const;
  // Dual cells holding fluid at the last step (the active pressure unknowns).
  const std::vector<int>& fluid_cells() const { return ops_.cell_of_pressure; }

  // The last step's discrete objects, for tests and diagnostics.
  const FluidOperators<dim>& fluid_operators() const { return ops_; }
  const PressureSystem& pressure_system() const { return system_; }
  const Eigen::VectorXd& pressure_solution() const { return lambda_; }
  const Eigen::VectorXd& grid_velocity_before_projection() const { return velocity_star_; }
  const Eigen::VectorXd& grid_velocity_after_projection() const { return velocity_next_; }

 private:
  void sort_particles();
  void particles_to_grid(Real dt);
  void build_fluid_operators();
  void assemble_pressure_system(Real dt);
  void solve_pressure_system();
  void update_grid_velocities();
  void grid_to_particles(Real dt);
  void keep_particles_in_domain();
  void correct_particle_positions();

  SceneSpec scene_;
  Grid<dim> grid_;
  Vec<dim> gravity_;
  int up_axis_ = 1;
  Real fluid_density_ = 1000;
  std::array<std::array<bool, 2>, dim> slip_{};
  Particles<dim> fluid_;
  ParticleBins<dim> fluid_bins_;
  GridMomentum<dim> corner_momentum_;
  FluidOperators<dim> ops_;
  Eigen::VectorXd velocity_star_;  // stacked grid velocities before the projection
  PressureSystem system_;
  Eigen::VectorXd lambda_;         // solution (p_f, y)
  Eigen::VectorXd velocity_next_;  // stacked grid velocities after the projection
  std::vector<Vec<dim>> corner_velocity_;
  // Previous solution by dual cell, for the warm start.
  std::vector<Real> previous_pressure_;
  std::map<std::pair<int, int>, Real> previous_wall_;  // (cell, axis*2+side) -> y
  StageTimer timer_;
  StepStats last_;
};

extern template class Simulation<2>;
extern template class Simulation<3>;

}  // namespace iqmpm
