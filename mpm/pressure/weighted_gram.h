// A = s D W D^T for a sparse D (rows: constraints, columns: velocity entries) and a
// diagonal W, row by row (Gustavson's algorithm): row i of A gathers D(i,k) W(k) D(j,k)
// over the entries k of row i of D and the rows j of column k. Rows are independent, so
// they run on the OpenMP threads (dynamic schedule: a busy core takes fewer rows) and the
// result does not depend on the thread count. Replaces two format conversions and Eigen's
// general sparse product per step (issue 21: 15 % of a 2-D run).
//
// A is symmetric to the bit, pattern and values: row i's pass computes the entries j <= i
// only, the upper triangle of column i (the one CHOLMOD, the direct solver's gather of
// the permuted upper triangle and IC(0) read), and the strict lower triangle is its
// mirror. A(j,i), j <= i, is stored where some k of non-zero weight has D(i,k) != 0 and
// D(j,k) stored; products through a zero weight (a held velocity component) are left out,
// and a sum that cancels stays as a stored zero (in 2-D the centre rule's face neighbours),
// since IC(0) fills it. Why the upper triangle keeps each row's own rounding, and not a
// product symmetric in i and j: method.md#pressure-system.
#pragma once

#include <Eigen/SparseCore>
#include <algorithm>
#include <vector>

#include "core/types.h"

namespace iqmpm {

// Returned column-major with sorted indices (column i = row i).
inline Eigen::SparseMatrix<Real> weighted_gram(const Eigen::SparseMatrix<Real, Eigen::RowMajor, int>& D,
                                               const Eigen::VectorXd& weight, Real scale) {
  const int rows = int(D.rows());
  const Eigen::SparseMatrix<Real> by_column = D;  // D's columns: the rows touching each velocity entry
  // Rows in blocks of 256, each block's entries gathered in one buffer, then concatenated.
  // A thread fills its own buffers and hands them to the block once it is done: block
  // vectors side by side share cache lines, and appending to them from two threads made
  // the product five times slower on two threads than on one (issue 21 item 4).
  constexpr int kBlock = 256;
  const int blocks = (rows + kBlock - 1) / kBlock;
  std::vector<std::vector<int>> index(blocks);
  std::vector<std::vector<Real>> value(blocks);
  std::vector<int> count(rows + 1, 0);  // upper entries of row i at count[i + 1]
#pragma omp parallel
  {
    std::vector<Real> sum(rows, 0);
    std::vector<char> seen(rows, 0);
    std::vector<int> touched, block_index;
    std::vector<Real> block_value;
#pragma omp for schedule(dynamic, 1)
    for (int b = 0; b < blocks; ++b) {
      block_index.clear();
      block_value.clear();
      for (int i = b * kBlock; i < std::min(rows, (b + 1) * kBlock); ++i) {
        touched.clear();
        for (Eigen::SparseMatrix<Real, Eigen::RowMajor, int>::InnerIterator ik(D, i); ik; ++ik) {
          const int k = int(ik.col());
          const Real left = scale * ik.value() * weight[k];
          if (left == 0) continue;
          for (Eigen::SparseMatrix<Real>::InnerIterator jk(by_column, k); jk && jk.row() <= i; ++jk) {
            const int j = int(jk.row());
            if (!seen[j]) seen[j] = 1, touched.push_back(j);
            sum[j] += left * jk.value();
          }
        }
        std::sort(touched.begin(), touched.end());
        count[i + 1] = int(touched.size());
        for (int j : touched) {
          block_index.push_back(j);
          block_value.push_back(sum[j]);
          sum[j] = 0;
          seen[j] = 0;
        }
      }
      index[b].assign(block_index.begin(), block_index.end());
      value[b].assign(block_value.begin(), block_value.end());
    }
  }
  // Column i of `upper`: the entries of row i's pass (rows j <= i, sorted); A is `upper` with
  // its strict upper triangle mirrored (Eigen's conversion keeps the rows sorted).
  Eigen::SparseMatrix<Real> upper(rows, rows);
  for (int i = 0; i < rows; ++i) count[i + 1] += count[i];
  upper.resizeNonZeros(count[rows]);
  std::copy(count.begin(), count.end(), upper.outerIndexPtr());
  for (int b = 0; b < blocks; ++b) {
    const int first = count[std::min(rows, b * kBlock)];
    std::copy(index[b].begin(), index[b].end(), upper.innerIndexPtr() + first);
    std::copy(value[b].begin(), value[b].end(), upper.valuePtr() + first);
  }
  Eigen::SparseMatrix<Real> A = upper.selfadjointView<Eigen::Upper>();
  return A;
}

}  // namespace iqmpm
