// The direct solvers of make_linear_solver (linear_solver.h), made there by solver.method.
#pragma once

#include <memory>

#include "linear_solver/linear_solver.h"

namespace iqmpm {

// CHOLMOD's simplicial LL^T with AMD ordering; an exact zero pivot retries once shifted.
std::unique_ptr<LinearSolver> make_cholmod_llt_solver();
// CHOLMOD's LDL^T: keeps its symbolic analysis while the pattern repeats and modifies its
// factor a row at a time for the active set's rounds; `simplicial` keeps it from choosing
// a supernodal LL^T (LinearSolverOptions::simplicial).
std::unique_ptr<LinearSolver> make_ldlt_solver(bool simplicial);

}  // namespace iqmpm
