// The resource estimate (run/resource_estimate.h): its counts are the seeding's, its frame
// count the runner's, and a scene past a limit is refused naming the keys and the option.
#include "core/errors.h"
#include "run/resource_estimate.h"
#include "simulation/simulation.h"
#include "support/scenes.h"
#include "support/test_helpers.h"

namespace iqmpm {
namespace {

// Boxes are counted exactly: the dam break's fluid and the floating block's solid. Fluid
// inside a solid is not taken off (high).
TEST(ResourceEstimateTest, ParticleCountsAreTheSeedings) {
  const SceneSpec dam = read_scene(testing::benchmark_document("dam_break/dam_break.json"));
  const ResourceEstimate e = estimate_resources(dam);
  EXPECT_NEAR(e.fluid_particles, double(Simulation<2>(dam).fluid().size()), 1e-6);
  EXPECT_NEAR(e.cells, 128.0 * 128.0, 1e-9);
  const SceneSpec block = read_scene(testing::benchmark_document("floating_block/floating_block.json"));
  const ResourceEstimate b = estimate_resources(block);
  const Simulation<2> sim(block);
  EXPECT_NEAR(b.solid_particles, double(sim.solid().size()), 1e-6 * b.solid_particles);
  EXPECT_GE(b.fluid_particles, double(sim.fluid().size()));
  EXPECT_LE(b.fluid_particles, double(sim.fluid().size() + sim.solid().size()) * (1 + 1e-9));
}

// Frames: the first, one every 1 / frame_rate, and the last; none without write_frames.
TEST(ResourceEstimateTest, FramesFollowEndTimeAndFrameRate) {
  Json doc = testing::benchmark_document("dam_break/dam_break.json");  // 0.6 s at 50 frames/s
  EXPECT_DOUBLE_EQ(estimate_resources(read_scene(doc)).frames, 32);
  doc["write_frames"] = false;
  EXPECT_DOUBLE_EQ(estimate_resources(read_scene(doc)).frames, 0);
}

// BoomerAMG's hierarchy is counted where PCG uses it, and only there: with a direct
// solve the preconditioner key changes nothing.
TEST(ResourceEstimateTest, BoomerAmgHierarchyIsCountedOnlyWithPcg) {
  auto memory = [](const std::string& method, const std::string& preconditioner) {
    return estimate_resources(read_scene(testing::benchmark_document(
                                  "hydrostatic/hydrostatic_3d.json", {"solver.method=" + method, "solver.preconditioner=" + preconditioner})))
        .memory_bytes;
  };
  EXPECT_GT(memory("pcg", "boomeramg"), memory("pcg", "ic0"));
  EXPECT_DOUBLE_EQ(memory("cholmod", "boomeramg"), memory("cholmod", "ic0"));
}

TEST(ResourceEstimateTest, PastALimitTheSceneIsRefusedNamingKeysAndOption) {
  const SceneSpec scene = read_scene(testing::benchmark_document("dam_break/dam_break.json", {"dx=1e-4"}));
  const ResourceEstimate e = estimate_resources(scene);
  EXPECT_NO_THROW(check_resources(e, {1.01 * e.memory_bytes, 1.01 * e.output_bytes}));
  try {
    check_resources(e, {0.99 * e.memory_bytes, 1e30});
    ADD_FAILURE() << "memory past the limit was accepted";
  } catch (const InputError& error) {
    for (const char* part : {"of memory, more than the limit", "'dx'", "'particles_per_axis'", "--max-memory"})
      EXPECT_NE(std::string(error.what()).find(part), std::string::npos) << error.what();
  }
  try {
    check_resources(e, {1e30, 0.99 * e.output_bytes});
    ADD_FAILURE() << "output past the limit was accepted";
  } catch (const InputError& error) {
    for (const char* part : {"of output, more than the limit", "'end_time'", "'frame_rate'", "--max-output"})
      EXPECT_NE(std::string(error.what()).find(part), std::string::npos) << error.what();
  }
}

}  // namespace
}  // namespace iqmpm
