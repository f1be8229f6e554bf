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
  EXPECT_EQ(scene.walls[0][0], "slip");
  EXPECT_EQ(scene.solver.method, "auto");
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
  EXPECT_EQ(scene.solver.method, "pcg");
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
