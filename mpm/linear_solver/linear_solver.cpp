#include "linear_solver/linear_solver.h"

#include <Eigen/CholmodSupport>
#include <Eigen/IterativeLinearSolvers>
#include <Eigen/OrderingMethods>
#include <Eigen/SparseCholesky>
#include <algorithm>
#include <cmath>
#include <vector>

#include "core/errors.h"

namespace iqmpm {
namespace {

using Sparse = Eigen::SparseMatrix<Real>;

class PcgSolver final : public LinearSolver {
 public:
  explicit PcgSolver(const LinearSolverOptions& options) : options_(options) {}
  bool solves_quasi_definite() const override { return false; }
  std::string name() const override { return "pcg-" + options_.preconditioner; }

  LinearSolveStats solve(const Sparse& A, const Eigen::VectorXd& b, Eigen::VectorXd& x) override {
    LinearSolveStats stats;
    stats.method = "pcg-" + options_.preconditioner;
    const int n = int(b.size());
    if (x.size() != n || !options_.warm_start) x = Eigen::VectorXd::Zero(n);
    const Real b_norm = b.norm();
    if (b_norm == 0) {
      x.setZero();
      stats.converged = true;
      return stats;
    }
    const bool jacobi = options_.preconditioner == "jacobi";
    Eigen::VectorXd inverse_diagonal;
    // Eigen's incomplete Cholesky with threshold fill (Lin & More), AMD ordering and an
    // automatic diagonal shift on breakdown: the Q1-P0 stencil is not an M-matrix, and a
    // plain MIC(0) on it breaks down in 3-D.
    Eigen::IncompleteCholesky<Real, Eigen::Lower, Eigen::AMDOrdering<int>> ichol;
    if (jacobi) {
      inverse_diagonal = A.diagonal().cwiseInverse();
    } else {
      ichol.setInitialShift(1e-3);
      ichol.compute(A);
      if (ichol.info() != Eigen::Success) throw NumericalFailure("incomplete Cholesky factorisation failed");
    }
    auto precondition = [&](const Eigen::VectorXd& r, Eigen::VectorXd& z) {
      if (jacobi)
        z = inverse_diagonal.cwiseProduct(r);
      else
        z = ichol.solve(r);
    };

    Eigen::VectorXd r = b - A * x;
    Eigen::VectorXd z(n), p(n), q(n);
    precondition(r, z);
    p = z;
    Real rz = r.dot(z);
    Real residual = r.norm() / b_norm;
    int k = 0;
    while (residual > options_.tolerance && k < options_.max_iterations) {
      q.noalias() = A * p;
      const Real alpha = rz / p.dot(q);
      x += alpha * p;
      r -= alpha * q;
      residual = r.norm() / b_norm;
      ++k;
      if (residual <= options_.tolerance) break;
      precondition(r, z);
      const Real rz_next = r.dot(z);
      p = z + (rz_next / rz) * p;
      rz = rz_next;
    }
    stats.iterations = k;
    stats.relative_residual = residual;
    stats.converged = residual <= options_.tolerance;
    return stats;
  }

 private:
  LinearSolverOptions options_;
};

// A direct factorisation (Factor: an Eigen sparse Cholesky-type solver) with the residual
// of its solution reported like PCG's.
template <class Factor>
class DirectSolver final : public LinearSolver {
 public:
  explicit DirectSolver(std::string name) : name_(std::move(name)) {}
  bool solves_quasi_definite() const override { return name_ == "ldlt"; }
  std::string name() const override { return name_; }

  LinearSolveStats solve(const Sparse& A, const Eigen::VectorXd& b, Eigen::VectorXd& x) override {
    LinearSolveStats stats;
    stats.method = name_;
    // The symbolic analysis (fill-reducing ordering, elimination tree) depends on the
    // pattern only: kept while the pattern repeats (the active-set rounds of one step).
    const bool same_pattern = analysed_ && std::size_t(A.outerSize()) + 1 == pattern_outer_.size() &&
                              std::equal(pattern_outer_.begin(), pattern_outer_.end(), A.outerIndexPtr()) &&
                              A.nonZeros() == Eigen::Index(pattern_inner_.size()) &&
                              std::equal(pattern_inner_.begin(), pattern_inner_.end(), A.innerIndexPtr());
    if (!same_pattern) {
      configure(factor);
      factor.analyzePattern(A);
      pattern_outer_.assign(A.outerIndexPtr(), A.outerIndexPtr() + A.outerSize() + 1);
      pattern_inner_.assign(A.innerIndexPtr(), A.innerIndexPtr() + A.nonZeros());
      analysed_ = true;
    }
    factor.factorize(A);
    if (factor.info() != Eigen::Success) {
      analysed_ = false;  // the shifted retry below analyses afresh
      // A semi-definite system (method.md §5: an enclosed pocket of fluid, or interface rows
      // that coincide with divergence rows next to a clamped body) can meet an exact zero
      // pivot. Retry once with a diagonal shift of 1e-12 of the mean diagonal, which selects
      // one solution of a consistent system; the residual below is of the unshifted system.
      Sparse shifted = A;
      const Real shift = 1e-12 * A.diagonal().cwiseAbs().mean();
      for (int i = 0; i < shifted.rows(); ++i) shifted.coeffRef(i, i) += shift;
      factor.compute(shifted);
      stats.shifted = true;
    }
    if (factor.info() != Eigen::Success) {
      stats.relative_residual = 1;
      return stats;
    }
    x = factor.solve(b);
    const Real b_norm = b.norm();
    stats.relative_residual = b_norm > 0 ? (b - A * x).norm() / b_norm : 0;
    stats.converged = std::isfinite(stats.relative_residual);
    return stats;
  }

 private:
  template <class F>
  static void configure(F&) {}
  // CHOLMOD: simplicial LL^T with AMD ordering. On the 2-D dam break at dx = a/64 (8.5k
  // unknowns) the supernodal factorisation took 46 ms a solve against 21 ms.
  static void configure(Eigen::CholmodDecomposition<Sparse, Eigen::Lower>& factor) {
    factor.cholmod().nmethods = 1;
    factor.cholmod().method[0].ordering = CHOLMOD_AMD;
    factor.setMode(Eigen::CholmodSimplicialLLt);
  }

  std::string name_;
  Factor factor;
  bool analysed_ = false;
  std::vector<int> pattern_outer_, pattern_inner_;
};

}  // namespace

std::unique_ptr<LinearSolver> make_linear_solver(const LinearSolverOptions& options, int unknowns, int dim) {
  if (options.method == "cholmod")
    return std::make_unique<DirectSolver<Eigen::CholmodDecomposition<Sparse, Eigen::Lower>>>("cholmod");
  // Eigen's simplicial LDL^T with AMD ordering.
  if (options.method == "ldlt" || (options.method == "auto" && dim == 2 && unknowns <= options.direct_max_unknowns))
    return std::make_unique<DirectSolver<Eigen::SimplicialLDLT<Sparse, Eigen::Lower>>>("ldlt");
  return std::make_unique<PcgSolver>(options);
}

}  // namespace iqmpm
