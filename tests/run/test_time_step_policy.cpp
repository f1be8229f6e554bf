// The time step's CFL rule (run/time_step_policy.h, method.md#time-step): a particle of the
// water's bulk moves at most cfl cells a step, spray (a cell holding at most half a cell of
// material, water and solid) at most spray_cfl, and spray_cfl = cfl is the single rule.
#include <cmath>

#include "run/time_step_policy.h"
#include "simulation/simulation.h"
#include "support/scenes.h"
#include "support/test_helpers.h"

namespace iqmpm {
namespace {

template <class D>
class TimeStepPolicyTest : public ::testing::Test {};
TYPED_TEST_SUITE(TimeStepPolicyTest, testing::Dimensions);

// The dam break's column at rest (2-D; 3-D four cells deep), its particles' velocities set
// by each case. `speed` along x for the particles `moving`, zero for the rest.
template <int dim>
SceneSpec dam_break_scene(const std::vector<std::string>& overrides = {}) {
  const Json doc = testing::benchmark_document("dam_break/dam_break.json", overrides);
  return read_scene(testing::in_dim<dim>(doc, 4 * doc.at("dx").get<Real>()));
}

template <int dim>
void set_speeds(Simulation<dim>& sim, const std::vector<std::size_t>& moving, Real speed) {
  for (auto& v : sim.fluid().velocity) v.setZero();
  for (std::size_t p : moving) sim.fluid().velocity[p][0] = speed;
}

// The particle nearest to `point`.
template <int dim>
std::size_t nearest_particle(const Particles<dim>& particles, const Vec<dim>& point) {
  std::size_t best = 0;
  for (std::size_t p = 1; p < particles.size(); ++p)
    if ((particles.position[p] - point).norm() < (particles.position[best] - point).norm()) best = p;
  return best;
}

// The centre of an empty cell far from the column (x, y = 0.4 m; mid-depth in 3-D).
template <int dim>
Vec<dim> empty_cell_centre(const Grid<dim>& grid) {
  Vec<dim> x = grid.origin;
  for (int a = 0; a < dim; ++a) {
    const Real target = a < 2 ? Real(0.4) : Real(2) * grid.dx;
    x[a] += (std::floor(target / grid.dx) + Real(0.5)) * grid.dx;
  }
  return x;
}

TYPED_TEST(TimeStepPolicyTest, BulkMovesCflCellsAndSprayMovesSprayCflCells) {
  constexpr int dim = TypeParam::value;
  const SceneSpec scene = dam_break_scene<dim>();
  ASSERT_EQ(scene.cfl, 0.5);
  ASSERT_EQ(scene.spray_cfl, 0.8);  // the default: twice cfl, at most 0.8
  Simulation<dim> sim(scene);
  const TimeStepPolicy policy(scene);
  const Real dx = sim.grid().dx, speed = 2;

  // A particle inside the column: cfl cells a step.
  Vec<dim> inside = sim.grid().origin;
  inside[0] += 0.073, inside[1] += 0.146;
  if constexpr (dim == 3) inside[2] += 2 * dx;
  const std::size_t bulk = nearest_particle(sim.fluid(), inside);
  set_speeds(sim, {bulk}, speed);
  EXPECT_DOUBLE_EQ(policy.stable_dt(sim), scene.cfl * dx / speed);

  // The same particle alone in an empty cell: spray_cfl cells a step.
  sim.fluid().position[bulk] = empty_cell_centre(sim.grid());
  set_speeds(sim, {bulk}, speed);
  EXPECT_NEAR(policy.stable_dt(sim), scene.spray_cfl * dx / speed, 1e-12 * dx / speed);

  // spray_cfl = cfl: every particle at cfl.
  const SceneSpec single = dam_break_scene<dim>({"spray_cfl=0.5"});
  EXPECT_DOUBLE_EQ(TimeStepPolicy(single).stable_dt(sim), scene.cfl * dx / speed);
}

// Spray is a cell with at most half a cell of material: half the seeding's particles of a
// cell are spray, one more is not.
TYPED_TEST(TimeStepPolicyTest, SprayIsAtMostHalfACell) {
  constexpr int dim = TypeParam::value;
  const SceneSpec scene = dam_break_scene<dim>();
  Simulation<dim> sim(scene);
  const TimeStepPolicy policy(scene);
  const Real dx = sim.grid().dx, speed = 2;
  int half = 1;
  for (int a = 0; a < dim; ++a) half *= scene.particles_per_axis;
  half /= 2;
  ASSERT_NEAR(sim.fluid().initial_volume[0] * half, 0.5 * sim.grid().cell_volume(), 1e-12 * sim.grid().cell_volume());
  std::vector<std::size_t> moved;
  for (int k = 0; k <= half; ++k) {
    const std::size_t p = sim.fluid().size() - 1 - k;  // any particles of the column
    Vec<dim> x = empty_cell_centre(sim.grid());
    x[0] += (Real(k) / (half + 1) - Real(0.4)) * dx;  // spread inside the cell
    sim.fluid().position[p] = x;
    moved.push_back(p);
  }
  // half + 1 particles in the cell, all moving: not spray.
  set_speeds(sim, moved, speed);
  EXPECT_DOUBLE_EQ(policy.stable_dt(sim), scene.cfl * dx / speed);
  // One of them back into the column: half a cell left, spray.
  sim.fluid().position[moved.back()] = sim.fluid().position[0];
  set_speeds(sim, {moved.begin(), moved.end() - 1}, speed);
  EXPECT_NEAR(policy.stable_dt(sim), scene.spray_cfl * dx / speed, 1e-12 * dx / speed);
}

// The solids' volume counts: a fluid particle alone among a body's particles is not spray
// (the submerged block, clamped; its water at rest).
TYPED_TEST(TimeStepPolicyTest, AFluidParticleInsideABodyIsNotSpray) {
  constexpr int dim = TypeParam::value;
  const SceneSpec scene = read_scene(testing::submerged_block_document<dim>("submerged_block.json"));
  Simulation<dim> sim(scene);
  const TimeStepPolicy policy(scene);
  const Real dx = sim.grid().dx, speed = 50;  // fast enough that dt_max does not bind
  ASSERT_LT(scene.spray_cfl * dx / speed, scene.dt_max);
  Vec<dim> centre = Vec<dim>::Constant(Real(0.5) * dx);  // a cell centre inside the block
  centre[0] += 0.5, centre[1] += 0.25;
  if constexpr (dim == 3) centre[2] += 0.2;
  sim.fluid().position[0] = centre;
  set_speeds(sim, {0}, speed);
  EXPECT_DOUBLE_EQ(policy.stable_dt(sim), scene.cfl * dx / speed);
  // The same particle in an empty cell above the water: spray.
  centre[1] = 0.7 + Real(0.5) * dx;
  sim.fluid().position[0] = centre;
  EXPECT_NEAR(policy.stable_dt(sim), scene.spray_cfl * dx / speed, 1e-12 * dx / speed);
}

}  // namespace
}  // namespace iqmpm
