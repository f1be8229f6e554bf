// Reads the scene's `solver` object (scene/scene.cpp reads the rest of the scene).
#pragma once

#include "linear_solver/linear_solver.h"
#include "pressure/warm_start.h"
#include "scene/json_reader.h"

namespace iqmpm {

// o: solver.method ... solver.amg_*; w: solver.warm_start, warm_start_history, model.
// docs: documentation mode (no cross-checks between keys).
void read_solver_keys(JsonReader& solver, LinearSolverOptions& o, WarmStartSpec& w, bool docs);

}  // namespace iqmpm
