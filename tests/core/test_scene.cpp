// Scene validation: an unknown key, a wrong type or an out-of-range value is rejected with
// an InputError naming the key path and what is accepted; --set overrides reach any key.
#include "core/errors.h"
#include "test_helpers.h"

namespace iqmpm {
namespace {

Json valid_scene() { return testing::fluid_box_scene(2, 0.1, {0.5, 0.5}, {1.0, 1.0}); }

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

TEST(SceneTest, ValidSceneFillsDefaults) {
  const SceneSpec scene = read_scene(valid_scene());
  EXPECT_EQ(scene.dim, 2);
  EXPECT_DOUBLE_EQ(scene.cfl, 0.5);
  EXPECT_DOUBLE_EQ(scene.fluid.density, 1000);
  EXPECT_TRUE(scene.slip_walls[0][0]);
  EXPECT_EQ(scene.solver.method, LinearSolverMethod::automatic);
}

TEST(SceneTest, UnknownKeyIsNamedWithAcceptedKeys) {
  Json doc = valid_scene();
  doc["fluid"]["densty"] = 1000;
  expect_rejected(doc, {"unknown scene key 'fluid.densty'", "density"});
}

TEST(SceneTest, WrongTypeIsNamed) {
  Json doc = valid_scene();
  doc["end_time"] = "long";
  expect_rejected(doc, {"'end_time'", "expected a number", "a string"});
}

TEST(SceneTest, OutOfRangeValueIsNamedWithRange) {
  Json doc = valid_scene();
  doc["cfl"] = 1.5;
  expect_rejected(doc, {"'cfl' = 1.5", "> 0 and <= 1"});
}

TEST(SceneTest, WrongVectorLengthIsNamed) {
  Json doc = valid_scene();
  doc["fluid"]["shapes"][0]["max"] = {0.5, 0.5, 0.5};
  expect_rejected(doc, {"fluid.shapes[0].max", "array of 2 numbers"});
}

TEST(SceneTest, UnknownChoiceListsAcceptedValues) {
  Json doc = valid_scene();
  doc["walls"] = {{"x-", "sticky"}};
  expect_rejected(doc, {"walls.x-", "slip, none"});
}

TEST(SceneTest, SpacingMustDivideTheDomain) {
  Json doc = valid_scene();
  doc["dx"] = 0.3;
  expect_rejected(doc, {"'dx'", "whole number"});
}

TEST(SceneTest, MissingRequiredKeyIsNamed) {
  Json doc = valid_scene();
  doc.erase("end_time");
  expect_rejected(doc, {"'end_time' is required"});
}

TEST(SceneTest, DuplicateProbeNamesAreRejected) {
  Json doc = valid_scene();
  doc["probes"] = Json::array({{{"type", "max_speed"}}, {{"type", "max_speed"}}});
  expect_rejected(doc, {"probes[1].name", "max_speed"});
}

TEST(SceneTest, OverridesReachNestedKeysAndArrays) {
  Json doc = valid_scene();
  apply_override(doc, "dx=0.05");
  apply_override(doc, "solver.method=pcg");
  apply_override(doc, "fluid.shapes.0.max=[0.4,0.3]");
  const SceneSpec scene = read_scene(doc);
  EXPECT_DOUBLE_EQ(scene.dx, 0.05);
  EXPECT_EQ(scene.solver.method, LinearSolverMethod::pcg);
  EXPECT_DOUBLE_EQ(scene.fluid.shapes[0].max[1], 0.3);
  EXPECT_THROW(apply_override(doc, "fluid.shapes.3.max=[1,1]"), InputError);
  EXPECT_THROW(apply_override(doc, "novalue"), InputError);
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

Json solid_scene() {
  Json doc = {{"dim", 2},
              {"domain", {{"min", {0.0, 0.0}}, {"max", {1.0, 1.0}}}},
              {"dx", 0.1},
              {"end_time", 1.0},
              {"solids", Json::array({{{"youngs_modulus", 1e6}, {"poisson_ratio", 0.3},
                                       {"shapes", Json::array({{{"type", "box"}, {"min", {0.2, 0.2}}, {"max", {0.4, 0.4}}}})}}})}};
  return doc;
}

TEST(SceneSolidTest, SolidOnlySceneIsValidWithDefaults) {
  const SceneSpec scene = read_scene(solid_scene());
  ASSERT_EQ(scene.solids.size(), 1u);
  EXPECT_EQ(scene.solids[0].name, "solid0");
  EXPECT_EQ(scene.solids[0].model, SolidModel::fixed_corotated);
  EXPECT_NEAR(scene.solids[0].mu, 1e6 / 2.6, 1e-6);
  EXPECT_NEAR(scene.solids[0].lambda, 1e6 * 0.3 / (1.3 * 0.4), 1e-6);
  EXPECT_DOUBLE_EQ(scene.solids[0].ghost_stiffness, 1e5);
  EXPECT_TRUE(scene.fluid.shapes.empty());
}

TEST(SceneSolidTest, ElasticConstantsAreOnePairOnly) {
  Json doc = solid_scene();
  doc["solids"][0]["mu"] = 1e5;
  expect_rejected(doc, {"'solids[0]'", "youngs_modulus and poisson_ratio, or mu and lambda"});
  doc = solid_scene();
  doc["solids"][0].erase("youngs_modulus");
  doc["solids"][0].erase("poisson_ratio");
  expect_rejected(doc, {"'solids[0]'", "exactly one pair"});
}

TEST(SceneSolidTest, IncompressiblePoissonRatioIsRejected) {
  Json doc = solid_scene();
  doc["solids"][0]["poisson_ratio"] = 0.5;
  expect_rejected(doc, {"'solids[0].poisson_ratio' = 0.5", "< 0.5"});
}

TEST(SceneSolidTest, UnknownModelAndMissingShapesAreNamed) {
  Json doc = solid_scene();
  doc["solids"][0]["model"] = "mooney";
  expect_rejected(doc, {"'solids[0].model'", "fixed_corotated, neo_hookean"});
  doc = solid_scene();
  doc["solids"][0].erase("shapes");
  expect_rejected(doc, {"'solids[0].shapes'", "at least one shape"});
}

TEST(SceneSolidTest, DuplicateSolidNamesAreRejected) {
  Json doc = solid_scene();
  doc["solids"].push_back(doc["solids"][0]);
  doc["solids"][0]["name"] = "gate";
  doc["solids"][1]["name"] = "gate";
  expect_rejected(doc, {"'solids[1].name' = \"gate\"", "solids[0]"});
}

TEST(SceneSolidTest, NoMaterialAtAllIsRejected) {
  Json doc = solid_scene();
  doc.erase("solids");
  expect_rejected(doc, {"no material"});
}

}  // namespace
}  // namespace iqmpm
