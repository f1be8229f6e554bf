#include "linear_solver/linear_solver.h"

#include <Eigen/CholmodSupport>
#include <algorithm>
#include <cmath>
#include <vector>

#include "core/errors.h"

namespace iqmpm {
namespace {

using Sparse = Eigen::SparseMatrix<Real>;

// Modified incomplete Cholesky MIC(0) on the pattern of the lower triangle of A: fill that
// falls outside the pattern is dropped and omega times it is moved to the diagonal, which
// keeps row sums for grid Laplacians (Bridson's fluid-simulation notes, ch. 4).
class Mic0Preconditioner {
 public:
  void compute(const Sparse& A, Real omega) {
    // Rebuilt from triplets so that every column is sorted with its diagonal first (a
    // sparse product does not promise sorted inner indices).
    std::vector<Eigen::Triplet<Real>> entries;
    entries.reserve(A.nonZeros() / 2 + A.cols());
    for (int k = 0; k < A.outerSize(); ++k)
      for (Sparse::InnerIterator it(A, k); it; ++it)
        if (it.row() >= it.col()) entries.emplace_back(int(it.row()), int(it.col()), it.value());
    lower_.resize(A.rows(), A.cols());
    lower_.setFromTriplets(entries.begin(), entries.end());
    lower_.makeCompressed();
    const int n = int(lower_.cols());
    const int* outer = lower_.outerIndexPtr();
    const int* inner = lower_.innerIndexPtr();
    Real* value = lower_.valuePtr();
    std::vector<Real> original_diagonal(n);
    for (int k = 0; k < n; ++k) original_diagonal[k] = value[outer[k]];
    // position of (i, j) in column j, or -1
    auto find = [&](int i, int j) {
      const int* first = inner + outer[j];
      const int* last = inner + outer[j + 1];
      const int* it = std::lower_bound(first, last, i);
      return (it != last && *it == i) ? int(it - inner) : -1;
    };
    for (int k = 0; k < n; ++k) {
      const int diag = outer[k];  // the first entry of column k is the diagonal (sorted, lower)
      Real pivot = value[diag];
      // Guard against breakdown (the Q1-P0 stencil is not an M-matrix, so MIC(0) can drive
      // a pivot towards zero): fall back to the original diagonal, as in Bridson's notes.
      // CG stays correct; only the preconditioner gets weaker.
      if (!(pivot > 0.25 * original_diagonal[k])) pivot = original_diagonal[k];
      pivot = std::sqrt(pivot);
      value[diag] = pivot;
      for (int e = diag + 1; e < outer[k + 1]; ++e) value[e] /= pivot;
      for (int e = diag + 1; e < outer[k + 1]; ++e) {
        const int j = inner[e];
        const Real ljk = value[e];
        for (int f = e; f < outer[k + 1]; ++f) {
          const int i = inner[f];
          const Real update = value[f] * ljk;
          const int pos = find(i, j);
          if (pos >= 0) {
            value[pos] -= update;
          } else if (omega != 0) {
            value[outer[i]] -= omega * update;
            value[outer[j]] -= omega * update;
          }
        }
      }
    }
  }

  // z = (L L^T)^-1 r
  void apply(const Eigen::VectorXd& r, Eigen::VectorXd& z) const {
    z = r;
    const int n = int(lower_.cols());
    const int* outer = lower_.outerIndexPtr();
    const int* inner = lower_.innerIndexPtr();
    const Real* value = lower_.valuePtr();
    for (int k = 0; k < n; ++k) {
      z[k] /= value[outer[k]];
      const Real zk = z[k];
      for (int e = outer[k] + 1; e < outer[k + 1]; ++e) z[inner[e]] -= value[e] * zk;
    }
    for (int k = n - 1; k >= 0; --k) {
      Real sum = z[k];
      for (int e = outer[k] + 1; e < outer[k + 1]; ++e) sum -= value[e] * z[inner[e]];
      z[k] = sum / value[outer[k]];
    }
  }

 private:
  Sparse lower_;
};

class PcgSolver final : public LinearSolver {
 public:
  explicit PcgSolver(const LinearSolverOptions& options) : options_(options) {}

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
    Mic0Preconditioner mic;
    if (jacobi)
      inverse_diagonal = A.diagonal().cwiseInverse();
    else
      mic.compute(A, options_.mic_relaxation);
    auto precondition = [&](const Eigen::VectorXd& r, Eigen::VectorXd& z) {
      if (jacobi)
        z = inverse_diagonal.cwiseProduct(r);
      else
        mic.apply(r, z);
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

class CholmodSolver final : public LinearSolver {
 public:
  LinearSolveStats solve(const Sparse& A, const Eigen::VectorXd& b, Eigen::VectorXd& x) override {
    LinearSolveStats stats;
    stats.method = "cholmod";
    Eigen::CholmodDecomposition<Sparse, Eigen::Lower> factor;  // CHOLMOD picks simplicial or supernodal
    factor.compute(A);
    if (factor.info() != Eigen::Success) {
      stats.converged = false;
      stats.relative_residual = 1;
      return stats;
    }
    x = factor.solve(b);
    const Real b_norm = b.norm();
    stats.relative_residual = b_norm > 0 ? (b - A * x).norm() / b_norm : 0;
    stats.converged = std::isfinite(stats.relative_residual);
    return stats;
  }
};

}  // namespace

std::unique_ptr<LinearSolver> make_linear_solver(const LinearSolverOptions& options, int unknowns) {
  if (options.method == "cholmod" ||
      (options.method == "auto" && unknowns <= options.cholmod_max_unknowns))
    return std::make_unique<CholmodSolver>();
  return std::make_unique<PcgSolver>(options);
}

}  // namespace iqmpm
