#include "linear_solver/linear_solver.h"

#include <Eigen/IterativeLinearSolvers>
#include <Eigen/OrderingMethods>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

#include "core/errors.h"
#include "linear_solver/direct_solvers.h"
#include "linear_solver/incomplete_cholesky.h"
#include "linear_solver/pcg.h"

namespace iqmpm {
namespace {

using Sparse = Eigen::SparseMatrix<Real>;

class PcgSolver final : public LinearSolver {
 public:
  // dim: BoomerAMG's parameters and its checkerboard flip by dimension.
  PcgSolver(const LinearSolverOptions& options, int dim)
      : options_(options),
        flip_(options.checkerboard_flip == CheckerboardFlip::on || (options.checkerboard_flip == CheckerboardFlip::automatic && dim == 3)) {
    if (options_.preconditioner == Preconditioner::boomeramg) amg_ = std::make_unique<BoomerAmgPreconditioner>(options_.amg, dim);
  }
  bool solves_quasi_definite() const override { return false; }
  std::string name() const override {
    switch (options_.preconditioner) {
      case Preconditioner::ic0: return "pcg-ic0";
      case Preconditioner::ichol: return "pcg-ichol";
      case Preconditioner::boomeramg: return flip_ ? "pcg-boomeramg-flip" : "pcg-boomeramg";
      case Preconditioner::jacobi: break;
    }
    return "pcg-jacobi";
  }
  LinearSolverKind kind() const override { return LinearSolverKind::pcg; }
  bool wants_checkerboard_signs() const override { return amg_ && flip_; }
  void suggest_checkerboard_signs(std::vector<signed char> signs) override { signs_ = std::move(signs); }

  LinearSolveStats solve(const Sparse& A, const Eigen::VectorXd& b, Eigen::VectorXd& x) override {
    prepared_ = b.norm() > 0;
    if (prepared_) prepare(A);
    return iterate(A, b, x);
  }
  // The preconditioner of the last solve serves the same matrix again.
  LinearSolveStats solve_again(const Sparse& A, const Eigen::VectorXd& b, Eigen::VectorXd& x) override {
    return prepared_ ? iterate(A, b, x) : solve(A, b, x);
  }

 private:
  void prepare(const Sparse& A) {
    switch (options_.preconditioner) {
      case Preconditioner::jacobi: inverse_diagonal_ = A.diagonal().cwiseInverse(); break;
      case Preconditioner::ic0:
        if (!ic0_.compute(A)) throw NumericalFailure("IC(0) factorisation failed even with a diagonal shift of 1 x diag(A)");
        break;
      case Preconditioner::ichol:
        ichol_.setInitialShift(1e-3);
        ichol_.compute(A);
        if (ichol_.info() != Eigen::Success) throw NumericalFailure("incomplete Cholesky factorisation failed");
        break;
      case Preconditioner::boomeramg:
        // Signs that do not fit this system (none handed over, or for other unknowns):
        // the hierarchy of A itself.
        amg_->compute(A, signs_.size() == std::size_t(A.rows()) ? signs_ : std::vector<signed char>{});
        break;
    }
  }

  LinearSolveStats iterate(const Sparse& A, const Eigen::VectorXd& b, Eigen::VectorXd& x) {
    LinearSolveStats stats;
    stats.method = name();
    if (x.size() != b.size()) x = Eigen::VectorXd::Zero(b.size());
    // A is symmetric: A^T p is the row-major product, which Eigen runs on the OpenMP
    // threads (dynamic schedule).
    const PcgResult result = preconditioned_cg(
        [&](const Eigen::VectorXd& p) -> Eigen::VectorXd { return A.transpose() * p; },
        [&](const Eigen::VectorXd& r, Eigen::VectorXd& z) {
          switch (options_.preconditioner) {
            case Preconditioner::jacobi: z = inverse_diagonal_.cwiseProduct(r); break;
            case Preconditioner::ic0: ic0_.solve(r, z); break;
            case Preconditioner::ichol: z = ichol_.solve(r); break;
            case Preconditioner::boomeramg: amg_->apply(r, z); break;
          }
        },
        b, x, options_.tolerance, options_.max_iterations);
    stats.iterations = result.iterations;
    stats.initial_relative_residual = result.initial_relative_residual;
    stats.relative_residual = result.relative_residual;
    stats.converged = result.converged;
    return stats;
  }

  LinearSolverOptions options_;
  bool flip_ = false;
  // The preconditioner of the last solve (prepared_: computed; a zero right-hand side needs none).
  bool prepared_ = false;
  Eigen::VectorXd inverse_diagonal_;
  IncompleteCholesky0 ic0_;
  // Eigen's incomplete Cholesky with threshold fill (Lin & More), AMD ordering and an
  // automatic diagonal shift on breakdown.
  Eigen::IncompleteCholesky<Real, Eigen::Lower, Eigen::AMDOrdering<int>> ichol_;
  std::unique_ptr<BoomerAmgPreconditioner> amg_;  // made with the solver (MPI and hypre start with the first)
  std::vector<signed char> signs_;
};

}  // namespace

LinearSolverKind linear_solver_kind(const LinearSolverOptions& options, int unknowns, int dim) {
  switch (options.method) {
    case LinearSolverMethod::cholmod: return LinearSolverKind::cholmod;
    case LinearSolverMethod::ldlt: return LinearSolverKind::ldlt;
    case LinearSolverMethod::pcg: return LinearSolverKind::pcg;
    case LinearSolverMethod::automatic: break;
  }
  return dim == 2 && unknowns <= options.direct_max_unknowns ? LinearSolverKind::ldlt : LinearSolverKind::pcg;
}

std::unique_ptr<LinearSolver> make_linear_solver(const LinearSolverOptions& options, int unknowns, int dim) {
  switch (linear_solver_kind(options, unknowns, dim)) {
    case LinearSolverKind::cholmod: return make_cholmod_llt_solver();
    case LinearSolverKind::ldlt: return make_ldlt_solver(options.simplicial);
    case LinearSolverKind::pcg: break;
  }
  return std::make_unique<PcgSolver>(options, dim);
}

}  // namespace iqmpm
