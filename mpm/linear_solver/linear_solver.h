// Linear solvers for the symmetric positive (semi-)definite pressure system, behind one
// interface: preconditioned CG (incomplete Cholesky, Jacobi or hypre's BoomerAMG), and
// CHOLMOD's LDL^T and LL^T.
#pragma once

#include <Eigen/SparseCore>
#include <memory>
#include <string>
#include <vector>

#include "core/types.h"
#include "linear_solver/boomeramg.h"

namespace iqmpm {

enum class LinearSolverMethod { automatic, pcg, cholmod, ldlt };
enum class Preconditioner { ic0, ichol, jacobi, boomeramg };
// BoomerAMG on S A S with S the checkerboard signs of the unknowns' dual cells
// (linear_solver/boomeramg.h): automatic = on in 3-D, off in 2-D (docs/method.md#linear-solver).
enum class CheckerboardFlip { automatic, on, off };
// The fill-reducing order of a direct solve (grid/nested_dissection.h): a nested
// dissection of the cells each step's system has, the grid's, fixed for the run, or AMD on
// each new pattern.
enum class DirectOrdering { cells, grid, amd };
// What make_linear_solver makes for a given system (automatic resolved).
enum class LinearSolverKind { pcg, cholmod, ldlt };

struct LinearSolverOptions {
  LinearSolverMethod method = LinearSolverMethod::automatic;
  Preconditioner preconditioner = Preconditioner::ic0;  // pcg only
  Real tolerance = 1e-8;                // relative residual ||b - A x|| / ||b||
  int max_iterations = 2000;
  int direct_max_unknowns = 100000;     // auto, 2-D: direct LDL^T up to this size, PCG above
  DirectOrdering ordering = DirectOrdering::cells;  // ldlt
  // ldlt: keep the factor simplicial LDL^T, as row modifications (the unilateral
  // interface's rounds) and quasi-definite systems (the solid's stiffness) need; otherwise
  // CHOLMOD chooses supernodal LL^T where the factor is dense enough (3-D systems).
  bool simplicial = false;
  // pcg with boomeramg: the flip and the hierarchy's parameters.
  CheckerboardFlip checkerboard_flip = CheckerboardFlip::automatic;
  BoomerAmgParameters amg{};
};

struct LinearSolveStats {
  std::string method;
  int iterations = 0;         // CG iterations (0 for a direct solve)
  Real initial_relative_residual = 0;  // CG: of the first guess (1 from zero; 0 for a direct solve)
  Real relative_residual = 0;
  bool converged = false;
  bool shifted = false;       // direct solve: refactorised with a tiny diagonal shift after a zero pivot
  int modified_rows = 0;      // LDL^T: rows modified in its factorisation instead of factorising (0: factorised)
  bool supernodal = false;    // LDL^T: the factor CHOLMOD chose was supernodal LL^T (dense enough), not simplicial LDL^T
  int factor_threads = 1;     // LDL^T: threads its last factorisation ran on (2: by subtrees, the same factor)
};

class LinearSolver {
 public:
  virtual ~LinearSolver() = default;
  // x holds the initial guess on entry (zero or the warm start) and the solution on exit.
  virtual LinearSolveStats solve(const Eigen::SparseMatrix<Real>& A, const Eigen::VectorXd& b,
                                 Eigen::VectorXd& x) = 0;
  // Another right-hand side for the matrix of the last solve (same values): a direct
  // solver reuses its factor (two triangular solves), PCG its preconditioner.
  virtual LinearSolveStats solve_again(const Eigen::SparseMatrix<Real>& A, const Eigen::VectorXd& b, Eigen::VectorXd& x) {
    return solve(A, b, x);
  }
  // LDL^T also solves symmetric quasi-definite systems; CG and LL^T need SPD ones.
  virtual bool solves_quasi_definite() const = 0;
  // The method, as LinearSolveStats::method. A direct solver keeps its symbolic analysis
  // for the next solve of the same pattern, so a caller may keep one solver per system.
  virtual std::string name() const = 0;
  virtual LinearSolverKind kind() const = 0;
  // The next solve's matrix differs from the last one solved only in these rows and
  // columns: `released` ones became unit vectors, `restored` ones got their assembled
  // entries back (the active set's rounds, PressureSystem::release). The LDL^T solver then
  // modifies its factorisation row by row instead of factorising again; others ignore it.
  virtual void expect_row_changes(std::vector<int> /*released*/, std::vector<int> /*restored*/) {}
  // A fill-reducing order for the next analysis of a new pattern: order[k] is the unknown
  // eliminated k-th (the caller's, from the grid; empty: the solver's own, AMD). Direct
  // solvers use it; others ignore it.
  virtual void suggest_order(std::vector<int> /*order*/) {}
  // Whether the solver reads the checkerboard signs of the unknowns: PCG with BoomerAMG on
  // S A S (solver.amg_checkerboard_flip). The caller then hands them over before each
  // solve: signs[i] = (-1)^(sum of the multi-index of unknown i's dual cell), +1 for an
  // unknown without one. Signs of another length than the next system's are not used.
  virtual bool wants_checkerboard_signs() const { return false; }
  virtual void suggest_checkerboard_signs(std::vector<signed char> /*signs*/) {}
};

// Chooses the solver for a system of `unknowns` rows according to the options. "auto" is
// LDL^T for 2-D systems up to direct_max_unknowns and PCG otherwise (method.md#linear-solver;
// benchmarks/solvers/ on the dam break); in 3-D direct fill-in explodes (CHOLMOD
// 2.8 s a solve on the 3-D hydrostatic tank, warm-started PCG 0.1 s).
std::unique_ptr<LinearSolver> make_linear_solver(const LinearSolverOptions& options, int unknowns, int dim);
// The kind of solver make_linear_solver would choose, without making it.
LinearSolverKind linear_solver_kind(const LinearSolverOptions& options, int unknowns, int dim);

}  // namespace iqmpm
