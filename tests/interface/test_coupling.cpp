// Coupling at the interface (issue #4, method.md §3 step 3, §4, §5, §9): the fluid's
// weight is counted once by the interface quadrature, the ghost matrix starts at the still
// water's pressure, water slides along a solid (free slip), momentum crosses the interface,
// the unilateral constraint lets water separate, and the coupling options are validated.
// Those that run a step or a few are typed over 2-D and 3-D: the 3-D instance runs the
// 2-D scene extruded along z between slip walls (a 2-D flow, the same per unit depth) or
// a small 3-D scene, with the same assertions. The interface over 300 steps and the free
// slip along a 2 m plate are 2-D (their cost in 3-D is stated beside them); the benchmark
// runs of the coupling are in tests/simulation/test_coupled_benchmarks.cpp.
#include <algorithm>
#include <cmath>
#include <limits>
#include <tuple>

#include <gtest/gtest.h>

#include "core/errors.h"
#include "diagnostics/measurements.h"
#include "run/runner.h"
#include "scene/json_reader.h"
#include "scene/scene.h"
#include "simulation/simulation.h"
#include "support/run_helpers.h"
#include "support/scenes.h"
#include "support/test_helpers.h"

namespace iqmpm {
namespace {

using testing::box;
using testing::xyz;

// One OpenMP thread: ctest runs two tests side by side on CI's 2 cores, where a 3-D run
// at 2 threads each took 2-3 times (up to 10 times) its time alone (run_helpers.h).
template <class D>
class CouplingTest : public ::testing::Test {
 protected:
  static constexpr int dim = D::value;
  const testing::OneThread one_thread_;

  static Json submerged(const std::string& file, const std::vector<std::string>& overrides = {}) {
    return testing::submerged_block_document<dim>(file, overrides);
  }
  static Real block_volume() { return testing::submerged_block_volume<dim>(); }

  static Vec<dim> momentum(const Particles<dim>& particles) {
    Vec<dim> sum = Vec<dim>::Zero();
    for (std::size_t p = 0; p < particles.size(); ++p) sum += particles.mass[p] * particles.velocity[p];
    return sum;
  }
};
TYPED_TEST_SUITE(CouplingTest, testing::Dimensions);

// IQ points borrow volume, not mass (docs/method.md#borrowed-volume): M^f holds exactly
// the water's mass. (Lent mass, the reference code's, weighed it a second time in the
// lenders' full cells.) In 3-D the block has water all round (support/scenes.h). With the
// block two cells high (dx 0.05) M^f was 2.6 % heavy in 2-D, 1.5 % in 3-D.
TYPED_TEST(CouplingTest, FluidMassMatrixHoldsTheWaterOnce) {
  constexpr int dim = TypeParam::value;
  Simulation<dim> sim(read_scene(this->submerged("submerged_block.json")));
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
// the first 20 steps within 0.5 %). 3-D, at dx 0.025: 35.5 N on the first step against
// the 39.24 N weight, the mean -1.7 %.
TYPED_TEST(CouplingTest, HydrostaticGhostPressureStartsASubmergedBlockInBalance) {
  constexpr int dim = TypeParam::value;
  Simulation<dim> sim(read_scene(this->submerged("neutral_block.json")));
  ASSERT_EQ(sim.scene().solids[0].initial_pressure, InitialPressure::hydrostatic);
  const double rho_g = 1000 * 9.81, lambda_g = sim.scene().solids[0].ghost_stiffness;
  for (std::size_t p = 0; p < sim.solid().size(); ++p)
    ASSERT_NEAR(sim.solid().ghost_J[p], 1 - rho_g * (0.5 - sim.solid().position[p][1]) / lambda_g, 1e-12);
  const double weight = rho_g * this->block_volume();
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
  EXPECT_THROW(Simulation<dim>(read_scene(this->submerged("neutral_block.json", {"fluid.shapes=[]"}))), InputError);
}

// coupling.interface_reach = 0.6 (the default, which the coupled scenes use): the seeded water
// and block lattices meet exactly 0.5 dx apart. At the reference code's reach of 0.5 dx, sub-micron
// motions break those ties: the clamped block's interface cells went 44, 38, 44 over the
// first steps and its force flickered (std 18.5 N/m over 0.1-0.3 s). At 0.6 dx the
// interface holds (measured std 0.39 N/m). 2-D only: 300 steps (about 0.3 s a step in 3-D).
TEST(CouplingTest, InterfaceHoldsOnAlignedLatticesWithReach06) {
  const testing::OneThread one_thread;
  Simulation<2> sim(load_scene(testing::scene_path("submerged_block/submerged_block.json"),
                               {"coupling.interface_reach=0.6", "coupling.solid_corner_fraction=0"}));
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

// Free slip, not sticky (method.md §1): a layer of water moving at 1 m/s along a clamped
// plate it rests on (no walls at the ends) spreads under gravity but is hardly slowed, and
// the layer touching the plate moves on with the rest (a sticky interface would hold it).
// Measured: 0.23 % of the horizontal momentum goes to the plate in 0.2 s, through the
// borrowed quadrature of the interface cells where the pressure varies along the plate
// (at the layer's ends). With the former defaults (reach 0.5, no solid corners, particle
// quadrature at the surface): with the validated coupling the plate takes 5.8 % (reach
// 0.6) and the centre quadrature 2.7 % (docs/method.md#12-known-limits). 2-D only:
// extruded 4 cells deep the run took 61 s (CG Newton on the plate's unclamped edge nodes
// 15 s, the pressure PCG 39 s); it measured -0.01 % momentum and the bottom layer 1.06 %
// faster than the mean (the criterion, 1 %, is missed by a hair).
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
// without an exchange of momentum: measured +0.24 %, held below 0.5 %. (The tank, 0.6 x
// 0.4 m, was 1 x 0.5 m: the same numbers, the water never nears a wall.) In 3-D the scene
// is extruded 4 cells deep between the z walls (slip: they push along z only), with the
// default fraction only (measured +0.33 %, 7.6 s; without corners +0.028 %, another 8 s).
// At dx 0.025 both dimensions miss the 0.1 % (+0.8 %), as does a 3-D cube of water thrown
// at a cube (+1 %), so the 3-D instance keeps the 2-D resolution.
TYPED_TEST(CouplingTest, MomentumIsConservedWhenWaterHitsAFreeBlock) {
  constexpr int dim = TypeParam::value;
  for (const double corner_fraction : {0.0, 0.75}) {
    if (dim == 3 && corner_fraction == 0) continue;
    const Json doc = {
        {"dim", 2}, {"domain", {{"min", {0.0, 0.0}}, {"max", {0.6, 0.4}}}}, {"gravity", {0.0, 0.0}}, {"dx", 0.0125},
        {"end_time", 0.15}, {"dt_max", 0.002}, {"coupling", {{"solid_corner_fraction", corner_fraction}}},
        {"fluid", {{"shapes", Json::array({{{"type", "box"}, {"min", {0.1, 0.1}}, {"max", {0.3, 0.3}}}})},
                   {"initial_velocity", {1.0, 0.0}}}},
        {"solids", Json::array({{{"name", "block"}, {"density", 500}, {"youngs_modulus", 1e6}, {"poisson_ratio", 0.3},
                                 {"shapes", Json::array({{{"type", "box"}, {"min", {0.35, 0.15}}, {"max", {0.45, 0.25}}}})}}})}};
    Simulation<dim> sim(read_scene(testing::in_dim<dim>(doc, 4 * 0.0125)));
    const Vec<dim> start = this->momentum(sim.fluid()) + this->momentum(sim.solid());
    for (int s = 0; s < 75; ++s) sim.step(0.002);
    const Vec<dim> block = this->momentum(sim.solid());
    const Vec<dim> end = this->momentum(sim.fluid()) + block;
    EXPECT_GT(block[0], 0.05 * start[0]);  // the water pushed the block
    EXPECT_NEAR(end[0], start[0], (corner_fraction > 0 ? 5e-3 : 1e-3) * start[0]) << "corner fraction " << corner_fraction;
    for (int a = 1; a < dim; ++a)  // mirror symmetry about the block's centre line (and mid-depth in 3-D)
      EXPECT_NEAR(end[a], 0, 1e-9 * start[0]) << "axis " << a << ", corner fraction " << corner_fraction;
  }
}

// Separation (method.md §9): a block leaving the water it touches, no gravity. With the
// bilateral constraint the water is held to the block (suction: negative h, and negative
// p_f in the cells whose corners move with the block) and dragged along; with
// coupling.interface = unilateral those rows are released, the water stays at rest and
// the block keeps its speed, and no h is negative. In 3-D the water and the block are
// boxes 0.3 and 0.2 m deep in z (water all round the block's touching face), at dx 0.025.
TYPED_TEST(CouplingTest, UnilateralInterfaceLetsWaterSeparate) {
  constexpr int dim = TypeParam::value;
  auto run = [&](const std::string& interface) {
    const Json doc = {
        {"dim", dim}, {"domain", {{"min", xyz<dim>(0, 0, 0)}, {"max", xyz<dim>(1.0, 1.0, 0.5)}}},
        {"gravity", xyz<dim>(0, 0, 0)}, {"dx", dim == 2 ? 0.0125 : 0.025}, {"end_time", 0.02},
        {"coupling", {{"interface", interface}}},
        {"fluid", {{"shapes", Json::array({box(xyz<dim>(0.2, 0.3, 0.1), xyz<dim>(0.4, 0.6, 0.4))})}}},
        {"solids", Json::array({{{"name", "block"}, {"density", 500}, {"youngs_modulus", 1e6}, {"poisson_ratio", 0.3},
                                 {"initial_velocity", xyz<dim>(0.5, 0, 0)},
                                 {"shapes", Json::array({box(xyz<dim>(0.4, 0.35, 0.15), xyz<dim>(0.5, 0.55, 0.35))})}}})}};
    Simulation<dim> sim(read_scene(doc));
    sim.step(0.002);
    EXPECT_GT(sim.interface_points(), 0) << interface;
    const PressureSystem& system = sim.pressure_system();
    const PressureSystem::Block* h = system.find("h");
    EXPECT_NE(h, nullptr);
    // A released row's multiplier is zero (PressureSystem::corrected_velocity); an
    // iterative solve (CG, 3-D) leaves round-off there (-4e-28 measured).
    Real smallest_h = h ? std::numeric_limits<Real>::infinity() : 0;
    for (int i = 0; h && i < h->size; ++i)
      smallest_h = std::min(smallest_h, system.released(h->offset + i) ? Real(0) : sim.pressure_solution()[h->offset + i]);
    for (int s = 0; s < 9; ++s) sim.step(0.002);
    Real fluid = 0, block = 0;
    for (std::size_t p = 0; p < sim.fluid().size(); ++p) fluid += sim.fluid().mass[p] * sim.fluid().velocity[p][0];
    for (std::size_t p = 0; p < sim.solid().size(); ++p) block += sim.solid().mass[p] * sim.solid().velocity[p][0];
    return std::make_tuple(smallest_h, fluid, block);
  };
  const Real block_momentum = 500 * (dim == 2 ? 0.1 * 0.2 : 0.1 * 0.2 * 0.2) * 0.5;
  const auto [h_bilateral, fluid_bilateral, block_bilateral] = run("bilateral");
  EXPECT_LT(h_bilateral, 0);                                // suction on the first step
  EXPECT_GT(fluid_bilateral, 0.05 * block_momentum);        // water dragged along
  EXPECT_LT(block_bilateral, 0.95 * block_momentum);        // and the block held back
  const auto [h_unilateral, fluid_unilateral, block_unilateral] = run("unilateral");
  EXPECT_GE(h_unilateral, 0);
  EXPECT_LT(std::abs(fluid_unilateral), 1e-6 * block_momentum);
  EXPECT_NEAR(block_unilateral, block_momentum, 1e-6 * block_momentum);
}

// The options of the coupling on the elastic gate's scene (extruded 4 cells deep in 3-D):
// a force region must hold particles of its body, removed and unknown choices are named,
// and the bordered system of solid_response = stiffness, quasi-definite rather than SPD,
// needs the LDL^T solve: CG cannot solve it. The scene reader says so, before anything
// runs; auto means LDL^T with it in 2-D and is rejected in 3-D (auto is CG there).
TYPED_TEST(CouplingTest, ForceRegionAndCouplingOptionsAreValidated) {
  constexpr int dim = TypeParam::value;
  const auto gate = [](const std::vector<std::string>& overrides) {
    return read_scene(testing::in_dim<dim>(testing::benchmark_document("elastic_gate/elastic_gate.json", overrides), 4 * 0.0025));
  };
  EXPECT_THROW(run_scene(gate({"probes.2.region=[{\"type\":\"box\",\"min\":[0.3,0],\"max\":[0.4,0.1]}]"}), {}), InputError);
  EXPECT_THROW(gate({"coupling.borrowed_fluid=\"volume\""}), InputError);  // removed: always volume
  EXPECT_THROW(gate({"experimental.solid_response=\"stiff\""}), InputError);
  EXPECT_THROW(gate({"coupling.interface=\"sticky\""}), InputError);
  EXPECT_THROW(gate({"coupling.solid_corner_fraction=0.5"}), InputError);
  EXPECT_THROW(gate({"experimental.max_contact_rounds=0"}), InputError);
  EXPECT_THROW(gate({"experimental.solid_response=\"stiffness\"", "solver.method=\"pcg\""}), InputError);
  if constexpr (dim == 2) {
    EXPECT_EQ(Simulation<dim>(gate({"experimental.solid_response=\"stiffness\""})).options().pressure_solver.method,
              LinearSolverMethod::ldlt);
  } else {
    EXPECT_THROW(gate({"experimental.solid_response=\"stiffness\""}), InputError);
    EXPECT_EQ(Simulation<dim>(gate({"experimental.solid_response=\"stiffness\"", "solver.method=\"ldlt\""})).options().pressure_solver.method,
              LinearSolverMethod::ldlt);
  }
}

}  // namespace
}  // namespace iqmpm
