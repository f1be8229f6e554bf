// Checks of a scene's geometry when it is read (scene/geometry.cpp); InputError naming the
// key, or a warning.
#pragma once

#include <string>
#include <vector>

#include "scene/scene.h"

namespace iqmpm {

// "x-", "x+", "y-", ... : a domain side as scenes name it.
const char* side_name(int axis, int side);
// A polygon's edges meet only at the vertices they share; `path` names its key.
void check_simple_polygon(const std::vector<Real>& vertices, const std::string& path);
// Bodies do not share space (error); a body reaching past the domain is clipped (warning).
void check_solid_geometry(const SceneSpec& scene);
// The seeding lattice and the node velocity components fit the solver's int indices.
void check_index_range(const SceneSpec& scene);

}  // namespace iqmpm
