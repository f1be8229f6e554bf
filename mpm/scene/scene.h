// A validated scene: everything a run needs, read from a JSON file (scene.cpp holds the
// single table of keys, defaults and accepted values; `iqmpm keys` prints it).
#pragma once

#include <array>
#include <string>
#include <vector>

#include "linear_solver/linear_solver.h"
#include "materials/solid_material.h"
#include "pressure/warm_start.h"
#include "scene/json_reader.h"
#include "solid/time_integration.h"

namespace iqmpm {

enum class ShapeType { box, sphere, polygon };

enum class SurfaceQuadrature { automatic, particles, centre };
enum class FluidInertia { automatic, quadrature, transfer };
// How a free-slip wall holds the fluid: its normal velocity component at each corner on
// the wall, or one multiplier row per wall face (docs/method.md#walls-on-corners).
enum class WallConstraint { automatic, corners, faces };
enum class InitialPressure { zero, hydrostatic };
enum class InterfaceConstraint { bilateral, unilateral };
enum class SolidResponse { mass, stiffness };
enum class NewtonDirection { automatic, direct, cg };

struct ShapeSpec {
  ShapeType type = ShapeType::box;
  std::vector<Real> min, max;    // box
  std::vector<Real> centre;      // sphere (a disk in 2-D)
  Real radius = 0;
  std::vector<Real> vertices;    // polygon (2-D): x0, y0, x1, y1, ...
  bool contains(const Real* x, int dim) const;
};

inline constexpr Real kNoRange = -1e300;  // an unset optional coordinate

enum class ProbeType {
  front, water_height, pressure, hydrostatic_head, wall_force, max_speed, volume, particle_volume,
  hydrostatic_pressure_error, displacement, solid_force, solid_com, solid_velocity, solid_angle
};

struct ProbeSpec {
  ProbeType type = ProbeType::front;
  std::string name;   // metrics.csv column
  int axis = 0;               // front: direction of travel; displacement: component
  Real band = -1;             // front: particles below this height count; water_height: half-width (m); -1 = one cell
  Real position = 0;          // water_height: coordinate along the first axis
  Real position_to = kNoRange;  // water_height: mean over gauges every dx from position to here
  std::vector<Real> point;    // pressure; displacement: the material point followed
  Real sensor = 0;            // pressure: side of the sensing box (m); 0 = the 2^dim nearest cells
  int wall_axis = 0, wall_side = 0;  // wall_force
  Real surface = 0;           // hydrostatic_pressure_error: still-water level
  Real initial_angle = 0;     // solid_angle: the body's orientation at t = 0 (rad), added to its rotation
  std::string solid;          // solid_force, solid_com, solid_velocity, solid_angle: the body's name
  std::vector<ShapeSpec> region;  // solid_force: only the part of the body that starts in this shape (empty: all)
};

struct FluidSpec {
  Real density = 1000;
  std::vector<ShapeSpec> shapes;
  std::vector<Real> initial_velocity;
  // Of G^f and M^f in fluid cells next to empty ones; automatic: centre with solids,
  // particles without (what the validated scenes use; docs/method.md#fluid-quadrature).
  SurfaceQuadrature surface_quadrature = SurfaceQuadrature::automatic;
  WallConstraint wall_constraint = WallConstraint::automatic;
  // The fluid corners' mass in the projection (docs/method.md#fluid-inertia).
  FluidInertia inertia = FluidInertia::automatic;
};

// One elastic body (method.md §1): hyperelastic model, density, the ghost matrix's
// stiffness lambda_g, the regions it fills and the regions where it is clamped.
struct SolidSpec {
  std::string name;
  SolidModel model = SolidModel::fixed_corotated;
  Real density = 1000;
  Real mu = 0, lambda = 0;                // Lame parameters (from E, nu when given so)
  Real ghost_stiffness = 1e5;             // lambda_g (Pa)
  int particles_per_axis = 2;             // this body's seeding; default the scene's
  InitialPressure initial_pressure = InitialPressure::zero;  // the ghost matrix's starting pressure
  std::vector<ShapeSpec> shapes;
  std::vector<ShapeSpec> clamps;          // nodes whose centre lies inside are fixed
  std::vector<Real> initial_velocity;
};

// Projected Newton options of the implicit solid step (method.md §3 step 2).
struct NewtonSpec {
  Real relative_tolerance = 1e-5;
  Real cg_relative_tolerance = 1e-7;
  Real absolute_tolerance = 1e-9;
  int max_iterations = 50;
  int cg_max_iterations = 1000;
  bool project_hessian = true;
  NewtonDirection direction = NewtonDirection::automatic;
};

// Fluid-solid coupling (method.md §3 step 3, §4). The defaults are what the validated
// scenes use.
struct CouplingSpec {
  InterfaceConstraint interface = InterfaceConstraint::bilateral;
  Real solid_corner_fraction = 0.75;  // a fluid corner this much inside a solid moves with it; 0 = off
  Real interface_reach = 0.6;         // IQ points: solid particles this close (in dx) to a fluid particle
};

// Options under the scene's `experimental` section: kept for studies, each with a test, not
// used by a validated scene (docs/method.md#experimental-options).
struct ExperimentalSpec {
  Real position_correction = 0;                // relaxation of the particle position correction; 0 = off
  SolidResponse solid_response = SolidResponse::mass;  // the solid's mass matrix in the coupled solve
  int max_contact_rounds = 8;                  // unilateral interface: pressure solves per step at most
  bool trapped_air = false;                    // air enclosed by the water keeps its flux zero (docs/method.md#trapped-air)
};

// When a run writes checkpoint.h5 (docs/method.md#checkpoints); it always does at its end
// and on SIGINT / SIGTERM.
struct CheckpointSpec {
  int every_frames = 10;     // 0: not by frames
  Real every_minutes = 30;   // of wall time; 0: not by time
};

// Health checks after every step and the retries of a step that fails one
// (diagnostics/health.h, docs/method.md#health-checks).
struct HealthSpec {
  bool checks = true;
  Real energy_growth = 0.05;  // largest growth of the mechanical energy in a step, of the run's energy scale
  int max_retries = 3;        // halvings of dt before the run stops
};

struct SceneSpec {
  std::string name, description;
  int dim = 2;
  std::vector<Real> domain_min, domain_max;
  Real dx = 0;
  int particles_per_axis = 2;
  Real jitter = 0;
  unsigned seed = 1;
  std::vector<Real> gravity;
  Real gravity_ramp = 0;   // s over which gravity grows from zero; 0: full from the start
  Real end_time = 1;
  Real frame_rate = 0;     // output frames per second of simulated time; 0: first and last only
  bool write_frames = true;
  bool write_pressure_fields = false;  // pressure_fields.h5: MPMNet's dataset (io/pressure_field_writer.h)
  CheckpointSpec checkpoint;
  HealthSpec health;
  Real cfl = 0.5;
  Real spray_cfl = 0.8;    // spray (a cell with at most half a cell of material) moves up to this many cells a step
  Real dt_min = 1e-7, dt_max = 1e-2;
  SolidTimeIntegration solid_time_integration = SolidTimeIntegration::implicit_euler;
  Real solid_step_error = 0;  // the solids' local error a step, relative to their displacement; 0: not estimated
  bool extend_weak_solid_nodes = false;  // solid_weak_nodes = extended
  std::array<std::array<bool, 2>, 3> slip_walls{};  // [axis][side]: a free-slip wall (else no wall)
  FluidSpec fluid;
  std::vector<SolidSpec> solids;
  NewtonSpec newton;
  CouplingSpec coupling;
  ExperimentalSpec experimental;
  LinearSolverOptions solver;
  WarmStartSpec warm_start;  // solver.warm_start, solver.warm_start_history, solver.model
  std::vector<ProbeSpec> probes;
  Json document;  // the scene as given (after --set), stored in summary.json
};

// Reads and validates; throws InputError naming the key.
SceneSpec read_scene(const Json& document);
// Loads a file, applies --set overrides and validates.
SceneSpec load_scene(const std::string& path, const std::vector<std::string>& overrides);
// The reference table of all scene keys, from the same code that reads them.
std::vector<KeyDoc> document_scene_keys();

}  // namespace iqmpm
