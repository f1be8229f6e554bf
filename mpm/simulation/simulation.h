// One IQ-MPM simulation in `dim` dimensions: the particles and the grid state of the
// current step. step() (time_step.h) reads like the algorithm of method.md §3; each
// stage is timed and calls into its concept's folder, and a stage the scene does not need
// (no fluid, no solid, no interface) is skipped. The scene's options are resolved once, in
// the constructor (set_up.h), into StepOptions: the step never reads the scene.
// Measurements of the state are read-only functions in diagnostics/.
#pragma once

#include <array>
#include <cstdint>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "core/stage_timer.h"
#include "core/types.h"
#include "fluid/fluid_operators.h"
#include "fluid/trapped_air.h"
#include "grid/grid.h"
#include "grid/nested_dissection.h"
#include "interface/interface_quadrature.h"
#include "interface/unilateral_contact.h"
#include "io/state_archive.h"
#include "linear_solver/linear_solver.h"
#include "materials/solid_material.h"
#include "particles/particles.h"
#include "pressure/pressure_system.h"
#include "pressure/warm_start.h"
#include "scene/scene.h"
#include "solid/ghost_matrix.h"
#include "solid/projected_newton.h"
#include "solid/step_error.h"
#include "solid/weak_node_extension.h"
#include "transfer/apic.h"

namespace iqmpm {

struct StepStats {
  int pressure_unknowns = 0;
  int velocity_unknowns = 0;
  LinearSolveStats linear;
  int wall_clamps = 0;  // particles pushed back inside a slip wall this step
  int newton_iterations = 0;
  int newton_cg_iterations = 0;
  int extended_solid_nodes = 0;  // weak solid nodes given by extrapolation (solid_weak_nodes = extended)
  Real solid_min_J = 1;  // smallest det F of a solid particle after the step
  Real solid_step_error = std::numeric_limits<Real>::quiet_NaN();  // solid_step_error's estimate (solid/step_error.h)
  int contact_rounds = 1;  // pressure solves of the step (unilateral interface: active-set rounds)
  bool contact_settled = true;  // unilateral: the active set stopped changing within max_contact_rounds
  int modified_solves = 0;      // unilateral: rounds solved by modifying the LDL^T factor's changed rows
  int correction_unknowns = 0;  // the position correction's own system (with solids; 0: none or the step's factor)
  int air_pockets = 0;          // experimental.trapped_air: pockets held this step
  int air_pocket_cells = 0;     // ... and the largest one's dual cells
};

// The scene's choices as the step uses them, resolved once.
struct StepOptions {
  Real fluid_density = 1000;
  bool surface_cells_at_centre = true;       // fluid.surface_quadrature
  bool walls_on_corners = true;              // fluid.wall_constraint
  bool inertia_from_transfer = false;        // fluid.inertia = transfer
  bool trapped_air = false;                  // experimental.trapped_air = incompressible
  Real position_correction = 0;              // experimental.position_correction; 0 = off
  bool unilateral = false;                   // coupling.interface
  int max_contact_rounds = 8;                // experimental.max_contact_rounds
  bool solid_stiffness_in_solve = false;     // experimental.solid_response = stiffness
  Real solid_corner_fraction = 0.75;         // coupling.solid_corner_fraction; 0 = off
  Real interface_reach = 0.6;                // coupling.interface_reach (in dx)
  LinearSolverOptions pressure_solver;       // solver.* (LDL^T whenever the solid's stiffness is in the solve)
  ProjectedNewtonOptions newton;             // newton.*
  SolidTimeIntegration solid_time_integration = SolidTimeIntegration::implicit_euler;
  bool extend_weak_solid_nodes = false;      // solid_weak_nodes = extended
  bool estimate_solid_step_error = false;    // solid_step_error > 0
  Real gravity_ramp = 0;                     // gravity_ramp (s); 0 = full gravity from the start
};

template <int dim>
class Simulation {
 public:
  explicit Simulation(const SceneSpec& scene);

  // Advances by dt (method.md §3). Throws NumericalFailure with a diagnosis. The time-step
  // policy (CFL, dt_min, dt_max, frame times) is the caller's: run/time_step_policy.h.
  void step(Real dt);

  // The state one step hands to the next, for checkpoints (simulation/state.h): the
  // particles, the time, the warm start's history, the unilateral interface's released
  // cells, and the stage timings. Every other member is rebuilt by each step.
  void save_state(StateArchive& archive) const;
  // Replaces the seeded state with a checkpoint's; InputError when it does not belong to
  // this scene (dimension, particle counts).
  void restore_state(const StateArchive& archive);

  // The same state kept in memory before a step, and brought back when the step failed
  // or failed a health check, so that the runner can take it again with a smaller dt. The
  // warm start keeps the failed attempt's solution (only the first guess of the retry).
  // keep_step_start() before step(): the step's particle sort hands over the arrays it
  // replaces, so keeping the start costs no copy.
  void keep_step_start();
  void return_to_step_start();

  const Grid<dim>& grid() const { return grid_; }
  const SceneSpec& scene() const { return scene_; }
  const std::vector<SolidMaterial<dim>>& materials() const { return materials_; }  // per body
  const StepOptions& options() const { return options_; }
  const Vec<dim>& gravity() const { return gravity_; }
  int up_axis() const { return up_axis_; }
  bool slip_wall(int axis, int side) const { return slip_[axis][side]; }
  const Particles<dim>& fluid() const { return fluid_; }
  Particles<dim>& fluid() { return fluid_; }
  const Particles<dim>& solid() const { return solid_; }
  bool has_fluid() const { return !fluid_.empty(); }
  bool has_solids() const { return !solid_.empty(); }
  int interface_points() const { return iq_points_.size(); }
  const StageTimer& timer() const { return timer_; }
  const StepStats& last_step() const { return last_; }
  // The solids' local error of the last step (solid_step_error > 0; solid/step_error.h).
  const SolidStepError& solid_step_error() const { return solid_step_error_; }
  // Simulated time at the end of the last step (the sum of the steps' dt).
  Real time() const { return time_; }
  // The last step's solution as dense grid fields (the warm start's Map; MPMNet's tensors).
  GridSolution pressure_fields() const { return map_to_grid(unknown_locations_, lambda_, time_); }
  // Warm-start guesses that were not finite and were replaced (pressure/warm_start.h).
  long rejected_warm_starts() const { return warm_start_.rejected_predictions(); }
  // Where the last system's unknowns live on the grid (pressure/warm_start.h).
  const UnknownLocations& unknown_locations() const { return unknown_locations_; }

  // The last solve's multipliers by dual cell (layout index); 0 where the cell has none.
  Real fluid_pressure(int dual_cell) const;
  bool has_fluid_pressure(int dual_cell) const;  // the cell holds a solved fluid pressure
  Real ghost_pressure(int dual_cell) const;
  // The force of the fluid on a slip wall along its axis in the last step (N/m in 2-D).
  Real wall_force(int axis, int side) const { return wall_force_[axis][side]; }
  // Force of the fluid on each solid particle from the last solve (method.md §7): the
  // interface rows' nodal force -D^T lambda shared among the particles around each node by
  // their mass there; evaluated before the particles moved (interface/interface_force.h).
  const std::vector<Vec<dim>>& solid_particle_interface_force() const { return particle_force_; }

  // The last step's discrete objects, for tests and diagnostics.
  const FluidOperators<dim>& fluid_operators() const { return ops_; }
  const InterfaceOperators<dim>& interface_operators() const { return iq_ops_; }
  const SolidOperators<dim>& solid_operators() const { return solid_ops_; }
  const WeakSolidNodes& weak_solid_nodes() const { return weak_solid_nodes_; }  // solid_weak_nodes = extended
  const std::vector<Vec<dim>>& solid_node_velocity() const { return node_velocity_; }  // v_s^{n+1}, dense over nodes
  const PressureSystem& pressure_system() const { return system_; }
  const Eigen::VectorXd& pressure_solution() const { return lambda_; }
  const Eigen::VectorXd& grid_velocity_before_projection() const { return velocity_star_; }
  // The solid nodes' entries lead the stacked velocities (dim per node); the fluid corners' follow.
  int solid_velocity_entries() const { return fluid_column_offset_; }
  const Eigen::VectorXd& grid_velocity_after_projection() const { return velocity_next_; }
  const std::vector<int>& fluid_cells() const { return ops_.cell_of_pressure; }  // dual cells with p_f
  // The dual cell (layout index) of each unknown of the last system: p_g, p_f, y (the cell
  // next to the wall face), h, p_a (the pocket's first cell); -1 for the mass block's velocities.
  std::vector<int> dual_cell_of_unknowns() const;

 private:
  // Set-up (set_up.h).
  void seed_fluid();
  void seed_solids();
  void mark_clamped_nodes(const SolidSpec& spec, const std::string& key);
  Real still_water_level(const std::string& key) const;
  Real height(const Vec<dim>& x) const { return gravity_[up_axis_] < 0 ? x[up_axis_] : -x[up_axis_]; }
  // Stages of the step, in order (transfer_stages.h, solid_stage.h, pressure_stages.h).
  void sort_particles();
  void find_interface_quadrature();
  void particles_to_grid(Real dt);
  void solve_solid_momentum(Real dt);
  void build_operators();
  void assemble_pressure_system(Real dt);
  void solve_with_interface_constraint();
  void update_grid_velocities();
  std::vector<std::vector<std::pair<int, Real>>> weak_solid_node_columns(Eigen::VectorXd& inverse_mass) const;
  void measure_interface_forces();
  void grid_to_particles(Real dt);
  void correct_fluid_positions();
  // Helpers of the stages.
  void set_solid_mass_block();
  void solve_pressure_system(const Eigen::VectorXd& rhs);
  UnknownLocations locate_unknowns() const;
  void measure_wall_forces(const Eigen::VectorXd& constraint_force);
  std::vector<signed char> checkerboard_signs_of_unknowns() const;
  void keep_particles_in_domain(Particles<dim>& particles, const char* kind);

  // Fixed for the run.
  const SceneSpec scene_;
  StepOptions options_;
  Grid<dim> grid_;
  Vec<dim> gravity_;                           // the scene's; this step's is step_gravity_
  int up_axis_ = 1;
  std::array<std::array<bool, 2>, dim> slip_{};
  std::vector<SolidMaterial<dim>> materials_;  // per body
  std::vector<Real> ghost_stiffness_;          // lambda_g per body
  std::vector<std::uint8_t> clamped_node_;     // dense over nodes; empty: no clamp
  CellOrdering<dim> cell_ordering_;            // solver.ordering: the direct solve's order of the unknowns by their cells

  // Particles (all bodies share one solid set; Particles::body says which).
  Particles<dim> fluid_, solid_;

  // This step's grid state.
  Vec<dim> step_gravity_ = Vec<dim>::Zero();   // gravity_ scaled by the ramp (gravity_ramp) at the step's middle
  ParticleBins<dim> fluid_bins_, solid_bins_;
  GridMomentum<dim> corner_momentum_;          // fluid P2G on cell corners
  GridMomentum<dim> node_momentum_;            // solid P2G on nodes
  std::vector<std::uint8_t> wall_held_axes_;   // dense over nodes; bit a: component held by a wall this step
  std::vector<Vec<dim>> node_velocity_star_;   // v_s* after Newton, dense over nodes
  std::vector<Vec<dim>> node_velocity_;        // v_s^{n+1}, dense over nodes
  std::vector<Vec<dim>> node_start_velocity_;  // midpoint rule: v_s^n without this step's gravity, dense; else empty
  std::vector<Vec<dim>> corner_velocity_;      // v_f^{n+1}, dense over corners
  // The Newton Hessian at v* and the dense node of each of its dim-row groups (empty: the
  // solid's lumped mass in the solve, or no free solid node).
  Eigen::SparseMatrix<Real, Eigen::RowMajor, int> solid_hessian_;
  std::vector<int> solid_hessian_nodes_;
  WeakSolidNodes weak_solid_nodes_;  // this step's (solid_weak_nodes = extended)
  FluidOperators<dim> ops_;
  SolidOperators<dim> solid_ops_;
  std::vector<std::uint8_t> solid_corners_;    // fluid corners moving with a solid (coupling.solid_corner_fraction)
  InterfacePoints<dim> iq_points_;             // empty: no coupling this step
  InterfaceOperators<dim> iq_ops_;
  TrappedAir<dim> trapped_air_;                // experimental.trapped_air: this step's pockets (p_a)
  Particles<dim> borrowed_points_;             // the massless G^f points at IQ points
  ParticleBins<dim> borrowed_point_bins_;
  std::vector<Vec<dim>> particle_force_;       // interface force per solid particle

  // The pressure system: blocks (p_g, p_f, y, h, p_a) and the stacked grid velocities (solid
  // nodes, then fluid corners).
  SolutionLayout layout_;
  int fluid_column_offset_ = 0;
  Eigen::VectorXd velocity_star_;  // stacked grid velocities before the projection
  Eigen::VectorXd velocity_next_;  // ... and after
  PressureSystem system_;
  // Walls on the corners: each held fluid component, its wall, and m v*/dt along the axis.
  struct WallHold {
    int column;
    int axis, side;
    Real force_to_stop;
  };
  std::vector<WallHold> wall_holds_;
  std::array<std::array<Real, 2>, dim> wall_force_{};
  std::unique_ptr<LinearSolver> pressure_solver_;
  std::vector<int> direct_order_;  // this step's order for a direct solver (solver.ordering cells or grid); handed over once
  Eigen::VectorXd lambda_;         // solution: the multipliers (p_g, p_f, y, h, p_a), then the mass block's u
  WarmStart warm_start_;
  UnknownLocations unknown_locations_;  // of this step's system
  Real time_ = 0;                       // at the end of the step (in progress)
  UnilateralContact contact_;      // unilateral interface: the active set
  SolidStepError solid_step_error_;  // of the last step (solid_step_error > 0)

  StageTimer timer_;
  StepStats last_;
  struct StepStart {
    Particles<dim> fluid, solid;  // as before the step's sort (transfer_stages.h)
    bool requested = false;       // by keep_step_start(), for the next sort
    bool kept = false;            // fluid and solid hold the start of the last step
    Real time = 0;
    SolidStepError solid_step_error;
    std::vector<std::uint8_t> released_h_cells, released_p_cells;
  } step_start_;
};

extern template class Simulation<2>;
extern template class Simulation<3>;

}  // namespace iqmpm
