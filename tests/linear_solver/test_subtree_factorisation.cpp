// The simplicial LDL^T by subtrees (linear_solver/subtree_factorisation.h) against
// cholmod_factorize on a system with the shape of the 2-D pressure solve's: a 9-point
// stencil on a grid in its nested dissection order, whose top separator's rows come after
// the two bins and take every bin's updates.
#include <Eigen/CholmodSupport>
#include <Eigen/SparseCore>

#include <algorithm>
#include <cmath>
#include <numeric>
#include <random>
#include <vector>

#include <cholmod.h>
#include <omp.h>
#include <gtest/gtest.h>

#include "grid/nested_dissection.h"
#include "linear_solver/subtree_factorisation.h"

namespace iqmpm {
namespace {

using SparseMatrix = Eigen::SparseMatrix<Real>;

// A random symmetric 9-point stencil on an n x n grid, diagonally dominant; quasi_definite
// makes the rows of the grid's middle column negative definite (a quasi-definite system,
// as the bordered one of coupling.solid_response = stiffness: LDL^T without pivoting).
SparseMatrix stencil(int n, unsigned seed, bool quasi_definite) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<Real> uniform(0.5, 1.5);
  auto sign = [&](int x) { return quasi_definite && x == n / 2 ? -1.0 : 1.0; };
  std::vector<Eigen::Triplet<Real>> entries;
  for (int y = 0; y < n; ++y)
    for (int x = 0; x < n; ++x) {
      const int i = x + n * y;
      for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx) {
          const int xj = x + dx, yj = y + dy, j = xj + n * yj;
          if (xj < 0 || yj < 0 || xj >= n || yj >= n || j <= i) continue;
          const Real value = sign(x) == sign(xj) ? -uniform(rng) * sign(x) : 0.1 * uniform(rng);
          entries.emplace_back(i, j, value), entries.emplace_back(j, i, value);
        }
      entries.emplace_back(i, i, 13 * sign(x));
    }
  SparseMatrix A(n * n, n * n);
  A.setFromTriplets(entries.begin(), entries.end());
  return A;
}

// The cells of an n x n grid in its nested dissection order (the stencil's unknowns).
std::vector<int> grid_order(int n) {
  const IVec<2> extent(n, n);
  const std::vector<int> rank = nested_dissection_rank<2>(GridLayout<2>(IVec<2>::Zero(), extent), extent);
  std::vector<int> order(n * n);
  for (int cell = 0; cell < n * n; ++cell) order[rank[cell]] = cell;
  return order;
}

struct Cholmod {
  cholmod_common common[2];
  Cholmod() {
    for (cholmod_common& c : common) {
      cholmod_start(&c);
      c.nmethods = 1;
      c.method[0].ordering = CHOLMOD_GIVEN;
      c.supernodal = CHOLMOD_SIMPLICIAL;
      c.final_ll = false;
      c.print = 0;
    }
  }
  ~Cholmod() {
    for (cholmod_common& c : common) cholmod_finish(&c);
  }
};

// cholmod_factorize's factor of `view` in `order` and S = triu(P A P') as it builds it.
struct ReferenceFactor {
  cholmod_common* common;
  cholmod_factor* factor = nullptr;
  cholmod_sparse* lower = nullptr;
  cholmod_sparse* S = nullptr;
  ReferenceFactor(cholmod_sparse& view, std::vector<int> order, cholmod_common* c) : common(c) {
    factor = cholmod_analyze_p(&view, order.data(), nullptr, 0, common);
    if (!factor || !cholmod_factorize(&view, factor, common)) return;
    lower = cholmod_ptranspose(&view, 2, static_cast<int*>(factor->Perm), nullptr, 0, common);
    S = cholmod_ptranspose(lower, 2, nullptr, nullptr, 0, common);
  }
  ~ReferenceFactor() {
    cholmod_free_sparse(&lower, common);
    cholmod_free_sparse(&S, common);
    cholmod_free_factor(&factor, common);
  }
  ReferenceFactor(const ReferenceFactor&) = delete;
  ReferenceFactor& operator=(const ReferenceFactor&) = delete;
};

// factorise_by_subtrees on one and on two threads: the same bits on both, the pattern of
// cholmod_factorize's factor `reference`, its values to round-off of each column's size,
// and `negative_pivots` negative entries of D.
void expect_cholmods_factor_on_one_and_two_threads(cholmod_sparse& view, std::vector<int> order, cholmod_sparse* S,
                                                   const cholmod_factor* reference, const SubtreeSchedule& schedule,
                                                   Cholmod& cholmod, int negative_pivots) {
  cholmod_common* common = &cholmod.common[0];
  const int n = int(reference->n);
  const int* Rp = static_cast<const int*>(reference->p);
  const int* Rnz = static_cast<const int*>(reference->nz);
  const int* Ri = static_cast<const int*>(reference->i);
  const double* Rx = static_cast<const double*>(reference->x);
  std::vector<double> values[2];
  for (int threads : {1, 2}) {
    SCOPED_TRACE(threads);
    cholmod_factor* L = cholmod_analyze_p(&view, order.data(), nullptr, 0, common);
    ASSERT_NE(L, nullptr);
    ASSERT_TRUE(factorise_by_subtrees(S, L, schedule, threads, &cholmod.common[0], &cholmod.common[1]));
    const int* Lp = static_cast<const int*>(L->p);
    const int* Lnz = static_cast<const int*>(L->nz);
    const int* Li = static_cast<const int*>(L->i);
    const double* Lx = static_cast<const double*>(L->x);
    double largest_difference = 0;
    int negative = 0;
    for (int j = 0; j < n; ++j) {
      ASSERT_EQ(Lnz[j], Rnz[j]) << "column " << j;
      double size = 0;
      for (int q = 0; q < Rnz[j]; ++q) size = std::max(size, std::abs(Rx[Rp[j] + q]));
      for (int q = 0; q < Lnz[j]; ++q) {
        ASSERT_EQ(Li[Lp[j] + q], Ri[Rp[j] + q]) << "column " << j;
        largest_difference = std::max(largest_difference, std::abs(Lx[Lp[j] + q] - Rx[Rp[j] + q]) / size);
        values[threads - 1].push_back(Lx[Lp[j] + q]);
      }
      negative += Lx[Lp[j]] < 0;
    }
    EXPECT_LT(largest_difference, 1e-13);
    EXPECT_EQ(negative, negative_pivots);
    cholmod_free_factor(&L, common);
  }
  EXPECT_TRUE(values[0] == values[1]);
}

TEST(SubtreeFactorisationTest, SameFactorAsCholmodToRoundOffAndTheSameBitsOnOneAndTwoThreads) {
  const int n = 72;  // 5 184 unknowns
  const std::vector<int> order = grid_order(n);
  for (const bool quasi_definite : {false, true}) {
    SCOPED_TRACE(quasi_definite ? "quasi-definite" : "positive definite");
    const SparseMatrix A = stencil(n, 5, quasi_definite);
    Cholmod cholmod;
    cholmod_sparse view = Eigen::viewAsCholmod(A.selfadjointView<Eigen::Upper>());
    const ReferenceFactor reference(view, order, &cholmod.common[0]);
    ASSERT_NE(reference.S, nullptr);
    ASSERT_EQ(reference.factor->minor, reference.factor->n);
    const SubtreeSchedule schedule = plan_subtree_schedule(reference.S, reference.factor, &cholmod.common[0]);
    ASSERT_TRUE(schedule.split());
    ASSERT_FALSE(schedule.after.empty());

    expect_cholmods_factor_on_one_and_two_threads(view, order, reference.S, reference.factor, schedule, cholmod,
                                                  quasi_definite ? n : 0);
  }
}

// The factor's inverse permutation (old -> new), as the solver keeps it.
std::vector<int> inverse_permutation(const cholmod_factor* factor) {
  const int* perm = static_cast<const int*>(factor->Perm);
  std::vector<int> inverse(factor->n);
  for (int k = 0; k < int(factor->n); ++k) inverse[perm[k]] = k;
  return inverse;
}

// permuted_upper_triangle of M in `reference`'s order.
cholmod_sparse* permuted_upper_triangle_of(const SparseMatrix& M, const ReferenceFactor& reference, cholmod_common* common) {
  const std::vector<int> inverse = inverse_permutation(reference.factor);
  return permuted_upper_triangle(int(M.rows()), M.outerIndexPtr(), M.innerIndexPtr(), M.valuePtr(),
                                 static_cast<const int*>(reference.factor->Perm), inverse.data(), common);
}

// S holds CHOLMOD's arrays of `expected`, entry for entry and to the bit.
void expect_the_same_sparse(const cholmod_sparse* S, const cholmod_sparse* expected) {
  EXPECT_EQ(S->stype, expected->stype);
  EXPECT_TRUE(S->sorted && S->packed);
  const int columns = int(expected->ncol);
  const int* Sp = static_cast<const int*>(S->p);
  const int* Ep = static_cast<const int*>(expected->p);
  ASSERT_TRUE(std::equal(Sp, Sp + columns + 1, Ep));
  EXPECT_TRUE(std::equal(static_cast<const int*>(S->i), static_cast<const int*>(S->i) + Sp[columns],
                         static_cast<const int*>(expected->i)));
  EXPECT_TRUE(std::equal(static_cast<const double*>(S->x), static_cast<const double*>(S->x) + Sp[columns],
                         static_cast<const double*>(expected->x)));
}

// permuted_upper_triangle builds S = triu(P A P') with the arrays of cholmod_factorize's two
// permuting transposes, to the bit, on one and two threads: on the stencil with its lower
// triangle nudged by a relative 1e-12 (A's values need not be symmetric to the bit, and S
// takes the upper ones), in the nested dissection order and in a random one; and on
// patterns made unsymmetric by an explicit zero (below).
TEST(SubtreeFactorisationTest, PermutedUpperTriangleIsCholmodsTransposesToTheBit) {
  const int n = 40;
  SparseMatrix nudged = stencil(n, 7, false);
  for (int c = 0; c < nudged.outerSize(); ++c)
    for (SparseMatrix::InnerIterator it(nudged, c); it; ++it)
      if (it.row() > c) it.valueRef() *= 1 + 1e-12;
  const SparseMatrix& A = nudged;
  const int threads_before = omp_get_max_threads();
  std::vector<int> shuffled(n * n);
  std::iota(shuffled.begin(), shuffled.end(), 0);
  std::shuffle(shuffled.begin(), shuffled.end(), std::mt19937(3));
  for (const std::vector<int>& order : {grid_order(n), shuffled}) {
    Cholmod cholmod;
    cholmod_common* common = &cholmod.common[0];
    cholmod_sparse view = Eigen::viewAsCholmod(A.selfadjointView<Eigen::Upper>());
    const ReferenceFactor reference(view, order, common);
    ASSERT_NE(reference.S, nullptr);
    for (int threads : {1, 2}) {
      SCOPED_TRACE(threads);
      omp_set_num_threads(threads);
      cholmod_sparse* S = permuted_upper_triangle_of(A, reference, common);
      ASSERT_NE(S, nullptr);
      expect_the_same_sparse(S, reference.S);
      cholmod_free_sparse(&S, common);
    }
    omp_set_num_threads(threads_before);
  }
  // A pattern made unsymmetric by an explicit zero: one stored in the lower triangle only is
  // not read (as by CHOLMOD: the same arrays); one in the upper triangle only is gathered
  // where it falls into its own column of S, and where it would have to be reached through
  // its missing mirror the function says so (null) instead of leaving it out. Both orders of
  // the grid, forwards and backwards, so that both happen.
  int refused = 0;
  std::vector<int> backwards = grid_order(n);
  std::reverse(backwards.begin(), backwards.end());
  for (const std::vector<int>& order : {grid_order(n), backwards})
    for (const bool upper_only : {false, true}) {
      SCOPED_TRACE(upper_only ? "an upper entry without its mirror" : "a lower entry without its mirror");
      SparseMatrix B = A;
      const int far = n * n - 1;  // (0, far) and (far, 0) are not in the stencil
      if (upper_only)
        B.insert(0, far) = 0.0;
      else
        B.insert(far, 0) = 0.0;
      B.makeCompressed();
      const SparseMatrix& C = B;
      Cholmod cholmod;
      cholmod_common* common = &cholmod.common[0];
      cholmod_sparse view = Eigen::viewAsCholmod(C.selfadjointView<Eigen::Upper>());
      const ReferenceFactor reference(view, order, common);
      ASSERT_NE(reference.S, nullptr);
      const std::vector<int> inverse = inverse_permutation(reference.factor);
      cholmod_sparse* S = permuted_upper_triangle_of(C, reference, common);
      if (upper_only && inverse[0] > inverse[far]) {  // S's column of the new row 0 needs the mirror
        EXPECT_EQ(S, nullptr);
        ++refused;
        continue;
      }
      ASSERT_NE(S, nullptr);
      expect_the_same_sparse(S, reference.S);
      cholmod_free_sparse(&S, common);
    }
  EXPECT_EQ(refused, 1);
}

// solve_by_subtrees against cholmod_solve on the same factor: the same solution to
// round-off, the same bits on one and two threads; also after CHOLMOD's row updates (a row
// of a bin and a row after the bins deleted, as the active set releases rows), whose
// patterns stay within the analysed one. A schedule that does not fit the factor (a row
// after the bins said to be the other bin's) is refused with x untouched, and the next solve
// with the right schedule in the same workspace is right again.
TEST(SubtreeFactorisationTest, TheSolveBySubtreesIsCholmodsToRoundOffAndTheSameBitsOnOneAndTwoThreads) {
  const int n = 72;
  std::vector<int> order = grid_order(n);
  for (const bool quasi_definite : {false, true}) {
    SCOPED_TRACE(quasi_definite ? "quasi-definite" : "positive definite");
    const SparseMatrix A = stencil(n, 11, quasi_definite);
    Cholmod cholmod;
    cholmod_common* common = &cholmod.common[0];
    cholmod_sparse view = Eigen::viewAsCholmod(A.selfadjointView<Eigen::Upper>());
    const ReferenceFactor reference(view, order, common);
    ASSERT_NE(reference.S, nullptr);
    const SubtreeSchedule schedule = plan_subtree_schedule(reference.S, reference.factor, common);
    ASSERT_TRUE(schedule.split());
    cholmod_factor* L = cholmod_analyze_p(&view, order.data(), nullptr, 0, common);
    ASSERT_NE(L, nullptr);
    ASSERT_TRUE(factorise_by_subtrees(reference.S, L, schedule, 2, &cholmod.common[0], &cholmod.common[1]));

    std::mt19937 rng(3);
    std::uniform_real_distribution<Real> uniform(-1, 1);
    Eigen::VectorXd b(n * n);
    for (Real& v : b) v = uniform(rng);
    SubtreeSolveWorkspace workspace;
    auto expect_cholmod_solve = [&](const char* what) {
      SCOPED_TRACE(what);
      cholmod_dense rhs = Eigen::viewAsCholmod(b);
      cholmod_dense* expected = cholmod_solve(CHOLMOD_A, L, &rhs, common);
      ASSERT_NE(expected, nullptr);
      const Eigen::Map<const Eigen::VectorXd> x_cholmod(static_cast<const Real*>(expected->x), n * n);
      Eigen::VectorXd x[2];
      for (int threads : {1, 2}) {
        x[threads - 1].resize(n * n);
        ASSERT_TRUE(solve_by_subtrees(L, schedule, threads, b.data(), x[threads - 1].data(), workspace));
      }
      EXPECT_TRUE(x[0] == x[1]);
      EXPECT_LT((x[0] - x_cholmod).lpNorm<Eigen::Infinity>(), 1e-13 * x_cholmod.lpNorm<Eigen::Infinity>());
      cholmod_free_dense(&expected, common);
    };
    expect_cholmod_solve("as factorised");
    Eigen::VectorXd x(n * n);
    ASSERT_TRUE(solve_by_subtrees(L, schedule, 2, b.data(), x.data(), workspace));
    EXPECT_LT((A * x - b).norm(), 1e-12 * b.norm());

    // A schedule that says a row after the bins, which bin 0's columns reach, is bin 1's.
    const int* Lp = static_cast<const int*>(L->p);
    const int* Lnz = static_cast<const int*>(L->nz);
    const int* Li = static_cast<const int*>(L->i);
    int reached_after = -1;
    const auto [first, end] = schedule.bins[0].front();
    for (int j = first; j < end && reached_after < 0; ++j)
      for (int q = 1; q < Lnz[j]; ++q)
        if (schedule.group[Li[Lp[j] + q]] == SubtreeSchedule::kAfterBins) reached_after = Li[Lp[j] + q];
    ASSERT_GE(reached_after, 0);
    SubtreeSchedule wrong = schedule;
    wrong.group[reached_after] = 1;
    Eigen::VectorXd untouched = Eigen::VectorXd::Constant(n * n, 7.0);
    EXPECT_FALSE(solve_by_subtrees(L, wrong, 2, b.data(), untouched.data(), workspace));
    EXPECT_TRUE((untouched.array() == 7.0).all());
    expect_cholmod_solve("after a refused schedule");

    // Rows released: one in bin 0 and one after the bins (L's indices).
    ASSERT_TRUE(cholmod_rowdel(std::size_t(first + (end - first) / 2), nullptr, L, common));
    ASSERT_TRUE(cholmod_rowdel(std::size_t(schedule.after.back().first), nullptr, L, common));
    expect_cholmod_solve("after row deletions");
    cholmod_free_factor(&L, common);
  }
}

// An L-shaped region (a 240 x 240 grid without its top-right 120 x 120 quadrant, 43 200
// unknowns as the dam break's at a/128), dissected as the solver dissects the water's
// cells: the top separator splits it into a 120 x 240 part and a 120 x 120 part, two thirds
// of the cells against one third, and every part below hangs from a chain of separator
// rows. The plan must reach below those chains to balance the bins (the first plan spent
// one of its 256 rounds on each row of a chain and left this system to one thread), and
// the factor must be the same as on one thread and as CHOLMOD's.
TEST(SubtreeFactorisationTest, AnUnevenTreeIsSplitBelowItsSeparatorChains) {
  const int n = 240;
  const SparseMatrix grid_matrix = stencil(n, 7, false);
  const GridLayout<2> layout(IVec<2>::Zero(), IVec<2>(n, n));
  std::vector<int> region;
  for (int cell = 0; cell < n * n; ++cell) {
    const IVec<2> at = layout.multi_index(cell);
    if (at.x() < n / 2 || at.y() < n / 2) region.push_back(cell);
  }
  const int m = int(region.size());
  std::vector<Eigen::Triplet<Real>> selection;
  for (int k = 0; k < m; ++k) selection.emplace_back(k, region[k], 1.0);
  SparseMatrix select(m, n * n);
  select.setFromTriplets(selection.begin(), selection.end());
  const SparseMatrix A = select * grid_matrix * select.transpose();
  std::vector<int> row_of_cell(n * n, -1);
  for (int k = 0; k < m; ++k) row_of_cell[region[k]] = k;
  std::vector<int> order;
  for (int cell : nested_dissection_of_cells(layout, region)) order.push_back(row_of_cell[cell]);

  Cholmod cholmod;
  cholmod_sparse view = Eigen::viewAsCholmod(A.selfadjointView<Eigen::Upper>());
  const ReferenceFactor reference(view, order, &cholmod.common[0]);
  ASSERT_NE(reference.S, nullptr);
  const SubtreeSchedule schedule = plan_subtree_schedule(reference.S, reference.factor, &cholmod.common[0]);
  ASSERT_TRUE(schedule.split());
  // The rows after the bins are one thread's: the heavier bin and they take at most 60 % of
  // the one-thread work (the old plan: all of it).
  const double one_thread = schedule.bin_work[0] + schedule.bin_work[1] + schedule.after_work;
  EXPECT_LT(std::max(schedule.bin_work[0], schedule.bin_work[1]) + schedule.after_work, 0.6 * one_thread);

  expect_cholmods_factor_on_one_and_two_threads(view, order, reference.S, reference.factor, schedule, cholmod, 0);
}

// Two one-node bins below one row: [[2, 0, 1], [0, 2, 1], [1, 1, d]]. The row above the bins
// takes 1/2 from each bin, so its pivot is d - 1 exactly: d = 1 is singular and must be
// reported at that row (L->minor = 2), as cholmod_factorize reports it; d = 2 gives D = 1.
TEST(SubtreeFactorisationTest, APivotOfTheRowsAboveTheBinsIsExactAndAZeroOneIsReported) {
  for (const double d : {1.0, 2.0}) {
    SCOPED_TRACE(d);
    std::vector<Eigen::Triplet<Real>> entries = {{0, 0, 2}, {1, 1, 2}, {0, 2, 1}, {2, 0, 1}, {1, 2, 1}, {2, 1, 1}, {2, 2, d}};
    SparseMatrix A(3, 3);
    A.setFromTriplets(entries.begin(), entries.end());
    Cholmod cholmod;
    cholmod_common* common = &cholmod.common[0];
    cholmod_sparse view = Eigen::viewAsCholmod(static_cast<const SparseMatrix&>(A).selfadjointView<Eigen::Upper>());
    const std::vector<int> natural = {0, 1, 2};
    for (int threads : {1, 2}) {
      cholmod_factor* L = cholmod_analyze_p(&view, const_cast<int*>(natural.data()), nullptr, 0, common);
      ASSERT_NE(L, nullptr);
      cholmod_sparse* lower = cholmod_ptranspose(&view, 2, static_cast<int*>(L->Perm), nullptr, 0, common);
      cholmod_sparse* S = cholmod_ptranspose(lower, 2, nullptr, nullptr, 0, common);
      const SubtreeSchedule schedule = plan_subtree_schedule(S, L, common);
      ASSERT_TRUE(schedule.split());
      ASSERT_EQ(schedule.after.size(), 1u);
      EXPECT_EQ(factorise_by_subtrees(S, L, schedule, threads, &cholmod.common[0], &cholmod.common[1]), d != 1);
      const int* Lp = static_cast<const int*>(L->p);
      const double* Lx = static_cast<const double*>(L->x);
      if (d == 1) {
        EXPECT_EQ(L->minor, 2u);
      } else {
        EXPECT_EQ(L->minor, 3u);
        EXPECT_EQ(Lx[Lp[2]], 1.0);
      }
      cholmod_free_sparse(&lower, common);
      cholmod_free_sparse(&S, common);
      cholmod_free_factor(&L, common);
    }
  }
}

}  // namespace
}  // namespace iqmpm
