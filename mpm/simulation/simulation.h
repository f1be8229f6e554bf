// One IQ-MPM simulation in `dim` dimensions. step() reads like the algorithm of
// method.md §3; each stage is timed, and a stage the scene does not need (no fluid, no
// solid) is skipped, so it does not appear in the timings. The interface blocks (IQ)
// plug into the same pressure system.
#pragma once

#include <array>
#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "core/stage_timer.h"
#include "core/types.h"
#include "fluid/fluid_operators.h"
#include "grid/grid.h"
#include "interface/interface_quadrature.h"
#include "linear_solver/linear_solver.h"
#include "materials/solid_material.h"
#include "particles/particles.h"
#include "pressure/pressure_system.h"
#include "scene/scene.h"
#include "solid/ghost_matrix.h"
#include "solid/projected_newton.h"
#include "transfer/apic.h"

namespace iqmpm {

struct StepStats {
  int pressure_unknowns = 0;
  int velocity_unknowns = 0;
  LinearSolveStats linear;
  int wall_clamps = 0;  // particles pushed back inside a slip wall this step
  int newton_iterations = 0;
  int newton_cg_iterations = 0;
  Real solid_min_J = 1;  // smallest det F of a solid particle after the step
  int contact_rounds = 1;  // pressure solves of the step (coupling.interface = unilateral: active-set rounds)
  bool contact_settled = true;  // unilateral: the active set stopped changing within max_contact_rounds
  int modified_solves = 0;      // unilateral: rounds solved by modifying the LDL^T factor's changed rows
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
  const Particles<dim>& solid() const { return solid_; }
  bool has_fluid() const { return !fluid_.empty(); }
  bool has_solids() const { return !solid_.empty(); }
  // Displacement of the material point followed by a `displacement` probe (by probe name).
  Vec<dim> tracked_displacement(const std::string& probe_name) const;
  // Ghost-matrix pressure of a dual cell from the last solve; 0 where no solid.
  Real ghost_pressure(int dual_cell) const;
  // Force of the fluid on solid `body` from the last solve (method.md §7): sum of H^sT h
  // over the body's IQ points (the ghost matrix adds no net force). N/m in 2-D, N in 3-D.
  Vec<dim> interface_force(int body) const;
  // The same restricted to the material of a `solid_force` probe's region (by probe name).
  Vec<dim> region_interface_force(const std::string& probe_name) const;
  // Centre of mass of a body, and (2-D) its rotation angle: the least-squares rotation of
  // its particles about the centre of mass since the start (rad, counter-clockwise).
  Vec<dim> solid_centre_of_mass(int body) const;
  Vec<dim> solid_mean_velocity(int body) const;  // momentum / mass of the body's particles
  Real solid_angle(int body) const;
  int body_index(const std::string& name) const;
  int interface_points() const { return iq_points_.size(); }
  const InterfaceOperators<dim>& interface_operators() const { return iq_ops_; }
  std::vector<Real> solid_particle_pressure() const;
  const SceneSpec& scene() const { return scene_; }
  const StageTimer& timer() const { return timer_; }
  const StepStats& last_step() const { return last_; }
  int up_axis() const { return up_axis_; }
  // Fluid pressure of a dual cell (layout index) from the last solve; 0 where no fluid.
  Real fluid_pressure(int dual_cell) const;
  bool has_fluid_pressure(int dual_cell) const;  // the cell holds a solved fluid pressure
  // Force of the fluid on a domain wall along its axis, from the wall multipliers y.
  Real wall_force(int axis, int side) const;
  // Pressure of the cell holding each fluid particle (for output frames).
  std::vector<Real> fluid_particle_pressure() const;
  // Water volume: the volume of the region the water fills (what interFoam's integral of
  // alpha measures). A dual cell whose 3^dim neighbours inside the domain all hold fluid
  // particles is full of water (less the solid volume in it), as the projection treats it
  // (method.md §4); any other cell holds its particles' volume, at most dx^dim.
  Real fluid_volume() const;
  // Particle measure: sum over dual cells of min(dx^dim, particle volume in the cell). It
  // falls when particles cluster and leave gaps inside the water even if the water's
  // region keeps its volume (README, known limits); the position correction targets it.
  Real fluid_particle_volume() const;
  // Dual cells holding fluid at the last step (the active pressure unknowns).
  const std::vector<int>& fluid_cells() const { return ops_.cell_of_pressure; }

  // The last step's discrete objects, for tests and diagnostics.
  const FluidOperators<dim>& fluid_operators() const { return ops_; }
  const PressureSystem& pressure_system() const { return system_; }
  const Eigen::VectorXd& pressure_solution() const { return lambda_; }
  const Eigen::VectorXd& grid_velocity_before_projection() const { return velocity_star_; }
  const Eigen::VectorXd& grid_velocity_after_projection() const { return velocity_next_; }

 private:
  void seed_solids();
  Real still_water_level(const std::string& key) const;
  // Height of x against gravity (along the up axis).
  Real height(const Vec<dim>& x) const { return gravity_[up_axis_] < 0 ? x[up_axis_] : -x[up_axis_]; }
  void sort_particles();
  void particles_to_grid(Real dt);
  void solve_solid_momentum(Real dt);
  void mark_solid_corners();
  void build_fluid_operators();
  void build_solid_operators();
  void find_interface_quadrature();
  void build_interface_operators();
  void measure_interface_forces();
  void assemble_pressure_system(Real dt);
  void set_solid_mass_block();
  void mark_unilateral_rows();
  bool update_released_rows();
  void solve_pressure_system();
  void update_grid_velocities();
  void grid_to_particles(Real dt);
  void keep_particles_in_domain(Particles<dim>& particles, const char* kind);
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
  // Solids (all bodies share one particle set; Particles::body says which).
  Particles<dim> solid_;
  ParticleBins<dim> solid_bins_;
  GridMomentum<dim> node_momentum_;
  std::vector<SolidMaterial<dim>> materials_;  // per body
  std::vector<Real> ghost_stiffness_;          // lambda_g per body
  std::vector<std::uint8_t> clamped_node_;     // dense over nodes; empty: no clamp
  std::vector<std::uint8_t> wall_held_axes_;   // dense over nodes; bit a: component held by a wall this step
  ProjectedNewtonOptions newton_options_;
  std::vector<Vec<dim>> node_velocity_star_;   // v_s* after Newton, dense over nodes
  std::vector<Vec<dim>> node_velocity_;        // v_s^{n+1}, dense over nodes
  SolidOperators<dim> solid_ops_;
  std::vector<std::uint8_t> solid_corners_;  // corners moving with a solid (coupling.solid_corner_fraction)
  std::vector<Real> previous_ghost_;           // p_g by dual cell, warm start
  // Interface quadrature of this step (empty: no coupling this step).
  InterfacePoints<dim> iq_points_;
  InterfaceOperators<dim> iq_ops_;
  Particles<dim> fluid_quadrature_;        // borrowed_fluid = mass: fluid particles (shared mass) + borrowed fluid
  ParticleBins<dim> fluid_quadrature_bins_;
  Particles<dim> borrowed_points_;         // borrowed_fluid = volume: the massless G^f points at IQ points
  ParticleBins<dim> borrowed_point_bins_;
  std::vector<Real> previous_interface_;   // h by dual cell, warm start
  int interface_offset_ = -1;
  std::vector<Vec<dim>> interface_force_;  // per body, from the last solve
  // solid_force probes with a region: their body, the region (in the initial configuration:
  // a particle belongs to it by its initial position, which moves with it when particles are
  // sorted), the force.
  struct ForceRegion {
    std::string probe_name;
    int body = 0;
    std::vector<ShapeSpec> region;
    Vec<dim> force = Vec<dim>::Zero();
    bool contains(const Particles<dim>& solid, std::size_t p) const {
      if (solid.body[p] != body) return false;
      for (const auto& shape : region)
        if (shape.contains(solid.initial_position[p].data(), dim)) return true;
      return false;
    }
  };
  std::vector<ForceRegion> force_regions_;
  bool lend_mass_ = false;        // this step's quadrature lends fluid mass to IQ points (borrowed_fluid = mass)
  bool borrowed_volume_ = false;  // ... or adds massless volume points there (borrowed_fluid = volume)
  // The fluid quadrature of P2G and M^f (and of G^f, with the borrowed volume points).
  const Particles<dim>& quadrature_fluid() const { return lend_mass_ ? fluid_quadrature_ : fluid_; }
  const ParticleBins<dim>& quadrature_bins() const { return lend_mass_ ? fluid_quadrature_bins_ : fluid_bins_; }
  // Material points followed by displacement probes.
  struct Marker {
    std::string name;
    Vec<dim> start;                  // the material point X (initial position)
    std::vector<Vec<dim>> carriers;  // initial positions of the particles that carry it
  };
  std::vector<Marker> markers_;
  // Offsets of the blocks in the solution vector (-1: absent).
  int ghost_offset_ = -1, pressure_offset_ = -1, wall_offset_ = -1;
  int fluid_column_offset_ = 0;  // solid velocities first, then fluid
  Eigen::VectorXd velocity_star_;  // stacked grid velocities before the projection
  PressureSystem system_;
  std::unique_ptr<LinearSolver> pressure_solver_;
  Eigen::VectorXd lambda_;         // solution: the multipliers (p_g, p_f, y, h), then the mass block's u
  // The Newton Hessian at v* and the dense node of each of its dim-row groups (empty:
  // coupling.solid_response = mass, or no free solid node).
  Eigen::SparseMatrix<Real, Eigen::RowMajor, int> solid_hessian_;
  std::vector<int> solid_hessian_nodes_;
  // coupling.interface = unilateral, per row of the system: an inequality row (h, or p_f
  // acting on the solid), its dual cell, released this round; the released cells of the
  // last round (h and p_f rows apart), the next step's starting set.
  std::vector<std::uint8_t> unilateral_row_, released_rows_;
  std::vector<int> cell_of_row_;
  std::vector<std::uint8_t> released_h_cells_, released_p_cells_;
  std::vector<int> newly_released_rows_, newly_restored_rows_;  // by the last active-set round
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
