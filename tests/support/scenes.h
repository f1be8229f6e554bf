// Scene documents for the typed tests: a benchmark's document with overrides, and a 2-D
// document extruded along z, so that the 3-D instance of a test runs the same set-up.
#pragma once

#include <gtest/gtest.h>

#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "scene/json_reader.h"
#include "scene/scene.h"

namespace iqmpm::testing {

// The document of a scene file under benchmarks/, with `--set` overrides applied.
inline Json benchmark_document(const std::string& relative, const std::vector<std::string>& overrides = {}) {
  std::ifstream in(std::string(IQMPM_BENCHMARKS_DIR) + "/" + relative);
  EXPECT_TRUE(in.good()) << relative;
  std::stringstream text;
  text << in.rdbuf();
  Json doc = Json::parse(text.str());
  for (const auto& assignment : overrides) apply_override(doc, assignment);
  return doc;
}

// A 2-D scene document extended along z, `depth` deep between the z walls (slip walls
// unless the document says otherwise): the domain and the boxes that seed material (fluid
// and solid shapes) span [0, depth] in z; the boxes that select (clamps, probe regions)
// span every z, [-depth, 2 depth], as in 2-D; vectors (gravity, initial velocities) get a
// zero z component and probe points sit at mid-depth. A flow of the 2-D scene is a flow of
// the extruded one, the same per unit depth. Boxes only: a disk or polygon fails the test.
inline Json extruded(Json doc, Real depth) {
  auto append = [](Json& vector, Real z) {
    if (vector.is_array() && vector.size() == 2) vector.push_back(z);
  };
  auto extrude_shapes = [&](Json& shapes, Real from, Real to) {
    if (!shapes.is_array()) return;
    for (Json& shape : shapes) {
      if (shape.value("type", std::string("box")) != "box") {
        ADD_FAILURE() << "extruded(): only boxes extrude, not " << shape.dump();
        continue;
      }
      append(shape["min"], from);
      append(shape["max"], to);
    }
  };
  doc["dim"] = 3;
  append(doc["domain"]["min"], 0);
  append(doc["domain"]["max"], depth);
  if (doc.contains("gravity")) append(doc["gravity"], 0);
  if (doc.contains("fluid")) {
    extrude_shapes(doc["fluid"]["shapes"], 0, depth);
    if (doc["fluid"].contains("initial_velocity")) append(doc["fluid"]["initial_velocity"], 0);
  }
  if (doc.contains("solids"))
    for (Json& solid : doc["solids"]) {
      extrude_shapes(solid["shapes"], 0, depth);
      if (solid.contains("clamps")) extrude_shapes(solid["clamps"], -depth, 2 * depth);
      if (solid.contains("initial_velocity")) append(solid["initial_velocity"], 0);
    }
  if (doc.contains("probes"))
    for (Json& probe : doc["probes"]) {
      if (probe.contains("point")) append(probe["point"], depth / 2);
      if (probe.contains("region")) extrude_shapes(probe["region"], -depth, 2 * depth);
    }
  return doc;
}

// The document in `dim` dimensions: itself in 2-D, extruded `depth` deep in 3-D.
template <int dim>
Json in_dim(const Json& doc, Real depth) {
  if constexpr (dim == 2) return doc;
  else return extruded(doc, depth);
}

// A block 0.2 x 0.1 m with its centre 0.25 m under the surface of water 0.5 m deep in a
// tank 1 m wide (benchmarks.md submerged_block): the benchmark's scene, clamped, or its
// neutral_block.json, free with rho_s = rho_f (`file`). In 3-D the block is 0.2 m deep, in
// the middle of a tank 0.6 m wide (x from 0.2 to 0.8 m) and 0.4 m deep, with water all
// round, at dx 0.025 instead of 0.0125. (At dx 0.05, the block two cells high, M^f
// weighs the water 2.6 % heavy in 2-D and 1.5 % in 3-D.)
template <int dim>
Json submerged_block_document(const std::string& file, const std::vector<std::string>& overrides = {}) {
  Json doc = benchmark_document("submerged_block/" + file, overrides);
  if constexpr (dim == 3) {
    doc = extruded(doc, 0.4);
    doc["dx"] = 0.025;
    doc["domain"]["min"][0] = 0.2;
    doc["domain"]["max"][0] = 0.8;
    for (Json& shape : doc["fluid"]["shapes"]) shape["min"][0] = 0.2, shape["max"][0] = 0.8;
    Json& solid = doc["solids"][0];
    for (Json* shape : {&solid["shapes"][0], solid.contains("clamps") ? &solid["clamps"][0] : nullptr})
      if (shape) (*shape)["min"][2] = 0.1, (*shape)["max"][2] = 0.3;
  }
  return doc;
}

template <int dim>
Real submerged_block_volume() {
  return dim == 2 ? 0.2 * 0.1 : 0.2 * 0.1 * 0.2;
}

}  // namespace iqmpm::testing
