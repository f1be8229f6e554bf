// Solids in the time step (method.md §3 steps 1, 2, 5 and the ghost-matrix block of §5):
// the cantilever against beam theory, exact free fall, clamps, the ghost-matrix constraint
// after the solve, and the stability scenes (block drop, soft beam) of issue #3. The
// benchmark runs (cantilever, soft beam) are 2-D; the others are typed over 2-D and 3-D.
#include <array>
#include <cmath>
#include <stdexcept>

#include "core/errors.h"
#include "diagnostics/measurements.h"
#include "run/runner.h"
#include "run/time_step_policy.h"
#include "simulation/simulation.h"
#include "support/run_helpers.h"
#include "support/scenes.h"
#include "support/test_helpers.h"

namespace iqmpm {
namespace {

using testing::scene_path;

// Static value (time average over whole periods of the second half) and frequency (mean
// spacing of upward crossings of that value) of a decaying oscillation.
struct Oscillation {
  double equilibrium = NAN, frequency = NAN;
};

Oscillation analyse(const RunResult& result, int column) {
  std::vector<double> t, y;
  for (const auto& row : result.metrics) t.push_back(row[0]), y.push_back(row[column]);
  const double half = 0.5 * t.back();
  auto upward_crossings = [&](double level, double from) {
    std::vector<double> times;
    for (std::size_t k = 1; k < t.size(); ++k)
      if (t[k - 1] >= from && y[k - 1] < level && y[k] >= level)
        times.push_back(t[k - 1] + (level - y[k - 1]) * (t[k] - t[k - 1]) / (y[k] - y[k - 1]));
    return times;
  };
  double mean = 0;
  int count = 0;
  for (std::size_t k = 0; k < t.size(); ++k)
    if (t[k] >= half) mean += y[k], ++count;
  mean /= count;
  const auto window = upward_crossings(mean, half);
  Oscillation out;
  if (window.size() < 2) return out;
  double integral = 0;  // trapezoid over [first crossing, last crossing]
  for (std::size_t k = 1; k < t.size(); ++k)
    if (t[k - 1] >= window.front() && t[k] <= window.back()) integral += 0.5 * (y[k] + y[k - 1]) * (t[k] - t[k - 1]);
  out.equilibrium = integral / (window.back() - window.front());
  const auto all = upward_crossings(out.equilibrium, 0);
  out.frequency = (all.size() - 1) / (all.back() - all.front());
  return out;
}

// The lowest and highest value of metric column 2 (tip_dy) over [from, to].
std::array<double, 2> swing_range(const RunResult& result, double from, double to) {
  double lo = INFINITY, hi = -INFINITY;
  for (const auto& row : result.metrics)
    if (row[0] >= from && row[0] <= to) lo = std::min(lo, row[2]), hi = std::max(hi, row[2]);
  return {lo, hi};
}

// The step start kept for a retry (run/runner.cpp take_checked_step) is handed over by
// the step's particle sort instead of copied (simulation/state.h): after a step,
// return_to_step_start() gives back the particles exactly as they were, and the step
// taken again is the same bits as the first, with the solids' error estimate of the step
// before (solid_step_error on). Typed over 2-D and 3-D on the neutral block (free, so its
// particles accelerate).
template <class D>
class StepStartTest : public ::testing::Test {};
TYPED_TEST_SUITE(StepStartTest, testing::Dimensions);

template <int dim>
void expect_same_particles(const Particles<dim>& a, const Particles<dim>& b) {
  ASSERT_EQ(a.size(), b.size());
  EXPECT_TRUE(a.position == b.position && a.velocity == b.velocity && a.affine == b.affine);
  EXPECT_TRUE(a.mass == b.mass && a.initial_volume == b.initial_volume);
  EXPECT_TRUE(a.deformation_gradient == b.deformation_gradient && a.ghost_J == b.ghost_J);
  EXPECT_TRUE(a.body == b.body && a.initial_position == b.initial_position && a.acceleration == b.acceleration);
}

void expect_same_error(const SolidStepError& a, const SolidStepError& b) {
  EXPECT_EQ(a.dt, b.dt);
  EXPECT_TRUE(a.relative == b.relative || (std::isnan(a.relative) && std::isnan(b.relative)));
  EXPECT_EQ(a.displacement_scale, b.displacement_scale);
}

TYPED_TEST(StepStartTest, ReturnsTheExactStartAndRepeatsTheStep) {
  constexpr int dim = TypeParam::value;
  const testing::OneThread one_thread;
  std::vector<std::string> overrides{"solid_time_integration=\"midpoint\"", "solid_step_error=1e-3"};
  if (dim == 3) overrides.push_back("solver.method=\"ldlt\"");
  Simulation<dim> sim(read_scene(testing::submerged_block_document<dim>("neutral_block.json", overrides)));
  sim.step(0.002);  // particles that moved, so the next sort reorders them
  sim.step(0.002);  // and an error estimate
  const Particles<dim> fluid = sim.fluid(), solid = sim.solid();
  const SolidStepError error = sim.solid_step_error();
  ASSERT_GT(error.relative, 0);
  ASSERT_EQ(solid.acceleration.size(), solid.size());
  const Real time = sim.time();
  EXPECT_THROW(sim.return_to_step_start(), std::logic_error);  // nothing kept yet
  sim.keep_step_start();
  sim.step(0.001);  // another dt than the step before: the restored estimate is the earlier one
  const Particles<dim> fluid_after = sim.fluid(), solid_after = sim.solid();
  const SolidStepError error_after = sim.solid_step_error();
  sim.return_to_step_start();
  expect_same_particles(sim.fluid(), fluid);
  expect_same_particles(sim.solid(), solid);
  expect_same_error(sim.solid_step_error(), error);
  EXPECT_EQ(sim.time(), time);
  sim.step(0.001);
  expect_same_particles(sim.fluid(), fluid_after);
  expect_same_particles(sim.solid(), solid_after);
  expect_same_error(sim.solid_step_error(), error_after);
}

// benchmarks.md: plane-strain beam 3.386 mm (Euler-Bernoulli + shear), 10.7 Hz. Issue #3:
// within 3 % and 5 % at the default resolution, and the two models within 1 % of each
// other. 1 s of the 2 s benchmark (about 10 periods) keeps the test short.
TEST(SolidSimulationTest, CantileverMatchesBeamTheoryWithBothModels) {
  Oscillation by_model[2];
  const char* models[2] = {"fixed_corotated", "neo_hookean"};
  for (int m = 0; m < 2; ++m) {
    const RunResult result = run_scene(
        load_scene(scene_path("cantilever/cantilever.json"), {"end_time=1.0", std::string("solids.0.model=") + models[m]}), {});
    ASSERT_TRUE(result.ok) << result.summary["status"];
    ASSERT_EQ(result.columns[2], "tip_dy");
    by_model[m] = analyse(result, 2);
    EXPECT_NEAR(by_model[m].equilibrium, -3.386e-3, 0.03 * 3.386e-3) << models[m];
    EXPECT_NEAR(by_model[m].frequency, 10.7, 0.05 * 10.7) << models[m];
    EXPECT_GE(result.summary["newton_iterations"]["mean"].get<double>(), 1.0);
    EXPECT_GT(result.summary["solid_min_J"].get<double>(), 0.99);  // small strain
  }
  EXPECT_NEAR(by_model[0].equilibrium, by_model[1].equilibrium, 0.01 * std::abs(by_model[0].equilibrium));
  EXPECT_NEAR(by_model[0].frequency, by_model[1].frequency, 0.01 * by_model[0].frequency);
}

// Free vibration (issue 23 item 2, method.md#solid-time-integration): the cantilever released
// from rest swings about its sag at 10.7 Hz. At 40 steps a period (dt 2.34 ms) implicit Euler
// loses about 2 pi^2 / 40 of the amplitude a period; the midpoint rule keeps it, its
// frequency within 1 % of beam theory and its swing centred on the static sag (within 3 %).
// Measured over this 0.5 s: swing kept 0.6149 (implicit Euler) and 0.9998 (midpoint) a
// period, the peak-to-peak range over the third period against the first; midpoint frequency
// 10.686 Hz (-0.14 %, upward crossings), centre of the third period's swing -3.350 mm (-1.1 %).
// (The benchmark's figures, cantilever_vibration over 2 s, fit a damped sinusoid instead.)
TEST(SolidSimulationTest, MidpointRuleKeepsTheCantileversVibration) {
  const double period = 1 / 10.7, dt = period / 40;
  struct Swing {
    double kept_per_period, centre;
    Oscillation oscillation;
  };
  auto swing_of = [&](const char* rule) {
    const RunResult result =
        run_scene(load_scene(scene_path("cantilever/cantilever.json"),
                             {"end_time=0.5", "dt_max=" + std::to_string(dt), std::string("solid_time_integration=") + rule}),
                  {});
    EXPECT_TRUE(result.ok) << result.summary["status"];
    EXPECT_EQ(result.columns[2], "tip_dy");
    const auto first = swing_range(result, 0, period), third = swing_range(result, 2 * period, 3 * period);
    return Swing{std::sqrt((third[1] - third[0]) / (first[1] - first[0])), 0.5 * (third[0] + third[1]), analyse(result, 2)};
  };
  const Swing midpoint = swing_of("midpoint"), euler = swing_of("implicit_euler");
  std::cout << "[          ] swing kept a period at 40 steps a period: midpoint " << midpoint.kept_per_period
            << ", implicit Euler " << euler.kept_per_period << "; midpoint: frequency " << midpoint.oscillation.frequency
            << " Hz, centre " << midpoint.centre << " m\n";
  EXPECT_GT(midpoint.kept_per_period, 0.98);  // issue 23: amplitude loss below 2 % a period
  EXPECT_LT(midpoint.kept_per_period, 1.02);  // and no growth
  EXPECT_LT(euler.kept_per_period, 0.8);
  EXPECT_NEAR(midpoint.oscillation.frequency, 10.7, 0.01 * 10.7);
  EXPECT_NEAR(midpoint.centre, -3.386e-3, 0.03 * 3.386e-3);
}

// The time step that follows the solid (solid_step_error, method.md#solid-time-step): the
// cantilever released from rest under the midpoint rule with dt_max at its default 10 ms (9
// steps a period). Left to dt_max the vibration runs 2-3 % slow (its period error (omega
// dt)^2 / 12, with steps halved by the health checks); with solid_step_error = 1e-3 the
// estimate sets the step: frequency within 1 % of beam theory, swing kept within 2 % a period,
// and at least the 22 steps a period the first mode alone asks for at this tolerance (2 pi /
// (24 e)^(1/3): the swing's amplitude is half the largest displacement; the higher modes ask
// for more), at most 80. Measured over this 0.5 s: controlled 10.668 Hz (-0.30 %), 31.6 steps
// a period, swing kept 1.013, one step retaken (the second); uncontrolled 10.316 Hz (-3.6 %).
TEST(SolidSimulationTest, StepErrorControlResolvesTheCantileversVibration) {
  const testing::OneThread one_thread;  // spinning threads beside a busy core took 40x as long
  const double period = 1 / 10.7;
  struct Run {
    Oscillation oscillation;
    double kept_per_period, steps_per_period;
    long retakes, halvings;
  };
  auto run_with = [&](const std::string& tolerance) {
    const RunResult result = run_scene(load_scene(scene_path("cantilever/cantilever_vibration_adaptive.json"),
                                                  {"end_time=0.5", "solid_step_error=" + tolerance}),
                                       {});
    EXPECT_TRUE(result.ok) << result.summary["status"];
    EXPECT_EQ(result.columns[2], "tip_dy");
    const auto first = swing_range(result, 0, period), third = swing_range(result, 2 * period, 3 * period);
    return Run{analyse(result, 2), std::sqrt((third[1] - third[0]) / (first[1] - first[0])),
               result.summary["steps"].get<double>() * period / 0.5, result.summary["solid_error_retakes"].get<long>(),
               result.summary["dt_retries"].get<long>()};
  };
  const Run controlled = run_with("1e-3"), left_to_dt_max = run_with("0");
  std::cout << "[          ] solid_step_error 1e-3: " << controlled.oscillation.frequency << " Hz, "
            << controlled.steps_per_period << " steps a period, swing kept " << controlled.kept_per_period
            << " a period; at dt_max 10 ms: " << left_to_dt_max.oscillation.frequency << " Hz\n";
  EXPECT_NEAR(controlled.oscillation.frequency, 10.7, 0.01 * 10.7);
  EXPECT_NEAR(controlled.kept_per_period, 1, 0.02);
  EXPECT_GT(controlled.steps_per_period, 2 * M_PI / std::cbrt(24 * 1e-3));
  EXPECT_LT(controlled.steps_per_period, 80);
  EXPECT_LT(left_to_dt_max.oscillation.frequency, 0.98 * 10.7);
  // The second step, at 10 ms, has an estimate 20x the tolerance: it is taken again.
  EXPECT_GE(controlled.retakes, 1);
  EXPECT_EQ(controlled.halvings, 0);
  EXPECT_EQ(left_to_dt_max.retakes, 0);
}

// One OpenMP thread, as the coupled runs (run_helpers.h): the 3-D block drop took 40 s
// beside another test at 2 threads each, 1.3 s alone on one.
template <class D>
class SolidSimulationTest : public ::testing::Test {
 protected:
  static constexpr int dim = D::value;
  const testing::OneThread one_thread_;

  // A neo-Hookean block (E = 1e5 Pa) moving at 0.3 m/s along x in the unit box, dx 0.05;
  // lo and hi are its (x, y) corners, and in 3-D it spans `z` (lo, hi) along z.
  static Json block_scene(const std::vector<double>& lo, const std::vector<double>& hi, const std::array<double, 2>& z,
                          double end_time) {
    using testing::xyz;
    return {{"dim", dim},
            {"domain", {{"min", xyz<dim>(0, 0, 0)}, {"max", xyz<dim>(1, 1, 1)}}},
            {"dx", 0.05},
            {"end_time", end_time},
            {"solids", Json::array({{{"name", "block"}, {"model", "neo_hookean"}, {"youngs_modulus", 1e5},
                                     {"poisson_ratio", 0.3}, {"initial_velocity", xyz<dim>(0.3, 0, 0)},
                                     {"shapes", Json::array({testing::box(xyz<dim>(lo[0], lo[1], z[0]),
                                                                               xyz<dim>(hi[0], hi[1], z[1]))})}}})}};
  }
};
TYPED_TEST_SUITE(SolidSimulationTest, testing::Dimensions);

// Uniform translation has no strain: implicit Euler then gives v = v0 + g t exactly, F
// stays the identity and the ghost matrix stays unstressed (p_g = 0, J_g = 1).
TYPED_TEST(SolidSimulationTest, FreeFallIsExact) {
  constexpr int dim = TypeParam::value;
  Simulation<dim> sim(read_scene(this->block_scene({0.3, 0.6}, {0.5, 0.8}, {0.4, 0.6}, 0.2)));
  double t = 0;
  for (int step = 0; step < 20; ++step) {
    const double dt = 0.005;
    sim.step(dt);
    t += dt;
  }
  const auto& solid = sim.solid();
  for (std::size_t p = 0; p < solid.size(); ++p) {
    EXPECT_NEAR(solid.velocity[p][0], 0.3, 1e-9);
    EXPECT_NEAR(solid.velocity[p][1], -9.81 * t, 1e-9);
    if constexpr (dim == 3) {
      EXPECT_NEAR(solid.velocity[p][2], 0, 1e-9);
    }
    EXPECT_NEAR((solid.deformation_gradient[p] - Mat<dim>::Identity()).norm(), 0, 1e-9);
    EXPECT_NEAR(solid.ghost_J[p], 1, 1e-9);
  }
}

// solids[].particles_per_axis (method.md#solid-particles): a body seeds its own lattice, 3
// per axis here beside water at the scene's 2, each particle its share of the body's volume
// and mass; the water keeps its own seeding and stays out of the body.
TYPED_TEST(SolidSimulationTest, BodySeedsItsOwnParticlesPerAxis) {
  constexpr int dim = TypeParam::value;
  using testing::xyz;
  Json doc = this->block_scene({0.3, 0.6}, {0.5, 0.8}, {0.4, 0.6}, 0.1);
  doc["solids"][0]["particles_per_axis"] = 3;
  doc["fluid"] = {{"shapes", Json::array({testing::box(xyz<dim>(0, 0, 0), xyz<dim>(1, 0.3, 1))})}};
  const Simulation<dim> sim(read_scene(doc));
  const Real dx = 0.05, block_volume = dim == 2 ? 0.2 * 0.2 : 0.2 * 0.2 * 0.2;
  const Real block_cells = block_volume / std::pow(dx, dim), fluid_cells = 0.3 / std::pow(dx, dim);
  EXPECT_EQ(Real(sim.solid().size()), std::round(block_cells * std::pow(3, dim)));
  EXPECT_EQ(Real(sim.fluid().size()), std::round(fluid_cells * std::pow(2, dim)));
  Real mass = 0, volume = 0;
  for (std::size_t p = 0; p < sim.solid().size(); ++p) mass += sim.solid().mass[p], volume += sim.solid().initial_volume[p];
  EXPECT_NEAR(volume, block_volume, 1e-12);
  EXPECT_NEAR(mass, 1000 * block_volume, 1e-9);  // block_scene's density is the default 1000
  EXPECT_NEAR(sim.solid().initial_volume[0], std::pow(dx / 3, dim), 1e-15);
}

// gravity_ramp (method.md#gravity-ramp): gravity (1 - cos(pi t / T)) / 2 of its value up to
// T, then all of it; a body in free fall has v = g (t - T / 2) once the ramp is over (the
// ramp's integral is T / 2), here to the midpoint rule's error in the step's factor,
// pi^2 dt^2 / (48 T) g = 1e-3 m/s; without the ramp it would be g t, 0.245 m/s more.
TYPED_TEST(SolidSimulationTest, GravityRampDelaysAFreeFallByHalfItsLength) {
  constexpr int dim = TypeParam::value;
  Json doc = this->block_scene({0.3, 0.6}, {0.5, 0.8}, {0.4, 0.6}, 0.2);
  doc["gravity_ramp"] = 0.05;
  Simulation<dim> sim(read_scene(doc));
  const double dt = 0.005, ramp = 0.05;
  for (int step = 0; step < 20; ++step) sim.step(dt);
  const double t = 20 * dt;
  for (std::size_t p = 0; p < sim.solid().size(); ++p) {
    EXPECT_NEAR(sim.solid().velocity[p][1], -9.81 * (t - ramp / 2), 2e-3);
    EXPECT_NEAR(sim.solid().velocity[p][0], 0.3, 1e-9);
  }
}

// Ghost matrix (method.md §1, §5): after the solve, the p_g rows of the constraint hold,
//   S (p_g^{n+1} - p_g^n) / dt = G^sT v_s^{n+1},
// to the direct solver's precision (auto is LDL^T in 2-D; named in 3-D, where auto is
// CG), on a block compressed against the floor.
TYPED_TEST(SolidSimulationTest, GhostMatrixConstraintHoldsAfterTheSolve) {
  constexpr int dim = TypeParam::value;
  Json doc = this->block_scene({0.3, 0.0}, {0.7, 0.3}, {0.3, 0.7}, 1.0);
  doc["solids"][0]["ghost_stiffness"] = 1e6;
  doc["solids"][0]["initial_velocity"] = testing::xyz<dim>(0.0, -0.5, 0.0);
  if (dim == 3) doc["solver"] = {{"method", "ldlt"}};
  Simulation<dim> sim(read_scene(doc));
  for (int step = 0; step < 5; ++step) sim.step(0.01);
  const PressureSystem& system = sim.pressure_system();
  const PressureSystem::Block* ghost = system.find("p_g");
  ASSERT_NE(ghost, nullptr);
  EXPECT_EQ(system.find("p_f"), nullptr);  // solid only: no fluid blocks
  const Eigen::VectorXd v = sim.grid_velocity_after_projection();
  const Eigen::VectorXd lambda = sim.pressure_solution();
  // D v^{n+1} = C lambda - offset, with offset = rhs(v) - D v: checked as A lambda = rhs(v*).
  const Eigen::VectorXd residual = system.matrix() * lambda - system.rhs(sim.grid_velocity_before_projection());
  const Eigen::VectorXd rhs = system.rhs(sim.grid_velocity_before_projection());
  EXPECT_LT(residual.norm(), 1e-9 * rhs.norm());
  // The block is squeezed: a non-trivial ghost pressure, positive (compression) on average.
  EXPECT_GT(lambda.segment(ghost->offset, ghost->size).mean(), 0);
  // Velocity recovery: the corrected velocity is v* - dt M^-1 D^T lambda.
  EXPECT_LT((system.corrected_velocity(sim.grid_velocity_before_projection(), lambda) - v).norm(), 1e-12 * (1 + v.norm()));
}

// solid_weak_nodes = extended holds through the whole step (method.md#weak-solid-nodes): a
// disk (ball) dropped onto the floor, so that it deforms, its ghost matrix is loaded and
// the floor holds nodes. After every step the weak nodes' final velocities are their
// blocks' extrapolation (G2P reads them), and the pressure system's columns of the weak
// nodes are empty (their constraint entries moved to the blocks). Either wiring left out
// lets the weak nodes relieve the face particles through the pressure step (a slanted
// beam's sag then crept, method.md#weak-solid-nodes).
TYPED_TEST(SolidSimulationTest, WeakNodesFollowTheirBlocksThroughTheStep) {
  constexpr int dim = TypeParam::value;
  Json doc = this->block_scene({0.3, 0.0}, {0.7, 0.3}, {0.3, 0.7}, 1.0);
  doc["solids"][0]["shapes"] = Json::array({{{"type", "sphere"}, {"centre", testing::xyz<dim>(0.5, 0.17, 0.5)}, {"radius", 0.13}}});
  doc["solids"][0]["initial_velocity"] = testing::xyz<dim>(0.0, -1.0, 0.0);
  doc["solid_weak_nodes"] = "extended";
  Simulation<dim> sim(read_scene(doc));
  const PressureSystem& system = sim.pressure_system();
  int extended = 0;
  for (int step = 0; step < 8; ++step) {
    sim.step(0.01);
    const WeakSolidNodes& weak = sim.weak_solid_nodes();
    EXPECT_EQ(sim.last_step().extended_solid_nodes, weak.size());
    extended += weak.size();
    const std::vector<Vec<dim>>& v = sim.solid_node_velocity();
    Real scale = 0;
    for (const Vec<dim>& x : v) scale = std::max(scale, x.norm());
    for (int i = 0; i < weak.size(); ++i) {
      Vec<dim> extrapolated = Vec<dim>::Zero();
      for (int j = weak.parent_start[i]; j < weak.parent_start[i + 1]; ++j) extrapolated += weak.weight[j] * v[weak.parent[j]];
      EXPECT_LT((v[weak.node[i]] - extrapolated).norm(), 1e-12 * scale) << "step " << step << ", weak node " << weak.node[i];
      const int dof = sim.solid_operators().dof_of_node[weak.node[i]];
      ASSERT_GE(dof, 0);
      for (int a = 0; a < dim; ++a) {
        Eigen::VectorXd unit = Eigen::VectorXd::Zero(sim.grid_velocity_after_projection().size());
        unit[dof * dim + a] = 1;
        EXPECT_EQ(system.full_constraint_times(unit).norm(), 0) << "step " << step << ", weak node " << weak.node[i];
      }
    }
  }
  EXPECT_GT(extended, 8 * (dim == 2 ? 4 : 20));  // a ball across the grid has weak nodes at every step
  EXPECT_LT(sim.last_step().solid_min_J, 0.999);     // and it was squeezed by the floor
}

// Clamp: the quadratic velocity field vanishes on the clamp region [0, 0.05] of the
// cantilever, so the particles there never move. In 3-D the cantilever is extruded 4
// cells deep at dx 0.025 instead of 0.0125 (at 0.0125: 60 s).
TYPED_TEST(SolidSimulationTest, ClampedRegionDoesNotMove) {
  constexpr int dim = TypeParam::value;
  const Real dx = dim == 2 ? 0.0125 : 0.025;
  const Json cantilever = testing::benchmark_document("cantilever/cantilever.json", {"dx=" + std::to_string(dx)});
  Simulation<dim> sim(read_scene(testing::in_dim<dim>(cantilever, 4 * dx)));
  for (int step = 0; step < 100; ++step) sim.step(1e-3);
  const auto& solid = sim.solid();
  int clamped = 0;
  double largest_speed = 0, tip_speed = 0;
  for (std::size_t p = 0; p < solid.size(); ++p) {
    if (solid.position[p][0] < 0.05) {
      ++clamped;
      largest_speed = std::max(largest_speed, solid.velocity[p].norm());
    }
    if (solid.position[p][0] > 0.5) tip_speed = std::max(tip_speed, solid.velocity[p].norm());
  }
  // 0.05 m x 0.05 m (x 4 dx) at a particle spacing of dx/2: 8 x 8 particles in 2-D
  const int across = int(std::lround(0.05 / (dx / 2)));
  EXPECT_EQ(clamped, dim == 2 ? across * across : across * across * 8);
  EXPECT_EQ(largest_speed, 0.0);
  EXPECT_GT(tip_speed, 1e-3);  // while the free end swings
}

// Stability (issue #3): a neo-Hookean block dropped onto the floor at the CFL time step:
// no NaN, no inverted particle, nothing pushed back through a wall or through the floor, no
// sideways drift of the symmetric drop, and it comes to rest on the floor (about a cell
// above it: grid contact). 2-D: the stability/block_drop benchmark (E = 1e6 Pa, dropped
// from 0.5 m, dx 0.02) for 1 s; 3-D (Newton with diagonal PCG): a cube of side 0.2 m, dx
// 0.05, dropped 0.25 m, for 0.6 s. Smallest det F: above 0.5 in 2-D, 0.8 in 3-D.
TYPED_TEST(SolidSimulationTest, DroppedBlockLandsAndRests) {
  constexpr int dim = TypeParam::value;
  SceneSpec scene;
  double end_time = 0, min_J_floor = 0;
  if constexpr (dim == 2) {
    scene = load_scene(scene_path("stability/block_drop.json"), {"end_time=1.0"});
    end_time = 1.0, min_J_floor = 0.5;
  } else {
    const Json doc = {
        {"dim", 3},
        {"domain", {{"min", {0.0, 0.0, 0.0}}, {"max", {0.5, 0.5, 0.5}}}},
        {"dx", 0.05},
        {"end_time", 0.6},
        {"gravity", {0.0, -9.81, 0.0}},
        {"solids", Json::array({{{"model", "neo_hookean"}, {"youngs_modulus", 1e6}, {"poisson_ratio", 0.3},
                                 {"shapes", Json::array({{{"type", "box"}, {"min", {0.15, 0.25, 0.15}}, {"max", {0.35, 0.45, 0.35}}}})}}})}};
    scene = read_scene(doc);
    end_time = 0.6, min_J_floor = 0.8;
  }
  Simulation<dim> sim(scene);
  const TimeStepPolicy policy(scene);
  double t = 0, min_J = 1;
  int wall_clamps = 0;
  // dt from the CFL rule only (no clamp to the end time, which the runner's loop applies):
  // a sudden dt change on a body at rest starts a small transient (the elastic/ghost-matrix
  // splitting), which is not what this test measures.
  while (t < end_time) {
    const double dt = policy.stable_dt(sim);
    sim.step(dt);
    t += dt;
    min_J = std::min(min_J, double(sim.last_step().solid_min_J));
    wall_clamps += sim.last_step().wall_clamps;
  }
  EXPECT_GT(min_J, min_J_floor);
  EXPECT_EQ(wall_clamps, 0);  // nothing pushed back through a wall
  const auto& solid = sim.solid();
  double lowest = 1, fastest = 0;
  for (std::size_t p = 0; p < solid.size(); ++p) {
    lowest = std::min(lowest, double(solid.position[p][1]));
    fastest = std::max(fastest, solid.velocity[p].norm());
    ASSERT_TRUE(solid.deformation_gradient[p].allFinite());
  }
  const Real centre = 0.5 * (scene.domain_min[0] + scene.domain_max[0]);
  const Vec<dim> com = body_centre_of_mass(sim, 0);
  for (int a = 0; a < dim; ++a)
    if (a != 1) {
      EXPECT_NEAR(com[a], centre, 1e-9) << "axis " << a;  // symmetric drop: no sideways drift
    }
  EXPECT_GT(lowest, 0);                   // nothing through the floor
  EXPECT_LT(lowest, 2.0 * sim.grid().dx); // landed: it started 0.5 (2-D) or 0.25 m (3-D) up
  EXPECT_LT(fastest, 1e-3);               // and rests
}

// Stability: the cantilever with E = 1e5 Pa sags to large deflection and touches the
// floor, with both models, at cfl 0.5 and dt_max 0.01 s.
TEST(SolidSimulationTest, SoftBeamSagsWithoutInversion) {
  for (const char* model : {"fixed_corotated", "neo_hookean"}) {
    const RunResult result = run_scene(
        load_scene(scene_path("stability/soft_beam.json"), {"end_time=1.5", std::string("solids.0.model=") + model}), {});
    ASSERT_TRUE(result.ok) << model << ": " << result.summary["status"];
    EXPECT_GT(result.summary["solid_min_J"].get<double>(), 0.3) << model;
    const auto& last = result.metrics.back();
    EXPECT_LT(last[2], -0.15) << model;  // tip_dy: large deflection (the beam starts 0.2 m up)
    EXPECT_EQ(result.summary["wall_clamps"].get<int>(), 0) << model;
  }
}

}  // namespace
}  // namespace iqmpm
