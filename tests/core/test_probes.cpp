// Probes measure what benchmarks.md defines: at t = 0 the dam-break front is the column
// width a and the water height at the left wall is 2a (the half particle spacing beyond
// the outermost particles is counted), and a drop above the column does not raise it.
#include "simulation/runner.h"
#include "test_helpers.h"

namespace iqmpm {
namespace {

double first_row(const RunResult& result, const std::string& name) {
  for (std::size_t c = 0; c < result.columns.size(); ++c)
    if (result.columns[c] == name) return result.metrics.front()[c];
  ADD_FAILURE() << "no metric " << name;
  return 0;
}

TEST(ProbeTest, DamBreakColumnAtRest) {
  const std::string path = std::string(IQMPM_BENCHMARKS_DIR) + "/dam_break/dam_break.json";
  const RunResult result = run_scene(load_scene(path, {"dx=0.0365", "end_time=0.001"}), {});
  ASSERT_TRUE(result.ok);
  EXPECT_NEAR(first_row(result, "front_x"), 0.146, 1e-12);
  EXPECT_NEAR(first_row(result, "height_left"), 0.292, 1e-12);
}

TEST(ProbeTest, DetachedDropDoesNotCountAsWaterHeight) {
  const std::string path = std::string(IQMPM_BENCHMARKS_DIR) + "/dam_break/dam_break.json";
  const RunResult result = run_scene(
      load_scene(path, {"dx=0.0365", "end_time=0.001",
                        R"(fluid.shapes=[{"type":"box","min":[0,0],"max":[0.146,0.292]},{"type":"box","min":[0,0.4],"max":[0.0365,0.438]}])"}),
      {});
  ASSERT_TRUE(result.ok);
  EXPECT_NEAR(first_row(result, "height_left"), 0.292, 1e-12);
}

// A mean level over gauges (water_height with `to`): over a column with a step in its
// surface, the mean of the two heights weighted by their widths (0.292 m over x < 0.146,
// 0.146 m over 0.146 < x < 0.292: gauges every dx = 0.0365 from 0.01825 to 0.27375 are
// four on each part).
TEST(ProbeTest, MeanWaterLevelAveragesTheGauges) {
  const std::string path = std::string(IQMPM_BENCHMARKS_DIR) + "/dam_break/dam_break.json";
  const RunResult result = run_scene(
      load_scene(path, {"dx=0.0365", "end_time=0.001",
                        R"(fluid.shapes=[{"type":"box","min":[0,0],"max":[0.146,0.292]},{"type":"box","min":[0.146,0],"max":[0.292,0.146]}])",
                        R"(probes=[{"type":"water_height","name":"level","position":0.01825,"to":0.27375}])"}),
      {});
  ASSERT_TRUE(result.ok);
  EXPECT_NEAR(first_row(result, "level"), 0.5 * (0.292 + 0.146), 1e-12);
}

}  // namespace
}  // namespace iqmpm
