// Linear solvers for the symmetric positive (semi-)definite pressure system, behind one
// interface: preconditioned CG (MIC(0) or Jacobi) and SuiteSparse CHOLMOD.
#pragma once

#include <Eigen/SparseCore>
#include <memory>
#include <string>

#include "core/types.h"

namespace iqmpm {

struct LinearSolverOptions {
  std::string method = "auto";          // auto | pcg | cholmod
  std::string preconditioner = "mic0";  // mic0 | jacobi (pcg only)
  Real tolerance = 1e-6;                // relative residual ||b - A x|| / ||b||
  int max_iterations = 2000;
  Real mic_relaxation = 0.97;           // omega of MIC(0); 0 gives plain IC(0)
  int cholmod_max_unknowns = 60000;     // auto: CHOLMOD up to this size, PCG above
  bool warm_start = true;
};

struct LinearSolveStats {
  std::string method;
  int iterations = 0;         // CG iterations (0 for a direct solve)
  Real relative_residual = 0;
  bool converged = false;
};

class LinearSolver {
 public:
  virtual ~LinearSolver() = default;
  // x holds the initial guess on entry (zero or the warm start) and the solution on exit.
  virtual LinearSolveStats solve(const Eigen::SparseMatrix<Real>& A, const Eigen::VectorXd& b,
                                 Eigen::VectorXd& x) = 0;
};

// Chooses the solver for a system of `unknowns` rows according to the options.
std::unique_ptr<LinearSolver> make_linear_solver(const LinearSolverOptions& options, int unknowns);

}  // namespace iqmpm
