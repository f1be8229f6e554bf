// Readers of the scene's list entries, each a JSON object of its own: a shape (fluid.shapes[],
// solids[].shapes[] and .clamps[], probes[].region[]), a solid (solids[]) and a probe
// (probes[]). scene/scene.cpp reads the rest of the scene and the checks that join entries
// (names unique, probes naming solids that exist).
#pragma once

#include <vector>

#include "core/types.h"
#include "scene/json_reader.h"
#include "scene/scene.h"

namespace iqmpm {

ShapeSpec read_shape(JsonReader& r, int dim);

// domain_min / domain_max: a probe's point must lie in the domain.
ProbeSpec read_probe(JsonReader& r, int dim, const std::vector<Real>& domain_min, const std::vector<Real>& domain_max);

// index: the solid's place in solids[] (its default name); scene_particles_per_axis: its
// default particles_per_axis.
SolidSpec read_solid(JsonReader& r, int dim, int index, int scene_particles_per_axis);

}  // namespace iqmpm
