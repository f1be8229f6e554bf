// Scene validation: an unknown key, a wrong type or an out-of-range value is rejected with
// an InputError naming the key path and what is accepted; --set overrides reach any key.
#include "core/errors.h"
#include "support/test_helpers.h"

namespace iqmpm {
namespace {


// Expects read_scene to throw an InputError whose message contains every fragment.
void expect_rejected(const Json& doc, const std::vector<std::string>& fragments) {
  try {
    read_scene(doc);
    ADD_FAILURE() << "scene was accepted: " << doc.dump();
  } catch (const InputError& error) {
    for (const auto& fragment : fragments)
      EXPECT_NE(std::string(error.what()).find(fragment), std::string::npos) << error.what() << "\n  lacks: " << fragment;
  }
}

// The reader is one for both dimensions (the scene's "dim"); vectors have dim entries.
template <class D>
class SceneTest : public ::testing::Test {
 protected:
  static constexpr int dim = D::value;
  static Json valid_scene() { return testing::fluid_box_scene(dim, 0.1, std::vector<Real>(dim, 0.5), std::vector<Real>(dim, 1.0)); }
};
TYPED_TEST_SUITE(SceneTest, testing::Dimensions);

TYPED_TEST(SceneTest, ValidSceneFillsDefaults) {
  constexpr int dim = TestFixture::dim;
  Json doc = this->valid_scene();
  doc.erase("gravity");
  const SceneSpec scene = read_scene(doc);
  EXPECT_EQ(scene.dim, dim);
  EXPECT_EQ(scene.gravity, testing::xyz<dim>(0, -9.81, 0));
  EXPECT_DOUBLE_EQ(scene.cfl, 0.5);
  EXPECT_DOUBLE_EQ(scene.fluid.density, 1000);
  EXPECT_TRUE(scene.slip_walls[0][0]);
  EXPECT_EQ(scene.solver.method, LinearSolverMethod::automatic);
}

TYPED_TEST(SceneTest, UnknownKeyIsNamedWithAcceptedKeys) {
  Json doc = this->valid_scene();
  doc["fluid"]["densty"] = 1000;
  expect_rejected(doc, {"unknown scene key 'fluid.densty'", "density"});
  // A misspelt key is named with the key it most likely meant; the accepted keys of an
  // either-or choice are listed whichever pair the object used.
  Json solid = this->valid_scene();
  solid["solids"] = Json::array({{{"density", 500}, {"youngs_modulus", 1e6}, {"poisson_ratio", 0.3}, {"lamda", 1e6},
                                  {"shapes", Json::array({{{"type", "box"}, {"min", std::vector<Real>(TestFixture::dim, 0.6)},
                                                           {"max", std::vector<Real>(TestFixture::dim, 0.7)}}})}}});
  expect_rejected(solid, {"unknown scene key 'solids[0].lamda' (did you mean 'lambda'?)", "mu", "youngs_modulus"});
}

TYPED_TEST(SceneTest, WrongTypeIsNamed) {
  Json doc = this->valid_scene();
  doc["end_time"] = "long";
  expect_rejected(doc, {"'end_time'", "expected a number", "a string"});
}

TYPED_TEST(SceneTest, OutOfRangeValueIsNamedWithRange) {
  Json doc = this->valid_scene();
  doc["cfl"] = 1.5;
  expect_rejected(doc, {"'cfl' = 1.5", "> 0 and <= 1"});
}

TYPED_TEST(SceneTest, WrongVectorLengthIsNamed) {
  Json doc = this->valid_scene();
  constexpr int dim = TestFixture::dim;
  doc["fluid"]["shapes"][0]["max"] = std::vector<Real>(dim + 1, 0.5);
  expect_rejected(doc, {"fluid.shapes[0].max", "array of " + std::to_string(dim) + " numbers"});
}

TYPED_TEST(SceneTest, UnknownChoiceListsAcceptedValues) {
  Json doc = this->valid_scene();
  doc["walls"] = {{"x-", "sticky"}};
  expect_rejected(doc, {"walls.x-", "slip, none"});
}

TYPED_TEST(SceneTest, SpacingMustDivideTheDomain) {
  Json doc = this->valid_scene();
  doc["dx"] = 0.3;
  expect_rejected(doc, {"'dx'", "whole number"});
}

TYPED_TEST(SceneTest, MissingRequiredKeyIsNamed) {
  Json doc = this->valid_scene();
  doc.erase("end_time");
  expect_rejected(doc, {"'end_time' is required"});
}

TYPED_TEST(SceneTest, DuplicateProbeNamesAreRejected) {
  Json doc = this->valid_scene();
  doc["probes"] = Json::array({{{"type", "max_speed"}}, {{"type", "max_speed"}}});
  expect_rejected(doc, {"probes[1].name", "max_speed"});
}

TYPED_TEST(SceneTest, OverridesReachNestedKeysAndArrays) {
  Json doc = this->valid_scene();
  apply_override(doc, "dx=0.05");
  apply_override(doc, "solver.method=pcg");
  apply_override(doc, TestFixture::dim == 2 ? "fluid.shapes.0.max=[0.4,0.3]" : "fluid.shapes.0.max=[0.4,0.3,0.4]");
  const SceneSpec scene = read_scene(doc);
  EXPECT_DOUBLE_EQ(scene.dx, 0.05);
  EXPECT_EQ(scene.solver.method, LinearSolverMethod::pcg);
  EXPECT_DOUBLE_EQ(scene.fluid.shapes[0].max[1], 0.3);
  EXPECT_THROW(apply_override(doc, "fluid.shapes.3.max=[1,1]"), InputError);
  EXPECT_THROW(apply_override(doc, "novalue"), InputError);
}

// Grid layouts and particles are indexed by int: a dx whose seeding lattice (cells x
// particles_per_axis^dim) passes 2^31 is refused naming dx, not left to wrap into "no
// particle was seeded" (the dam break at dx = 2e-5); one just below is read.
TYPED_TEST(SceneTest, SpacingBeyondTheIndexRangeIsRefused) {
  constexpr int dim = TestFixture::dim;
  Json doc = this->valid_scene();
  doc["dx"] = dim == 2 ? 1.0 / 25000 : 1.0 / 1000;  // 2.5e9 and 8e9 lattice points
  expect_rejected(doc, {"'dx'", "32-bit indices", "accepted: dx >="});
  doc["dx"] = dim == 2 ? 1.0 / 20000 : 1.0 / 640;  // 1.6e9 and 2.1e9
  EXPECT_NO_THROW(read_scene(doc));
  doc["particles_per_axis"] = 3;  // 3.6e9 and 7.1e9
  expect_rejected(doc, {"'dx'", "particles_per_axis = 3"});
}

// A body seeded finer than the water (solids[].particles_per_axis, default the scene's):
// read, bounded like the scene's, and its own lattice kept within the index range.
TYPED_TEST(SceneTest, SolidParticlesPerAxisDefaultsToTheScenesAndIsChecked) {
  constexpr int dim = TestFixture::dim;
  Json doc = this->valid_scene();
  doc["particles_per_axis"] = 3;
  doc["solids"] = Json::array({{{"youngs_modulus", 1e6}, {"poisson_ratio", 0.3},
                                {"shapes", Json::array({testing::box(std::vector<Real>(dim, 0.6), std::vector<Real>(dim, 0.7))})}}});
  EXPECT_EQ(read_scene(doc).solids[0].particles_per_axis, 3);
  doc["solids"][0]["particles_per_axis"] = 5;
  EXPECT_EQ(read_scene(doc).solids[0].particles_per_axis, 5);
  EXPECT_EQ(read_scene(doc).particles_per_axis, 3);
  doc["solids"][0]["particles_per_axis"] = 9;
  expect_rejected(doc, {"'solids[0].particles_per_axis'", "9"});
  doc["solids"][0]["particles_per_axis"] = 8;
  doc["particles_per_axis"] = 1;
  doc["dx"] = dim == 2 ? 1.0 / 8000 : 1.0 / 400;  // the body's lattice: 4.1e9 and 3.3e10 points
  expect_rejected(doc, {"'solids[0].particles_per_axis' = 8", "32-bit indices"});
}

// The even-odd rule would fill a self-intersecting polygon otherwise than drawn.
TEST(SceneTest, SelfIntersectingPolygonIsRefused) {
  Json doc = testing::fluid_box_scene(2, 0.1, {0.5, 0.5}, {1.0, 1.0});
  auto polygon = [](std::vector<Real> vertices) { return Json{{"type", "polygon"}, {"vertices", vertices}}; };
  doc["fluid"]["shapes"][0] = polygon({0.1, 0.1, 0.4, 0.4, 0.4, 0.1, 0.1, 0.4});  // a bow tie: edges 0 and 2 cross
  expect_rejected(doc, {"'fluid.shapes[0].vertices'", "intersects itself", "edge 0", "edge 2", "simple polygon"});
  doc["fluid"]["shapes"][0] = polygon({0.1, 0.1, 0.5, 0.1, 0.3, 0.1, 0.3, 0.4});  // edge 1 folds back along edge 0
  expect_rejected(doc, {"'fluid.shapes[0].vertices'", "intersects itself"});
  doc["fluid"]["shapes"][0] = polygon({0.1, 0.1, 0.5, 0.1, 0.5, 0.2, 0.2, 0.2, 0.2, 0.5, 0.1, 0.5});  // an L: concave, simple
  EXPECT_NO_THROW(read_scene(doc));
  doc["solids"] = Json::array({{{"youngs_modulus", 1e6}, {"poisson_ratio", 0.3},
                                {"shapes", Json::array({polygon({0.6, 0.6, 0.9, 0.9, 0.9, 0.6, 0.6, 0.9})})}}});
  expect_rejected(doc, {"'solids[0].shapes[0].vertices'", "intersects itself"});
}

TEST(SceneTest, EveryKeyIsDocumented) {
  const auto docs = document_scene_keys();
  auto documented = [&](const std::string& path) {
    for (const auto& d : docs)
      if (d.path == path) return !d.meaning.empty();
    return false;
  };
  for (const char* path : {"dx", "cfl", "fluid.density", "solver.method", "walls.x-", "probes[].type", "fluid.shapes[].radius"})
    EXPECT_TRUE(documented(path)) << path;
}

}  // namespace
}  // namespace iqmpm

namespace iqmpm {
namespace {

template <class D>
class SceneSolidTest : public ::testing::Test {
 protected:
  static constexpr int dim = D::value;
  static Json solid_scene() {
    using testing::xyz;
    return {{"dim", dim},
            {"domain", {{"min", xyz<dim>(0, 0, 0)}, {"max", xyz<dim>(1, 1, 1)}}},
            {"dx", 0.1},
            {"end_time", 1.0},
            {"solids", Json::array({{{"youngs_modulus", 1e6}, {"poisson_ratio", 0.3},
                                     {"shapes", Json::array({testing::box(xyz<dim>(0.2, 0.2, 0.2), xyz<dim>(0.4, 0.4, 0.4))})}}})}};
  }
};
TYPED_TEST_SUITE(SceneSolidTest, testing::Dimensions);

TYPED_TEST(SceneSolidTest, SolidOnlySceneIsValidWithDefaults) {
  const SceneSpec scene = read_scene(this->solid_scene());
  ASSERT_EQ(scene.solids.size(), 1u);
  EXPECT_EQ(scene.solids[0].name, "solid0");
  EXPECT_EQ(scene.solids[0].model, SolidModel::fixed_corotated);
  EXPECT_NEAR(scene.solids[0].mu, 1e6 / 2.6, 1e-6);
  EXPECT_NEAR(scene.solids[0].lambda, 1e6 * 0.3 / (1.3 * 0.4), 1e-6);
  EXPECT_DOUBLE_EQ(scene.solids[0].ghost_stiffness, 1e5);
  EXPECT_TRUE(scene.fluid.shapes.empty());
}

TYPED_TEST(SceneSolidTest, ElasticConstantsAreOnePairOnly) {
  Json doc = this->solid_scene();
  doc["solids"][0]["mu"] = 1e5;
  expect_rejected(doc, {"'solids[0]'", "youngs_modulus and poisson_ratio, or mu and lambda"});
  doc = this->solid_scene();
  doc["solids"][0].erase("youngs_modulus");
  doc["solids"][0].erase("poisson_ratio");
  expect_rejected(doc, {"'solids[0]'", "exactly one pair"});
}

TYPED_TEST(SceneSolidTest, IncompressiblePoissonRatioIsRejected) {
  Json doc = this->solid_scene();
  doc["solids"][0]["poisson_ratio"] = 0.5;
  expect_rejected(doc, {"'solids[0].poisson_ratio' = 0.5", "< 0.5"});
}

// Rules that join options are the scene reader's, found before anything runs or is written.
TYPED_TEST(SceneSolidTest, CrossOptionRulesAreCheckedWhenReading) {
  Json doc = this->solid_scene();
  doc["solids"][0]["initial_pressure"] = "hydrostatic";  // a solid-only scene has no water
  expect_rejected(doc, {"'solids[0].initial_pressure' = \"hydrostatic\"", "needs fluid", "\"zero\""});
  doc = this->solid_scene();
  doc["experimental"] = {{"solid_response", "stiffness"}};
  doc["solver"] = {{"method", "pcg"}};
  expect_rejected(doc, {"'experimental.solid_response' = \"stiffness\"", "ldlt"});
  doc["solver"] = {{"method", "ldlt"}};
  EXPECT_EQ(read_scene(doc).experimental.solid_response, SolidResponse::stiffness);
  doc["solid_weak_nodes"] = "extended";
  expect_rejected(doc, {"'experimental.solid_response' = \"stiffness\"", "solid_weak_nodes = \"free\""});
  doc["solid_weak_nodes"] = "gone";
  expect_rejected(doc, {"'solid_weak_nodes'", "extended", "free"});
  doc = this->solid_scene();
  doc["end_time"] = 1e-300;
  expect_rejected(doc, {"'end_time'", "dt_min"});
  doc = this->solid_scene();
  doc["solid_step_error"] = 1e-3;  // the estimate is the midpoint rule's
  expect_rejected(doc, {"'solid_step_error' = 0.001", "midpoint"});
  doc["solid_time_integration"] = "midpoint";
  EXPECT_EQ(read_scene(doc).solid_step_error, 1e-3);
  doc["solid_step_error"] = -1;
  expect_rejected(doc, {"'solid_step_error'"});
}

TYPED_TEST(SceneSolidTest, UnknownModelAndMissingShapesAreNamed) {
  Json doc = this->solid_scene();
  doc["solids"][0]["model"] = "mooney";
  expect_rejected(doc, {"'solids[0].model'", "fixed_corotated, neo_hookean"});
  doc = this->solid_scene();
  doc["solids"][0].erase("shapes");
  expect_rejected(doc, {"'solids[0].shapes'", "at least one shape"});
}

TYPED_TEST(SceneSolidTest, DuplicateSolidNamesAreRejected) {
  Json doc = this->solid_scene();
  doc["solids"].push_back(doc["solids"][0]);
  doc["solids"][0]["name"] = "gate";
  doc["solids"][1]["name"] = "gate";
  expect_rejected(doc, {"'solids[1].name' = \"gate\"", "solids[0]"});
}

// Two bodies seeded into the same space are refused naming both shapes; bodies that touch,
// and overlapping shapes of one body, are accepted.
TYPED_TEST(SceneSolidTest, OverlappingBodiesAreRefused) {
  using testing::xyz;
  constexpr int dim = TestFixture::dim;
  Json doc = this->solid_scene();
  doc["solids"].push_back(doc["solids"][0]);
  doc["solids"][1]["shapes"][0] = testing::box(xyz<dim>(0.3, 0.3, 0.3), xyz<dim>(0.6, 0.6, 0.6));
  expect_rejected(doc, {"'solids[1].shapes[0]'", "overlaps solids[0].shapes[0]", "accepted"});
  doc["solids"][1]["shapes"][0] = testing::box(xyz<dim>(0.4, 0.2, 0.2), xyz<dim>(0.6, 0.4, 0.4));  // touching at x = 0.4
  EXPECT_NO_THROW(read_scene(doc));
  Json sphere = {{"type", "sphere"}, {"centre", xyz<dim>(0.65, 0.3, 0.3)}, {"radius", 0.1}};  // inside the second box
  doc["solids"][1]["shapes"].push_back(sphere);
  EXPECT_NO_THROW(read_scene(doc));
  doc["solids"][0]["shapes"].push_back(sphere);
  expect_rejected(doc, {"'solids[1].shapes[0]'", "overlaps solids[0].shapes[1]"});
}

TYPED_TEST(SceneSolidTest, NoMaterialAtAllIsRejected) {
  Json doc = this->solid_scene();
  doc.erase("solids");
  expect_rejected(doc, {"no material"});
}

}  // namespace
}  // namespace iqmpm
