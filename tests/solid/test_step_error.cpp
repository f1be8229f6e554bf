// Tests of the solids' local error estimate (solid/step_error.h, method.md#solid-time-step)
// and the time step that follows it.
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

#include "particles/particles.h"
#include "solid/step_error.h"
#include "support/test_helpers.h"

namespace iqmpm {
namespace {

template <class D>
class SolidStepErrorTest : public ::testing::Test {
 protected:
  static constexpr int dim = D::value;
};
TYPED_TEST_SUITE(SolidStepErrorTest, testing::Dimensions);

// Particles of three bodies move with constant jerk j_p: x(t) = x0 + v0 t + a0 t^2 / 2 + j t^3 / 6.
// The trapezoidal (midpoint) rule's position over a step from exact velocities misses the
// exact one by j dt^3 / 12, the estimate's e (Zienkiewicz-Xie): from the mean accelerations
// of two steps of unequal length it must give exactly that, over each body's largest
// displacement so far (or the floor), the largest over the bodies. Body 2, one particle
// that turns back (its displacement falls after the second step) with the largest jerk,
// sets the result: the scale must be the largest displacement so far, not the current one.
TYPED_TEST(SolidStepErrorTest, EstimateIsTheMidpointRulesLocalErrorUnderConstantJerk) {
  constexpr int dim = TestFixture::dim;
  std::mt19937 random(7);
  std::uniform_real_distribution<Real> uniform(-1, 1);
  auto random_vector = [&] {
    Vec<dim> v;
    for (int a = 0; a < dim; ++a) v[a] = uniform(random);
    return v;
  };
  const int n = 13, bodies = 3;
  Particles<dim> solid;
  std::vector<Vec<dim>> x0(n), v0(n), a0(n), jerk(n);
  for (int p = 0; p < n; ++p) {
    x0[p] = random_vector(), v0[p] = random_vector(), a0[p] = random_vector(), jerk[p] = 5 * random_vector();
    if (p < 6) jerk[p] *= 0.1;  // body 0 moves gently
    if (p == n - 1) v0[p] = Vec<dim>::UnitX(), a0[p] = -60 * Vec<dim>::UnitX(), jerk[p] = 50 * Vec<dim>::UnitY();
    solid.add(x0[p], v0[p], 1, 1);
    solid.body.push_back(p < 6 ? 0 : p < n - 1 ? 1 : 2);
    solid.initial_position.push_back(x0[p]);
  }
  auto position = [&](int p, Real t) { return x0[p] + t * v0[p] + t * t / 2 * a0[p] + t * t * t / 6 * jerk[p]; };
  auto velocity = [&](int p, Real t) { return v0[p] + t * a0[p] + t * t / 2 * jerk[p]; };
  const Real floor = 1e-3;
  SolidStepError error;
  Real t = 0;
  std::vector<Real> largest_displacement(bodies, floor);
  for (const Real dt : {0.01, 0.013, 0.006, 0.02}) {
    std::vector<Vec<dim>> start_velocity = solid.velocity;
    for (int p = 0; p < n; ++p) solid.velocity[p] = velocity(p, t + dt), solid.position[p] = position(p, t + dt);
    const bool first = error.dt == 0;
    error = measure_solid_step_error(solid, start_velocity, dt, error, bodies, floor);
    t += dt;
    std::vector<Real> largest_error(bodies, 0), current_displacement(bodies, floor);
    for (int p = 0; p < n; ++p) {
      const int b = solid.body[p];
      // The exact local error of the trapezoidal rule on this step.
      const Vec<dim> missed = position(p, t) - (position(p, t - dt) + dt / 2 * (velocity(p, t - dt) + velocity(p, t)));
      ASSERT_NEAR(missed.norm(), jerk[p].norm() * dt * dt * dt / 12, 1e-12);
      largest_error[b] = std::max(largest_error[b], missed.norm());
      largest_displacement[b] = std::max(largest_displacement[b], (position(p, t) - x0[p]).norm());
      current_displacement[b] = std::max(current_displacement[b], (position(p, t) - x0[p]).norm());
    }
    ASSERT_EQ(error.dt, dt);
    if (first) {
      EXPECT_TRUE(std::isnan(error.relative)) << "the first step has no earlier acceleration to compare with";
      continue;
    }
    Real expected = 0;
    for (int b = 0; b < bodies; ++b) expected = std::max(expected, largest_error[b] / largest_displacement[b]);
    EXPECT_NEAR(error.relative, expected, 1e-9 * expected) << "dt " << dt;
    EXPECT_EQ(expected, largest_error[2] / largest_displacement[2]) << "body 2 sets it";
    if (dt == Real(0.006)) {
      EXPECT_LT(current_displacement[2], 0.6 * largest_displacement[2]) << "body 2 has turned back";
    }
    for (int b = 0; b < bodies; ++b) EXPECT_NEAR(error.displacement_scale[b], largest_displacement[b], 1e-12);
  }
}

// A body that has hardly moved is measured against the floor: one particle from rest under
// constant jerk (displacement j t^3 / 6, far below the floor) gives e / floor, not e over
// its own displacement (which would be about 0.1 here).
TYPED_TEST(SolidStepErrorTest, ABodyThatHardlyMovedIsMeasuredAgainstTheFloor) {
  constexpr int dim = TestFixture::dim;
  Particles<dim> solid;
  solid.add(Vec<dim>::Zero(), Vec<dim>::Zero(), 1, 1);
  solid.body.push_back(0);
  solid.initial_position.push_back(Vec<dim>::Zero());
  const Real jerk = 10, floor = 0.01;
  SolidStepError error;
  Real t = 0;
  for (const Real dt : {0.01, 0.013}) {
    const std::vector<Vec<dim>> start_velocity = solid.velocity;
    t += dt;
    solid.velocity[0] = Vec<dim>::UnitX() * jerk * t * t / 2;
    solid.position[0] = Vec<dim>::UnitX() * jerk * t * t * t / 6;
    error = measure_solid_step_error(solid, start_velocity, dt, error, 1, floor);
  }
  ASSERT_LT(solid.position[0].norm(), 0.01 * floor);
  EXPECT_NEAR(error.relative, jerk * std::pow(0.013, 3) / 12 / floor, 1e-12);
}

// The next dt keeps the estimate at the tolerance (third order: a step error 8x the
// tolerance halves dt), grows at most 2x a step, and does not limit a step with no estimate.
TEST(SolidStepErrorLimit, FollowsTheThirdOrderErrorAndGrowsAtMostTwofold) {
  SolidStepError error;
  EXPECT_TRUE(std::isinf(solid_error_dt_limit(error, 1e-3)));  // no step yet
  error.dt = 0.01;
  EXPECT_TRUE(std::isinf(solid_error_dt_limit(error, 1e-3)));  // a step without a comparison
  error.relative = 8e-3;
  EXPECT_NEAR(solid_error_dt_limit(error, 1e-3), 0.005, 1e-15);
  error.relative = 1e-3 / 1.331;
  EXPECT_NEAR(solid_error_dt_limit(error, 1e-3), 0.011, 1e-15);
  error.relative = 1e-9;
  EXPECT_EQ(solid_error_dt_limit(error, 1e-3), 0.02);
  error.relative = 0;
  EXPECT_EQ(solid_error_dt_limit(error, 1e-3), 0.02);
}

}  // namespace
}  // namespace iqmpm
