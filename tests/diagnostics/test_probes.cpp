// Probes measure what benchmarks.md defines: at t = 0 the dam-break front is the column
// width a and the water height at the left wall is 2a (the half particle spacing beyond
// the outermost particles is counted), and a drop above the column does not raise it.
// Typed over 2-D and 3-D: the 3-D column is the 2-D one extruded between the z walls and
// reads the same; a 3-D gauge is a row of columns across, each with its own top.
#include <cmath>

#include "diagnostics/measurements.h"
#include "run/runner.h"
#include "simulation/simulation.h"
#include "support/scenes.h"
#include "support/test_helpers.h"

namespace iqmpm {
namespace {

double first_row(const RunResult& result, const std::string& name) {
  for (std::size_t c = 0; c < result.columns.size(); ++c)
    if (result.columns[c] == name) return result.metrics.front()[c];
  ADD_FAILURE() << "no metric " << name;
  return 0;
}

template <class D>
class ProbeTest : public ::testing::Test {
 protected:
  static constexpr int dim = D::value;
  static constexpr Real dx = 0.0365;  // the column 0.146 x 0.292 m is 4 x 8 cells

  // The dam-break benchmark with overrides (written for its 2-D document); in 3-D extruded
  // 4 cells deep between the z walls: every gauge reads the 2-D value.
  static SceneSpec dam_break(std::vector<std::string> overrides) {
    overrides.insert(overrides.begin(), "dx=" + std::to_string(dx));
    return read_scene(testing::in_dim<dim>(testing::benchmark_document("dam_break/dam_break.json", overrides), 4 * dx));
  }
};
TYPED_TEST_SUITE(ProbeTest, testing::Dimensions);

TYPED_TEST(ProbeTest, DamBreakColumnAtRest) {
  const RunResult result = run_scene(this->dam_break({"end_time=0.001"}), {});
  ASSERT_TRUE(result.ok);
  EXPECT_NEAR(first_row(result, "front_x"), 0.146, 1e-12);
  EXPECT_NEAR(first_row(result, "height_left"), 0.292, 1e-12);
}

TYPED_TEST(ProbeTest, DetachedDropDoesNotCountAsWaterHeight) {
  const RunResult result = run_scene(
      this->dam_break({"end_time=0.001",
                       R"(fluid.shapes=[{"type":"box","min":[0,0],"max":[0.146,0.292]},{"type":"box","min":[0,0.4],"max":[0.0365,0.438]}])"}),
      {});
  ASSERT_TRUE(result.ok);
  EXPECT_NEAR(first_row(result, "height_left"), 0.292, 1e-12);
}

// A mean level over gauges (water_height with `to`): over a column with a step in its
// surface, the mean of the two heights weighted by their widths (0.292 m over x < 0.146,
// 0.146 m over 0.146 < x < 0.292: gauges every dx = 0.0365 from 0.01825 to 0.27375 are
// four on each part).
TYPED_TEST(ProbeTest, MeanWaterLevelAveragesTheGauges) {
  const RunResult result = run_scene(
      this->dam_break({"end_time=0.001",
                       R"(fluid.shapes=[{"type":"box","min":[0,0],"max":[0.146,0.292]},{"type":"box","min":[0.146,0],"max":[0.292,0.146]}])",
                       R"(probes=[{"type":"water_height","name":"level","position":0.01825,"to":0.27375}])"}),
      {});
  ASSERT_TRUE(result.ok);
  EXPECT_NEAR(first_row(result, "level"), 0.5 * (0.292 + 0.146), 1e-12);
}

// In 3-D a gauge is a row of columns along z, each with its own top: water 0.5 m deep
// with a ridge 0.125 m high over a quarter of the tank's z extent reads 0.5 + 0.125 / 4 m
// (the highest particle over the whole row would read the ridge, 0.625 m), and a drop
// above the surface does not count.
TEST(ProbeTest, WaterHeightIn3DAveragesTheColumnsAcross) {
  const std::string path = std::string(IQMPM_BENCHMARKS_DIR) + "/hydrostatic/hydrostatic_3d.json";
  const RunResult result = run_scene(
      load_scene(path, {"dx=0.125", "end_time=0.001", "domain.max=[1,1,1]",
                        R"(fluid.shapes=[{"type":"box","min":[0,0,0],"max":[1,0.5,1]},{"type":"box","min":[0,0.5,0],"max":[1,0.625,0.25]},{"type":"box","min":[0,0.875,0.5],"max":[1,1,0.625]}])",
                        R"(probes=[{"type":"water_height","name":"level","position":0.0625,"to":0.9375}])"}),
      {});
  ASSERT_TRUE(result.ok);
  EXPECT_NEAR(first_row(result, "level"), 0.5 + 0.125 / 4, 1e-12);
}

// The water volume is the volume of the region the water fills; the particle measure
// counts each cell's particle volume up to dx^dim. On the dam-break column at rest (2^dim
// particles a cell, 4 x 8 cells, 4 deep in 3-D) both are the column's volume. Moving one
// particle of an interior cell into its neighbour leaves the region as it was but loses a
// particle's volume (a quarter cell in 2-D, an eighth in 3-D) from the particle measure
// (the crowded cell is capped at dx^dim, the thinned one short); a particle lifted off a
// surface cell keeps its volume as a drop, and the drop counts no more once it is out of
// the domain.
TYPED_TEST(ProbeTest, WaterVolumeIsTheRegionTheWaterFills) {
  constexpr int dim = TypeParam::value;
  constexpr Real dx = TestFixture::dx;
  Simulation<dim> sim(this->dam_break({}));
  const double volume = 0.146 * 0.292 * (dim == 3 ? 4 * dx : 1.0), particle = std::pow(dx, dim) / (1 << dim);
  EXPECT_NEAR(fluid_volume(sim), volume, 1e-12);
  EXPECT_NEAR(fluid_particle_volume(sim), volume, 1e-12);
  auto& x = sim.fluid().position;
  const auto in_cell = [&](double cx, double cy) {  // at z cell 1 in 3-D
    for (std::size_t p = 0; p < x.size(); ++p)
      if (std::floor(x[p][0] / dx) == cx && std::floor(x[p][1] / dx) == cy && (dim == 2 || std::floor(x[p][dim - 1] / dx) == 1))
        return p;
    ADD_FAILURE() << "no particle in cell " << cx << ", " << cy;
    return std::size_t(0);
  };
  x[in_cell(1, 3)][1] += dx;  // interior cell (1, 3) -> (1, 4)
  EXPECT_NEAR(fluid_volume(sim), volume, 1e-12);
  EXPECT_NEAR(fluid_particle_volume(sim), volume - particle, 1e-12);
  x[in_cell(3, 7)][1] += 5 * dx;  // off the top surface cell (3, 7) into the air
  EXPECT_NEAR(fluid_volume(sim), volume, 1e-12) << "a detached drop keeps its volume";
  x[in_cell(3, 12)][1] = 10;  // the drop leaves the domain: not counted
  EXPECT_NEAR(fluid_volume(sim), volume - particle, 1e-12);
}

}  // namespace
}  // namespace iqmpm
