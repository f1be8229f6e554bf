// The optional position correction (method.md §3 step 6) has its own volume-drift tests.
// The dam break at its benchmark resolution (dx = a/32, 0.6 s): particles spread, and the
// region the water fills (the `volume` probe, volume_drift) falls to -16.8 % without the
// correction, the particle measure (Simulation::fluid_particle_volume, a count per cell) to
// -21.6 % at the end. With relaxation 1, the scenes' (the step's own operators and factor,
// no solids), the region stays within -1.56 / +0.16 % at every step and the particle
// measure ends at -8.7 % (measured 2026-12-03; at 0.5 -1.75 / +0.16 % and -8.6 %, the
// same with 1 and 2 threads). Margins: the uncorrected run
// must show the problem (< -10 % and < -15 %), the corrected one keep the region within 2 %
// at every step (issue 23's criterion) and the particle measure within 10 %.
// At a/16 this correction ends at -2.4 % (lowest -3.1 %): 16 cells across the column leave
// few interior cells for its filter (fluid/position_correction.h); the count-per-cell
// target before it kept +0.3 % there but ran away at a/64 (second test).
#include <algorithm>

#include "run/runner.h"
#include "support/test_helpers.h"

namespace iqmpm {
namespace {

struct Drifts {
  double particles, region_end, region_farthest;  // region_farthest: largest |drift| over the steps
};

Drifts dam_break_drifts(const std::vector<std::string>& overrides) {
  const std::string path = std::string(IQMPM_BENCHMARKS_DIR) + "/dam_break/dam_break.json";
  const RunResult result = run_scene(load_scene(path, overrides), {});
  EXPECT_TRUE(result.ok) << result.summary["status"];
  const auto column = std::find(result.columns.begin(), result.columns.end(), "volume") - result.columns.begin();
  EXPECT_LT(column, Eigen::Index(result.columns.size())) << "the dam break scene has a volume probe";
  const double initial = result.metrics.front()[column];
  double farthest = 0;
  for (const auto& row : result.metrics) farthest = std::max(farthest, std::abs(row[column] / initial - 1));
  return {result.summary["particle_volume_drift"].get<double>(), result.summary["volume_drift"].get<double>(), farthest};
}

TEST(PositionCorrectionTest, KeepsDamBreakVolume) {
  const Drifts uncorrected = dam_break_drifts({"experimental.position_correction=0"});
  const Drifts corrected = dam_break_drifts({"experimental.position_correction=1"});
  EXPECT_LT(uncorrected.particles, -0.15);
  EXPECT_LT(uncorrected.region_end, -0.10);
  EXPECT_LT(std::abs(corrected.particles), 0.10);
  EXPECT_LT(corrected.region_farthest, 0.02);
}

// At a/64 the correction used to run away (the target counted particles per cell and kept
// its checkerboard part, which D cannot produce: fluid/position_correction.h). In the
// first 0.1 s of that dam break the region then fell by 4-7 % while the uncorrected run
// stays within 0.25 %; with the smoothed, filtered target it stays within -0.20 / +0.10 %
// at every step (measured 2026-12-03; at relaxation 1, the scenes' value, -0.20 / +0.11 %).
// Margin 1 %, checked at every step.
TEST(PositionCorrectionTest, StaysQuietOnAFineDamBreak) {
  const Drifts corrected = dam_break_drifts({"dx=0.00228125", "end_time=0.1", "experimental.position_correction=1"});
  EXPECT_LT(corrected.region_farthest, 0.01);
}

}  // namespace
}  // namespace iqmpm
