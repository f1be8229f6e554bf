// experimental.trapped_air (docs/method.md#trapped-air): air that the water encloses gets one
// uniform pressure that holds the flow into it at zero. A layer of water spanning the hydrostatic tank, 0.25 m
// above its floor, is held up by the air under it: with the pocket it is the aligned
// column's exact discrete equilibrium (pressure rho g (0.5 - y) in the water, to round-off;
// the pocket's pressure is the weight of the layer), without it the layer falls freely. Where
// the air is open (the tank's top layer of cells) the option changes nothing.
#include <fmt/format.h>

#include "core/errors.h"
#include "run/runner.h"
#include "support/test_helpers.h"

namespace iqmpm {
namespace {

template <class D>
class TrappedAirTest : public ::testing::Test {
 protected:
  static constexpr int dim = D::value;

  static SceneSpec scene(const std::vector<std::string>& overrides) {
    const std::string path = std::string(IQMPM_BENCHMARKS_DIR) + (dim == 2 ? "/hydrostatic/hydrostatic_2d.json" : "/hydrostatic/hydrostatic_3d.json");
    std::vector<std::string> all = {"end_time=0.15", "dx=" + std::string(dim == 2 ? "0.03125" : "0.125"), "solver.method=cholmod"};
    all.insert(all.end(), overrides.begin(), overrides.end());
    return load_scene(path, all);
  }
  // The water between 0.25 m and 0.5 m, the whole width: air under it, sealed by the walls.
  static std::vector<std::string> layer(const std::string& trapped_air) {
    return {"fluid.shapes.0.min.1=0.25", "experimental.trapped_air=" + trapped_air,
            fmt::format(R"(probes=[{{"type":"pressure","name":"p","point":[0.5,0.375{}],"sensor":0.1}},{{"type":"max_speed","name":"max_speed"}}])",
                        dim == 3 ? ",0.5" : "")};
  }

  static double metric(const RunResult& result, const std::string& name) {
    for (std::size_t c = 0; c < result.columns.size(); ++c)
      if (result.columns[c] == name) return result.metrics.back()[c];
    ADD_FAILURE() << "no metric " << name;
    return 0;
  }
};
TYPED_TEST_SUITE(TrappedAirTest, testing::Dimensions);

TYPED_TEST(TrappedAirTest, TrappedAirHoldsUpTheWaterOverIt) {
  const RunResult held = run_scene(this->scene(this->layer("incompressible")), {});
  ASSERT_TRUE(held.ok) << held.summary["status"];
  EXPECT_LT(this->metric(held, "max_speed"), 1e-9);
  EXPECT_NEAR(this->metric(held, "p"), 1000 * 9.81 * (0.5 - 0.375), 1e-9 * 1000 * 9.81);
  EXPECT_EQ(held.summary["trapped_air"]["pockets_max"].template get<int>(), 1);
  EXPECT_EQ(held.summary["trapped_air"]["steps"].template get<long>(), held.summary["steps"].template get<long>());

  // Without the pocket the layer falls freely: after 0.15 s at g t (its lowest particles are
  // then 0.11 m lower, still a cell above the floor's), without pressure.
  const RunResult fallen = run_scene(this->scene(this->layer("none")), {});
  ASSERT_TRUE(fallen.ok) << fallen.summary["status"];
  EXPECT_NEAR(this->metric(fallen, "max_speed"), 9.81 * 0.15, 1e-9);
  EXPECT_LT(std::abs(this->metric(fallen, "p")), 1e-6 * 1000 * 9.81);
  EXPECT_EQ(fallen.summary["trapped_air"]["steps"].template get<long>(), 0);
}

// One particle falling through the pocket is a drop with corners of its own, light ones (a
// particle's far tail) among them: as the pocket's boundary they would let it out at almost
// no pressure (by 0.15 s the layer's pressure fell to 38 % in 2-D, 70 % in 3-D). Floating in
// the pocket, the drop counts as inside it, and the layer stays the exact equilibrium.
TYPED_TEST(TrappedAirTest, ADropInThePocketDoesNotLetItOut) {
  constexpr int dim = TestFixture::dim;
  std::vector<std::string> overrides = this->layer("incompressible");
  overrides.push_back(dim == 2 ? R"(fluid.shapes=[{"type":"box","min":[0,0.25],"max":[1,0.5]},{"type":"box","min":[0.5,0.11],"max":[0.515,0.125]}])"
                               : R"(fluid.shapes=[{"type":"box","min":[0,0.25,0],"max":[1,0.5,1]},{"type":"box","min":[0.5,0.05,0.5],"max":[0.56,0.12,0.56]}])");
  const RunResult held = run_scene(this->scene(overrides), {});
  ASSERT_TRUE(held.ok) << held.summary["status"];
  EXPECT_EQ(held.summary["fluid_particles"].template get<long>(), (dim == 2 ? 64 * 16 : 16 * 4 * 16) + 1);
  EXPECT_NEAR(this->metric(held, "p"), 1000 * 9.81 * (0.5 - 0.375), 1e-9 * 1000 * 9.81);
}

// The tank's own air touches its top layer of cells: open, no pocket, the same run.
TYPED_TEST(TrappedAirTest, OpenAirIsNoPocket) {
  const RunResult off = run_scene(this->scene({}), {});
  const RunResult on = run_scene(this->scene({"experimental.trapped_air=incompressible"}), {});
  ASSERT_TRUE(off.ok && on.ok);
  EXPECT_EQ(on.summary["trapped_air"]["steps"].template get<long>(), 0);
  EXPECT_EQ(on.metrics, off.metrics);
}

TYPED_TEST(TrappedAirTest, NeedsGravityAndAKnownValue) {
  constexpr int dim = TestFixture::dim;
  EXPECT_THROW(this->scene({"experimental.trapped_air=incompressible", dim == 2 ? "gravity=[0,0]" : "gravity=[0,0,0]"}), InputError);
  EXPECT_THROW(this->scene({"experimental.trapped_air=compressible"}), InputError);
}

}  // namespace
}  // namespace iqmpm
