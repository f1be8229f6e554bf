// Incomplete Cholesky without fill, IC(0), in the system's own order: L has the pattern of
// A's lower triangle, and L L^T matches A on that pattern. The pressure unknowns are
// numbered in grid order (dual cells, then the blocks after them), and in that order IC(0)
// needs about a third of the iterations of Eigen's threshold-fill factorisation with AMD
// order on the 3-D floating cube (method.md#linear-solver).
//
// The Q1-P0 pressure stencil is not an M-matrix, so a pivot can turn non-positive; the
// factorisation is then redone on A + alpha diag(A) with alpha = 1e-3, doubling (Manteuffel's
// shift), and shift() reports the alpha used. A row of A that is empty (zero diagonal, so
// zero throughout in a semi-definite A: an unknown that nothing constrains this step, as the
// direct solve's zero pivot) gets the pivot 1: the preconditioner leaves it alone.
#pragma once

#include <Eigen/SparseCore>
#include <cmath>
#include <vector>

#include "core/types.h"

namespace iqmpm {

class IncompleteCholesky0 {
 public:
  // A: symmetric, both triangles stored (column j holds row j). Returns false if no shift
  // up to alpha = 1 gave positive pivots.
  bool compute(const Eigen::SparseMatrix<Real>& A) {
    const int n = int(A.rows());
    // Row i of L's pattern: the entries of A's column i with row index <= i (sorted).
    start_.assign(n + 1, 0);
    column_.clear();
    value_.clear();
    std::vector<Real> diagonal(n, 0);
    for (int i = 0; i < n; ++i) {
      for (Eigen::SparseMatrix<Real>::InnerIterator it(A, i); it; ++it) {
        if (it.row() >= i) break;
        column_.push_back(int(it.row()));
        value_.push_back(it.value());
      }
      diagonal[i] = A.coeff(i, i);
      if (diagonal[i] == 0) diagonal[i] = 1;  // an empty row
      column_.push_back(i);
      value_.push_back(diagonal[i]);
      start_[i + 1] = int(column_.size());
    }
    original_ = value_;
    for (shift_ = 0; shift_ <= 1; shift_ = shift_ == 0 ? 1e-3 : 2 * shift_) {
      value_ = original_;
      if (shift_ > 0)
        for (int i = 0; i < n; ++i) value_[start_[i + 1] - 1] += shift_ * diagonal[i];
      if (factorise(n)) return true;
    }
    return false;
  }

  // z = (L L^T)^-1 r.
  void solve(const Eigen::VectorXd& r, Eigen::VectorXd& z) const {
    const int n = int(start_.size()) - 1;
    z = r;
    for (int i = 0; i < n; ++i) {  // L y = r
      Real s = z[i];
      const int last = start_[i + 1] - 1;
      for (int e = start_[i]; e < last; ++e) s -= value_[e] * z[column_[e]];
      z[i] = s / value_[last];
    }
    for (int i = n - 1; i >= 0; --i) {  // L^T z = y
      const int last = start_[i + 1] - 1;
      const Real zi = z[i] / value_[last];
      z[i] = zi;
      for (int e = start_[i]; e < last; ++e) z[column_[e]] -= value_[e] * zi;
    }
  }

  Real shift() const { return shift_; }

  // L as a sparse matrix (for tests).
  Eigen::SparseMatrix<Real> factor() const {
    const int n = int(start_.size()) - 1;
    std::vector<Eigen::Triplet<Real>> entries;
    for (int i = 0; i < n; ++i)
      for (int e = start_[i]; e < start_[i + 1]; ++e) entries.emplace_back(i, column_[e], value_[e]);
    Eigen::SparseMatrix<Real> L(n, n);
    L.setFromTriplets(entries.begin(), entries.end());
    return L;
  }

 private:
  std::vector<int> start_, column_;  // L row by row (CSR), the diagonal last in each row
  std::vector<Real> value_, original_;
  Real shift_ = 0;

  // Row by row: with row i scattered into `work` (zero outside its pattern, which drops
  // the fill), L_ik = (A_ik - sum_{j<k} L_kj L_ij) / L_kk for k < i in order, then
  // L_ii = sqrt(A_ii - sum_k L_ik^2).
  bool factorise(int n) {
    std::vector<Real> work(n, 0);
    for (int i = 0; i < n; ++i) {
      const int first = start_[i], last = start_[i + 1] - 1;
      for (int e = first; e <= last; ++e) work[column_[e]] = value_[e];
      Real diagonal = work[i];
      for (int e = first; e < last; ++e) {
        const int k = column_[e];
        Real s = work[k];
        const int k_last = start_[k + 1] - 1;
        for (int f = start_[k]; f < k_last; ++f) s -= value_[f] * work[column_[f]];
        s /= value_[k_last];
        work[k] = s;
        diagonal -= s * s;
      }
      if (!(diagonal > 0)) {
        for (int e = first; e <= last; ++e) work[column_[e]] = 0;
        return false;
      }
      for (int e = first; e < last; ++e) {
        value_[e] = work[column_[e]];
        work[column_[e]] = 0;
      }
      value_[last] = std::sqrt(diagonal);
      work[i] = 0;
    }
    return true;
  }
};

}  // namespace iqmpm
