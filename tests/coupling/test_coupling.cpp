// Coupling (issue #4, method.md §3 step 3, §4, §5, §7): the fluid's weight is not counted
// twice by the interface quadrature, the buoyancy of a clamped block, and the hydrostatic
// force on the free part of a (stiff) gate measured by a region of a body.
#include <algorithm>
#include <cmath>
#include <tuple>

#include <gtest/gtest.h>
#include <omp.h>

#include "core/errors.h"
#include "diagnostics/probes.h"
#include "scene/scene.h"
#include "run/runner.h"
#include "diagnostics/measurements.h"
#include "simulation/simulation.h"

namespace iqmpm {
namespace {

std::string scene_path(const std::string& relative) { return std::string(IQMPM_BENCHMARKS_DIR) + "/" + relative; }

// Mean of a metrics column over t in [from, to].
double column_mean(const RunResult& result, const std::string& name, double from, double to) {
  int column = -1;
  for (std::size_t c = 0; c < result.columns.size(); ++c)
    if (result.columns[c] == name) column = int(c);
  EXPECT_GE(column, 0) << name;
  double sum = 0;
  int count = 0;
  for (const auto& row : result.metrics)
    if (row[0] >= from && row[0] <= to) sum += row[column], ++count;
  return count > 0 ? sum / count : NAN;
}

// ctest runs two tests at a time on CI's 2 cores. The two long coupled runs below, at 2
// OpenMP threads each side by side, took 250 and 310 s (measured; 25 and 57 s alone on one
// thread), so they run on one thread.
struct OneThread {
  int previous = omp_get_max_threads();
  OneThread() { omp_set_num_threads(1); }
  ~OneThread() { omp_set_num_threads(previous); }
};

// IQ points borrow volume, not mass (docs/method.md#borrowed-volume): M^f holds exactly
// the water's mass. (Lent mass, the reference code's, weighed it a second time in the
// lenders' full cells.)
TEST(CouplingTest, FluidMassMatrixHoldsTheWaterOnce) {
  Simulation<2> sim(load_scene(scene_path("submerged_block/submerged_block.json"), {}));
  double water = 0;
  for (double m : sim.fluid().mass) water += m;
  sim.step(0.001);
  ASSERT_GT(sim.interface_points(), 0);
  double mass_matrix = 0;
  for (double m : sim.fluid_operators().mass) mass_matrix += m;
  EXPECT_NEAR(mass_matrix, water, 1e-10 * water);
}

// solids[].initial_pressure = hydrostatic: the ghost matrix starts at the still water's
// pressure rho_f g (level - y), level the top of the fluid particles (0.5 m here), so the
// neutrally buoyant block starts in balance with the water. Unstressed, the water squeezes
// it through the soft ghost matrix: its first-step interface force was 71 N/m against its
// 196.2 N/m weight (measured 175 N/m on the first step with the option, and the mean over
// the first 20 steps within 0.5 %).
TEST(CouplingTest, HydrostaticGhostPressureStartsASubmergedBlockInBalance) {
  const std::string scene = scene_path("submerged_block/neutral_block.json");
  Simulation<2> sim(load_scene(scene, {}));
  ASSERT_EQ(sim.scene().solids[0].initial_pressure, InitialPressure::hydrostatic);
  const double rho_g = 1000 * 9.81, lambda_g = sim.scene().solids[0].ghost_stiffness;
  for (std::size_t p = 0; p < sim.solid().size(); ++p)
    ASSERT_NEAR(sim.solid().ghost_J[p], 1 - rho_g * (0.5 - sim.solid().position[p][1]) / lambda_g, 1e-12);
  const double weight = rho_g * 0.2 * 0.1;
  double first = 0, sum = 0;
  const int steps = 20;
  for (int n = 0; n < steps; ++n) {
    sim.step(0.00025);
    const double force = body_interface_force(sim, 0)[1];
    if (n == 0) first = force;
    sum += force;
  }
  EXPECT_NEAR(first, weight, 0.15 * weight);
  EXPECT_NEAR(sum / steps, weight, 0.02 * weight);
  // It needs water to stand in.
  EXPECT_THROW(Simulation<2>(load_scene(scene, {"fluid.shapes=[]"})), InputError);
}

// coupling.interface_reach = 0.6 (the floating and neutral-block scenes'): the seeded water
// and block lattices meet exactly 0.5 dx apart. At the default reach of 0.5 dx, sub-micron
// motions break those ties: the clamped block's interface cells went 44, 38, 44 over the
// first steps and its force flickered (std 18.5 N/m over 0.1-0.3 s). At 0.6 dx the
// interface holds (measured std 0.39 N/m).
TEST(CouplingTest, InterfaceHoldsOnAlignedLatticesWithReach06) {
  const OneThread one_thread;
  Simulation<2> sim(load_scene(scene_path("submerged_block/submerged_block.json"), {"coupling.interface_reach=0.6"}));
  int first_count = -1;
  std::vector<double> forces;
  for (int n = 0; n < 300; ++n) {
    sim.step(0.001);
    const int count = sim.interface_operators().multipliers();
    if (n == 0) first_count = count;
    if (n < 20) {
      EXPECT_EQ(count, first_count) << "step " << n + 1;
    }
    if (n >= 100) forces.push_back(body_interface_force(sim, 0)[1]);
  }
  double mean = 0, square = 0;
  for (double f : forces) mean += f / forces.size();
  for (double f : forces) square += (f - mean) * (f - mean) / forces.size();
  const double buoyancy = 1000 * 9.81 * 0.2 * 0.1;
  EXPECT_NEAR(mean, buoyancy, 0.02 * buoyancy);
  EXPECT_LT(std::sqrt(square), 5.0);
}

// Buoyancy of the clamped block (benchmarks.md submerged_block): rho_f g V = 196.2 N/m
// within 2 % (the criterion), averaged over 0.1-0.3 s at dt = 1 ms.
TEST(CouplingTest, SubmergedBlockBuoyancy) {
  SceneSpec scene = load_scene(scene_path("submerged_block/submerged_block.json"), {"end_time=0.3", "dt_max=0.001"});
  scene.frame_rate = 0;
  const RunResult result = run_scene(scene, {});
  ASSERT_TRUE(result.ok) << result.summary.dump();
  const double buoyancy = 1000 * 9.81 * 0.2 * 0.1;
  EXPECT_NEAR(column_mean(result, "block_force_y", 0.1, 0.3), buoyancy, 0.02 * buoyancy);
  EXPECT_NEAR(column_mean(result, "block_force_x", 0.1, 0.3), 0, 1e-6);
}

// The rest test: a free block as dense as the water (benchmarks/submerged_block/
// neutral_block.json, dt_max 0.25 ms, with the floating scenes' coupling: corner fraction
// 0.75, interface reach 0.6, hydrostatic initial ghost pressure) still rests after 1 s: its
// speed over 0.9-1 s stays below 1e-3 m/s and its centre within 1 mm of where it started
// (measured 0.54 mm/s and 0.45 mm; it keeps sinking slowly, 1.08 mm at 2 s). At dt 1 ms
// it fails (3.6 mm/s; docs/method.md#12-known-limits).
TEST(CouplingTest, NeutralBlockStaysAtRest) {
  const OneThread one_thread;
  SceneSpec scene = load_scene(scene_path("submerged_block/neutral_block.json"), {});
  scene.frame_rate = 0;
  const RunResult result = run_scene(scene, {});
  ASSERT_TRUE(result.ok) << result.summary.dump();
  int velocity = -1, height = -1;
  for (std::size_t c = 0; c < result.columns.size(); ++c) {
    if (result.columns[c] == "block_velocity_y") velocity = int(c);
    if (result.columns[c] == "com_y") height = int(c);
  }
  ASSERT_GE(velocity, 0);
  ASSERT_GE(height, 0);
  double late_speed = 0, drift = 0;
  for (const auto& row : result.metrics) {
    if (row[0] >= 0.9) late_speed = std::max(late_speed, std::abs(row[velocity]));
    drift = std::max(drift, std::abs(row[height] - 0.25));
  }
  EXPECT_LT(late_speed, 1e-3);
  EXPECT_LT(drift, 1e-3);
}

// The floating block (benchmarks.md floating_block, heave case; its scene sets
// coupling.solid_corner_fraction = 0.75) at dx 0.02: the still-water level (water_level
// probe, x = 0.02-0.3 m) minus the block's bottom (centre - 0.05 m), averaged over the
// last 2 s of 5, is the Archimedes draft 0.05 m within 2 % (the criterion;
// measured +0.06 %, 5 water particles inside the block's outline at 5 s), and the water
// volume stays within 1 %. With the option
// off, water creeps under the heaving block through the corners a stray particle frees:
// +29 %, 32 particles inside (docs/method.md#solid-corners).
TEST(CouplingTest, FloatingBlockFloatsAtItsArchimedesDraft) {
  const OneThread one_thread;
  SceneSpec scene = load_scene(scene_path("floating_block/floating_block.json"), {"dx=0.02"});
  ASSERT_EQ(scene.coupling.solid_corner_fraction, 0.75);
  scene.frame_rate = 0;
  const RunResult result = run_scene(scene, {});
  ASSERT_TRUE(result.ok) << result.summary.dump();
  const double draft = column_mean(result, "water_level", 3.0, 5.0) - column_mean(result, "com_y", 3.0, 5.0) + 0.05;
  EXPECT_NEAR(draft, 0.05, 0.02 * 0.05);
  // Water volume (the region the water fills) within 1 % of its start at every step (the
  // issue's criterion; measured -0.57 to +0.45 %, -0.04 % at 5 s; the particle measure,
  // which falls as particles cluster, ends at -4.7 %).
  int volume = -1;
  for (std::size_t c = 0; c < result.columns.size(); ++c)
    if (result.columns[c] == "volume") volume = int(c);
  ASSERT_GE(volume, 0);
  double worst_drift = 0;
  for (const auto& row : result.metrics)
    worst_drift = std::max(worst_drift, std::abs(row[volume] / result.metrics.front()[volume] - 1));
  EXPECT_LT(worst_drift, 0.01);
}

// The plate variant of submerged_block (benchmarks.md): the elastic gate 1000 times stiffer
// (E = 12 GPa). The force on its free part (a region of the body, y < 0.079 m) must be the
// hydrostatic integral 77.9 N/m within 2 %; free part and clamped wall part together carry
// rho_f g H^2 / 2 of the 0.14 m column. With the lumped solid mass in the solve (system
// (36)) this needs dt of order dx sqrt(rho_s / p) (the scene's 0.25 ms; at 1 ms the tip
// wanders 3 mm and the force is 165 +- 239 N/m); with the Newton Hessian in the solve
// (coupling.solid_response = stiffness) it holds at dt 1 ms (measured 77.65 +- 3.1 N/m).
// Bilateral interface (the gate scene's is unilateral; at 1 ms its active set chatters on
// the downstream face: 5.9 solves a step, force 63-110 N/m).
class StiffGateTest : public ::testing::TestWithParam<std::pair<const char*, const char*>> {};
INSTANTIATE_TEST_SUITE_P(SolidResponse, StiffGateTest,
                         ::testing::Values(std::make_pair("mass", "0.00025"), std::make_pair("stiffness", "0.001")),
                         [](const auto& info) { return std::string(info.param.first); });

TEST_P(StiffGateTest, CarriesTheHydrostaticForce) {
  SceneSpec scene = load_scene(scene_path("elastic_gate/elastic_gate.json"),
                               {"end_time=0.05", "solids.0.youngs_modulus=12e9", "coupling.interface=\"bilateral\"",
                                std::string("experimental.solid_response=\"") + GetParam().first + "\"",
                                std::string("dt_max=") + GetParam().second});
  scene.frame_rate = 0;
  const RunResult result = run_scene(scene, {});
  ASSERT_TRUE(result.ok) << result.summary.dump();
  const double gate = 1000 * 9.81 * (0.14 * 0.079 - 0.079 * 0.079 / 2);  // 77.9 N/m
  const double column = 1000 * 9.81 * 0.14 * 0.14 / 2;
  const double free_part = column_mean(result, "gate_force_x", 0.02, 0.05);
  EXPECT_NEAR(free_part, gate, 0.02 * gate);
  EXPECT_NEAR(free_part + column_mean(result, "wall_part_force_x", 0.02, 0.05), column, 0.02 * column);
  // The stiff gate hardly moves: beam theory gives 3e-5 m at its tip.
  EXPECT_LT(std::abs(column_mean(result, "gate_tip_dx", 0.02, 0.05)), 1e-4);
}

// Still water against a fixed wall standing on the floor stays still: the elastic_gate scene
// with its whole gate clamped, run 0.5 s with the scene's coupling. The water must rest
// (largest speed over 0.4-0.5 s below 1e-3 m/s, the neutral block's criterion), push on
// the gate's lower part with the hydrostatic 77.9 N/m (1 %) without noise, and none of it
// may reach the far side. Measured 0.35 mm/s, 77.72 +- 0.01 N/m, none through. With the
// default coupling (corner fraction 0, reach 0.5) a current runs down the wall and grows
// to 0.55 m/s, the force scatters by 24 N/m and water leaks through at the floor; without
// the wall reflection of the IQ normals (mass_reflected_across_walls) 2.0 mm/s.
TEST(CouplingTest, StillWaterRestsAgainstTheClampedGate) {
  const OneThread one_thread;
  // At 0.25 ms, 2.5 times the scene's dt_max, to keep the test short (the water is still).
  const SceneSpec scene =
      load_scene(scene_path("elastic_gate/elastic_gate.json"), {"solids.0.clamps.0.min=[0.1,0]", "dt_max=0.00025"});
  Simulation<2> sim(scene);
  const Probes<2> probes(scene, sim);
  std::size_t force_probe = probes.size();
  for (std::size_t i = 0; i < probes.size(); ++i)
    if (probes.name(i) == "gate_force_x") force_probe = i;
  ASSERT_LT(force_probe, probes.size());
  const double gate = 1000 * 9.81 * (0.14 * 0.079 - 0.079 * 0.079 / 2);  // 77.9 N/m
  double largest_speed = 0, force_sum = 0, worst_force = 0;
  int force_count = 0;
  for (int s = 1; s <= 2000; ++s) {  // 0.5 s
    sim.step(scene.dt_max);
    const double t = s * scene.dt_max;
    if (t >= 0.4)
      for (const auto& v : sim.fluid().velocity) largest_speed = std::max(largest_speed, double(v.norm()));
    if (t >= 0.1) {
      const double force = probes.evaluate(sim, force_probe);
      force_sum += force, ++force_count;
      worst_force = std::max(worst_force, std::abs(force - gate));
    }
  }
  EXPECT_LT(largest_speed, 1e-3);
  EXPECT_NEAR(force_sum / force_count, gate, 0.01 * gate);
  EXPECT_LT(worst_force, 0.05 * gate);
  int beyond = 0;
  for (const auto& x : sim.fluid().position) beyond += x[0] > 0.1;
  EXPECT_EQ(beyond, 0);
}

// A body flush against a slip wall: the wall mirrors it for the coupling's geometry (IQ
// normals, mass_reflected_across_walls). The heaving block of floating_block extruded to
// 3-D between the two z walls (dx 0.05, 4 cells deep, dt 1 ms, solid_corner_fraction 0 in
// both) is a 2-D flow, so its centre must sit where the 2-D block's does, within 0.1 dx
// over 1.8-3 s. Measured 0.4573 against 0.4565 m; without the reflection the normals by
// the walls tilt towards them, water runs in along the walls and the block sits 21.5 mm
// lower (0.4358 m).
TEST(CouplingTest, BlockBetweenTheZWallsFloatsLikeTheTwoDimensionalBlock) {
  const OneThread one_thread;
  SceneSpec flat = load_scene(scene_path("floating_block/floating_block.json"),
                              {"dx=0.05", "end_time=3", "coupling.solid_corner_fraction=0"});
  flat.frame_rate = 0;
  const RunResult flat_result = run_scene(flat, {});
  ASSERT_TRUE(flat_result.ok) << flat_result.summary.dump();
  SceneSpec extruded = load_scene(
      scene_path("floating_block_3d/floating_block_3d.json"),
      {"domain.max=[1,0.75,0.2]", "fluid.shapes.0.max=[1,0.5,0.2]", "solids.0.shapes.0.min=[0.4,0.47,0]",
       "solids.0.shapes.0.max=[0.6,0.57,0.2]", "coupling.solid_corner_fraction=0", "end_time=3", "dt_max=0.001"});
  extruded.frame_rate = 0;
  const RunResult extruded_result = run_scene(extruded, {});
  ASSERT_TRUE(extruded_result.ok) << extruded_result.summary.dump();
  EXPECT_NEAR(column_mean(extruded_result, "com_y", 1.8, 3.0), column_mean(flat_result, "com_y", 1.8, 3.0), 0.1 * 0.05);
}

// Free slip, not sticky (method.md §1): a layer of water moving at 1 m/s along a clamped
// plate it rests on (no walls at the ends) spreads under gravity but is hardly slowed, and
// the layer touching the plate moves on with the rest (a sticky interface would hold it).
// Measured: 0.23 % of the horizontal momentum goes to the plate in 0.2 s, through the
// borrowed quadrature of the interface cells where the pressure varies along the plate
// (at the layer's ends). With the former defaults (reach 0.5, no solid corners, particle
// quadrature at the surface): with the validated coupling the plate takes 5.8 % (reach
// 0.6) and the centre quadrature 2.7 % (docs/method.md#12-known-limits).
TEST(CouplingTest, WaterSlidesAlongAClampedPlate) {
  const Json doc = {
      {"dim", 2}, {"domain", {{"min", {0.0, 0.0}}, {"max", {2.0, 0.5}}}}, {"walls", {{"x-", "none"}, {"x+", "none"}}},
      {"coupling", {{"interface_reach", 0.5}, {"solid_corner_fraction", 0}}},
      {"dx", 0.0125}, {"end_time", 0.2}, {"dt_max", 0.002},
      {"fluid", {{"shapes", Json::array({{{"type", "box"}, {"min", {0.3, 0.1}}, {"max", {0.7, 0.2}}}})},
                 {"initial_velocity", {1.0, 0.0}}, {"surface_quadrature", "particles"}}},
      {"solids", Json::array({{{"name", "plate"}, {"youngs_modulus", 1e8}, {"poisson_ratio", 0.3},
                               {"shapes", Json::array({{{"type", "box"}, {"min", {0.0, 0.05}}, {"max", {2.0, 0.1}}}})},
                               {"clamps", Json::array({{{"type", "box"}, {"min", {0.0, 0.05}}, {"max", {2.0, 0.1}}}})}}})}};
  Simulation<2> sim(read_scene(doc));
  auto horizontal_momentum = [&](double below) {
    double momentum = 0, mass = 0;
    for (std::size_t p = 0; p < sim.fluid().size(); ++p)
      if (sim.fluid().position[p][1] < below) momentum += sim.fluid().mass[p] * sim.fluid().velocity[p][0], mass += sim.fluid().mass[p];
    return std::make_pair(momentum, mass);
  };
  const double start = horizontal_momentum(1).first;
  int coupled_steps = 0;
  for (int s = 0; s < 100; ++s) {
    sim.step(0.002);
    coupled_steps += sim.interface_points() > 0;
  }
  EXPECT_GT(coupled_steps, 90);  // the water rested on the plate
  const auto [momentum, mass] = horizontal_momentum(1);
  EXPECT_NEAR(momentum, start, 0.01 * start);
  const auto [bottom_momentum, bottom_mass] = horizontal_momentum(0.1 + 0.0125);
  ASSERT_GT(bottom_mass, 0);
  EXPECT_NEAR(bottom_momentum / bottom_mass, momentum / mass, 0.01);  // the bottom layer keeps the mean speed
}

// Momentum (method.md §6, §5): water thrown at a free block, no gravity, nothing touching a
// wall: the total momentum of fluid plus solid stays what it was while the block is pushed.
// Without solid corners (measured: 0.06 % at the impact, where the fluid's projection mass
// M^f, from the quadrature, differs from the transfer mass). Fluid corners that move with
// the solid (the default fraction 0.75) hand their velocity to stray fluid particles
// without an exchange of momentum: measured +0.24 %, held below 0.5 %.
TEST(CouplingTest, MomentumIsConservedWhenWaterHitsAFreeBlock) {
  for (const double corner_fraction : {0.0, 0.75}) {
    Json doc = {
        {"dim", 2}, {"domain", {{"min", {0.0, 0.0}}, {"max", {1.0, 0.5}}}}, {"gravity", {0.0, 0.0}}, {"dx", 0.0125},
        {"end_time", 0.15}, {"dt_max", 0.002},
        {"fluid", {{"shapes", Json::array({{{"type", "box"}, {"min", {0.1, 0.1}}, {"max", {0.3, 0.3}}}})},
                   {"initial_velocity", {1.0, 0.0}}}},
        {"solids", Json::array({{{"name", "block"}, {"density", 500}, {"youngs_modulus", 1e6}, {"poisson_ratio", 0.3},
                                 {"shapes", Json::array({{{"type", "box"}, {"min", {0.35, 0.15}}, {"max", {0.45, 0.25}}}})}}})}};
    doc["coupling"] = {{"solid_corner_fraction", corner_fraction}};
    Simulation<2> sim(read_scene(doc));
    auto total = [&](const Particles<2>& particles) {
      Vec<2> sum = Vec<2>::Zero();
      for (std::size_t p = 0; p < particles.size(); ++p) sum += particles.mass[p] * particles.velocity[p];
      return sum;
    };
    const Vec<2> start = total(sim.fluid()) + total(sim.solid());
    for (int s = 0; s < 75; ++s) sim.step(0.002);
    const Vec<2> block = total(sim.solid());
    const Vec<2> end = total(sim.fluid()) + block;
    EXPECT_GT(block[0], 0.05 * start[0]);  // the water pushed the block
    EXPECT_NEAR(end[0], start[0], (corner_fraction > 0 ? 5e-3 : 1e-3) * start[0]) << "corner fraction " << corner_fraction;
    EXPECT_NEAR(end[1], 0, 1e-9 * start[0]);  // mirror symmetry about the block's centre line
  }
}

// Separation (method.md §9): a block leaving the water it touches, no gravity. With the
// bilateral constraint the water is held to the block (suction: negative h, and negative
// p_f in the cells whose corners move with the block) and dragged along; with
// coupling.interface = unilateral those rows are released, the water stays at rest and
// the block keeps its speed, and no h is negative.
TEST(CouplingTest, UnilateralInterfaceLetsWaterSeparate) {
  auto run = [](const std::string& interface) {
    const Json doc = {
        {"dim", 2}, {"domain", {{"min", {0.0, 0.0}}, {"max", {1.0, 1.0}}}}, {"gravity", {0.0, 0.0}}, {"dx", 0.0125},
        {"end_time", 0.02}, {"coupling", {{"interface", interface}}},
        {"fluid", {{"shapes", Json::array({{{"type", "box"}, {"min", {0.2, 0.3}}, {"max", {0.4, 0.6}}}})}}},
        {"solids", Json::array({{{"name", "block"}, {"density", 500}, {"youngs_modulus", 1e6}, {"poisson_ratio", 0.3},
                                 {"initial_velocity", {0.5, 0.0}},
                                 {"shapes", Json::array({{{"type", "box"}, {"min", {0.4, 0.35}}, {"max", {0.5, 0.55}}}})}}})}};
    Simulation<2> sim(read_scene(doc));
    sim.step(0.002);
    EXPECT_GT(sim.interface_points(), 0) << interface;
    const PressureSystem::Block* h = sim.pressure_system().find("h");
    EXPECT_NE(h, nullptr);
    const Real smallest_h = h ? sim.pressure_solution().segment(h->offset, h->size).minCoeff() : 0;
    for (int s = 0; s < 9; ++s) sim.step(0.002);
    Real fluid = 0, block = 0;
    for (std::size_t p = 0; p < sim.fluid().size(); ++p) fluid += sim.fluid().mass[p] * sim.fluid().velocity[p][0];
    for (std::size_t p = 0; p < sim.solid().size(); ++p) block += sim.solid().mass[p] * sim.solid().velocity[p][0];
    return std::make_tuple(smallest_h, fluid, block);
  };
  const Real block_momentum = 500 * 0.1 * 0.2 * 0.5;
  const auto [h_bilateral, fluid_bilateral, block_bilateral] = run("bilateral");
  EXPECT_LT(h_bilateral, 0);                                // suction on the first step
  EXPECT_GT(fluid_bilateral, 0.05 * block_momentum);        // water dragged along
  EXPECT_LT(block_bilateral, 0.95 * block_momentum);        // and the block held back
  const auto [h_unilateral, fluid_unilateral, block_unilateral] = run("unilateral");
  EXPECT_GE(h_unilateral, 0);
  EXPECT_LT(std::abs(fluid_unilateral), 1e-6 * block_momentum);
  EXPECT_NEAR(block_unilateral, block_momentum, 1e-6 * block_momentum);
}

TEST(CouplingTest, ForceRegionAndCouplingOptionsAreValidated) {
  const std::string gate = scene_path("elastic_gate/elastic_gate.json");
  EXPECT_THROW(run_scene(load_scene(gate, {"probes.2.region=[{\"type\":\"box\",\"min\":[0.3,0],\"max\":[0.4,0.1]}]"}), {}), InputError);
  EXPECT_THROW(load_scene(gate, {"coupling.borrowed_fluid=\"volume\""}), InputError);  // removed: always volume
  EXPECT_THROW(load_scene(gate, {"experimental.solid_response=\"stiff\""}), InputError);
  EXPECT_THROW(load_scene(gate, {"coupling.interface=\"sticky\""}), InputError);
  EXPECT_THROW(load_scene(gate, {"coupling.solid_corner_fraction=0.5"}), InputError);
  EXPECT_THROW(load_scene(gate, {"experimental.max_contact_rounds=0"}), InputError);
  // The bordered system is quasi-definite, not SPD: CG cannot solve it. The scene reader
  // says so, before anything runs; in 2-D auto means LDL^T with it.
  EXPECT_THROW(load_scene(gate, {"experimental.solid_response=\"stiffness\"", "solver.method=\"pcg\""}), InputError);
  EXPECT_EQ(Simulation<2>(load_scene(gate, {"experimental.solid_response=\"stiffness\""})).options().pressure_solver.method,
            LinearSolverMethod::ldlt);
}

}  // namespace
}  // namespace iqmpm
