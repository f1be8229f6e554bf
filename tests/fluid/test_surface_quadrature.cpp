// The surface quadrature's one-point rule at the cell centre (fluid.surface_quadrature =
// "centre", the default with solids) against a lone particle: method.md#fluid-quadrature.
#include <gtest/gtest.h>

#include <cmath>

#include "scene/json_reader.h"
#include "scene/scene.h"
#include "simulation/simulation.h"
#include "support/test_helpers.h"

namespace iqmpm {
namespace {

using testing::box;
using testing::xyz;

template <class D>
class SurfaceQuadratureTest : public ::testing::Test {};
TYPED_TEST_SUITE(SurfaceQuadratureTest, testing::Dimensions);

// A lone water particle that slides down a slip wall falls freely: its speed after a drop
// of h is sqrt(v_t^2 + 2 g h), v_t its speed along the wall (the wall stops the rest). Its
// APIC affine velocity, a shear of 1000 1/s across the wall (spray leaving a jet carries
// such), adds nothing to its translation. With the whole cell's mass at the cell centre,
// as the centre rule puts it, the projection weighed the corners away from the wall as
// heavy as those beside it while the affine velocity filled them: measured 13.0 m/s
// instead of 3.42 in 2-D (3.54 in 3-D, whose walls hold the corners), the runaway of
// single particles along the dam_break_obstacle tank's walls (76 m/s).
TYPED_TEST(SurfaceQuadratureTest, LoneParticleSlidingDownAWallFallsFreely) {
  constexpr int dim = TypeParam::value;
  const double dx = 0.0045625, depth = 16 * dx, wall = 0.584;
  const Json doc = {
      {"dim", dim}, {"domain", {{"min", xyz<dim>(0, 0, 0)}, {"max", xyz<dim>(wall, wall, depth)}}}, {"dx", dx},
      {"end_time", 1.0},
      {"fluid", {{"surface_quadrature", "centre"}, {"inertia", "quadrature"},
                 {"shapes", Json::array({box(xyz<dim>(0.5, 0.4, 0.5 * depth), xyz<dim>(0.5 + dx / 2, 0.4 + dx / 2, 0.5 * depth + dx / 2))})}}}};
  Simulation<dim> sim(read_scene(doc));
  Particles<dim>& water = sim.fluid();
  ASSERT_EQ(water.size(), 1u);
  const double height = 0.4, along = 3.0;
  water.position[0] = Vec<dim>::Constant(0.5 * depth);
  water.position[0][0] = wall - 0.05 * dx;
  water.position[0][1] = height;
  water.velocity[0] = Vec<dim>::Zero();
  water.velocity[0][0] = 0.5;  // into the wall
  water.velocity[0][1] = -along;
  water.affine[0] = Mat<dim>::Zero();
  water.affine[0](0, 1) = 1000;  // d u_normal / d y
  for (int step = 0; step < 60; ++step) sim.step(0.5 * dx / std::max(3.0, double(water.velocity[0].norm())));
  const double drop = height - water.position[0][1];
  ASSERT_GT(drop, 0.1);
  const double free_fall = std::sqrt(along * along + 2 * 9.81 * drop);
  EXPECT_NEAR(water.velocity[0].norm(), free_fall, 0.01 * free_fall) << "drop " << drop << " m";
}

}  // namespace
}  // namespace iqmpm
