// The LDL^T solver's row modification (direct_solvers.cpp) against fresh factorisations, on
// systems assembled by PressureSystem as the unilateral interface's active-set rounds
// change them; its two kinds of factor, simplicial and supernodal, against Eigen's LDL^T.
#include <Eigen/Dense>
#include <Eigen/SparseCholesky>

#include <cstdint>
#include <random>
#include <vector>

#include <gtest/gtest.h>
#include <omp.h>

#include "linear_solver/linear_solver.h"
#include "pressure/pressure_system.h"

namespace iqmpm {
namespace {

// The active set's rounds (coupling.interface = unilateral) change a few rows of the
// system: released rows become unit rows and columns, restored ones get their entries
// back. The LDL^T solver then modifies its factorisation row by row (linear_solver.cpp)
// instead of factorising again. Its solution must equal a fresh factorisation's, on the
// positive definite system and on the quasi-definite bordered one, over several rounds.
TEST(RowModifiedLdltTest, EqualsAFreshFactorisationOverActiveSetRounds) {
  for (const bool bordered : {false, true}) {
    SCOPED_TRACE(bordered ? "bordered (quasi-definite)" : "positive definite");
    std::mt19937 rng(11);
    std::uniform_real_distribution<Real> uniform(-1, 1);
    const int velocities = 120, rows = 50;
    Eigen::VectorXd inverse_mass(velocities), v_star(velocities);
    for (int k = 0; k < velocities; ++k) inverse_mass[k] = 1 / (1 + 0.5 * (1 + uniform(rng))), v_star[k] = uniform(rng);
    std::vector<Eigen::Triplet<Real>> entries;
    for (int r = 0; r < rows; ++r)
      for (int k = 0; k < velocities; ++k)
        if (uniform(rng) > 0.9) entries.emplace_back(r, k, uniform(rng));
    PressureSystem system;
    system.reset(inverse_mass);
    system.add_block("rows", rows, entries);
    if (bordered) {
      const std::vector<int> columns = {3, 4, 5, 40, 41, 77};
      const int nb = int(columns.size());
      const Eigen::MatrixXd R = Eigen::MatrixXd::NullaryExpr(nb, nb, [&] { return uniform(rng); });
      system.set_mass_block(columns, Eigen::MatrixXd(R * R.transpose() + 2 * Eigen::MatrixXd::Identity(nb, nb)).sparseView());
    }
    system.assemble(0.01);
    auto solver = make_linear_solver(LinearSolverOptions{LinearSolverMethod::ldlt}, system.size(), 2);
    std::vector<std::uint8_t> released(rows, 0);
    const std::vector<std::vector<int>> rounds = {{2, 9, 17, 30}, {9, 31, 44}, {2, 5, 6, 7, 31}, {}};
    for (std::size_t round = 0; round < rounds.size(); ++round) {
      std::vector<int> newly_released, restored;
      std::vector<std::uint8_t> next(rows, 0);
      for (int r : rounds[round]) next[r] = 1;
      for (int r = 0; r < rows; ++r) {
        if (next[r] && !released[r]) newly_released.push_back(r);
        if (!next[r] && released[r]) restored.push_back(r);
      }
      released = next;
      system.release(released);
      if (round > 0) solver->expect_row_changes(newly_released, restored);
      const SparseMatrix& K = system.matrix();
      const Eigen::VectorXd b = system.rhs(v_star);
      Eigen::VectorXd x = Eigen::VectorXd::Zero(system.size()), fresh = x;
      const auto stats = solver->solve(K, b, x);
      const auto fresh_stats = make_linear_solver(LinearSolverOptions{LinearSolverMethod::ldlt}, system.size(), 2)->solve(K, b, fresh);
      ASSERT_TRUE(stats.converged && fresh_stats.converged);
      // Round 0 factorises; the later ones modify exactly the changed rows.
      EXPECT_EQ(stats.modified_rows, round == 0 ? 0 : int(newly_released.size() + restored.size()));
      EXPECT_LT(stats.relative_residual, 1e-12);
      EXPECT_LT((x - fresh).norm(), 1e-10 * fresh.norm());
      const Eigen::VectorXd dense = Eigen::MatrixXd(K).ldlt().solve(b);  // independent of CHOLMOD
      EXPECT_LT((x - dense).norm(), 1e-9 * dense.norm());
      for (int r = 0; r < rows; ++r)
        if (released[r]) {
          EXPECT_EQ(x[r], 0);
        }
    }
  }
}

// A row that repeats a combination of two others (interface rows beside a clamped body's
// divergence rows: method.md#pressure-system) makes A singular, but the system stays
// consistent. Eliminated after the rows it repeats, its pivot of D is round-off (about
// 1e-17 of its column), not an exact zero; dividing by it once left a dam_break_obstacle
// step 45 % off its constraints. The solver must notice, factorise with the relative
// diagonal shift and refine: the constraints met to round-off, and among the solutions
// near the one the shift selects in the limit, the least in sum_i A_ii x_i^2 (so that
// multipliers in the null space, which forces are measured from, are not arbitrary). Near:
// the round-off of b along the null space (1e-16) over the shift (1e-12) stays in x.
TEST(RowModifiedLdltTest, ARepeatedRowLeavesARoundOffPivotThatIsShiftedAndRefined) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<Real> uniform(-1, 1);
  const int velocities = 60, rows = 21, repeated = 20;
  Eigen::VectorXd inverse_mass(velocities), v_star(velocities);
  for (int k = 0; k < velocities; ++k) inverse_mass[k] = 1 / (1 + 0.5 * (1 + uniform(rng))), v_star[k] = uniform(rng);
  Eigen::MatrixXd B = Eigen::MatrixXd::Zero(rows, velocities);
  for (int r = 0; r < repeated; ++r)
    for (int k = 0; k < velocities; ++k)
      if (uniform(rng) > 0.6) B(r, k) = uniform(rng);
  B.row(repeated) = 0.1 * B.row(3) + 0.3 * B.row(7);  // not exactly representable: round-off
  std::vector<Eigen::Triplet<Real>> entries;
  for (int r = 0; r < rows; ++r)
    for (int k = 0; k < velocities; ++k)
      if (B(r, k) != 0) entries.emplace_back(r, k, B(r, k));
  PressureSystem system;
  system.reset(inverse_mass);
  system.add_block("rows", rows, entries);
  system.assemble(0.01);
  const SparseMatrix& A = system.matrix();
  const Eigen::VectorXd b = system.rhs(v_star);
  // The repeated row after the two it repeats, and before every row coupled to it.
  std::vector<int> order = {3, 7, repeated};
  for (int r = 0; r < repeated; ++r)
    if (r != 3 && r != 7) order.push_back(r);
  auto solver = make_linear_solver(LinearSolverOptions{LinearSolverMethod::ldlt}, system.size(), 2);
  solver->suggest_order(order);
  Eigen::VectorXd x = Eigen::VectorXd::Zero(system.size());
  const auto stats = solver->solve(A, b, x);
  ASSERT_TRUE(stats.converged);
  EXPECT_TRUE(stats.shifted);
  EXPECT_LT(stats.relative_residual, 1e-12);
  EXPECT_LT((b - A * x).norm(), 1e-12 * b.norm());
  // The least solution in the diagonal's norm: S = diag(A)^-1/2, x = S (S A S)^+ S b.
  const Eigen::MatrixXd dense(A);
  const Eigen::VectorXd S = dense.diagonal().cwiseSqrt().cwiseInverse();
  const Eigen::MatrixXd scaled = S.asDiagonal() * dense * S.asDiagonal();
  const Eigen::VectorXd least = S.asDiagonal() * scaled.completeOrthogonalDecomposition().solve(Eigen::VectorXd(S.asDiagonal() * b));
  EXPECT_LT((x - least).norm(), 1e-3 * least.norm());
}

// The pressure stencil's reach on an n^dim grid: each cell coupled to every cell of its 3^dim
// block (Q1-P0's D M^-1 D^T), with random coupling strengths (no constant-coefficient
// structure) and strictly dominant diagonals, so SPD.
SparseMatrix block_stencil(int n, int dim, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<Real> uniform(0.5, 1.5);
  const int size = dim == 2 ? n * n : n * n * n;
  std::vector<Eigen::Triplet<Real>> entries;
  for (int i = 0; i < size; ++i) {
    int c[3] = {i % n, (i / n) % n, dim == 3 ? i / (n * n) : 0};
    for (int dz = dim == 3 ? -1 : 0; dz <= (dim == 3 ? 1 : 0); ++dz)
      for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx) {
          const int x = c[0] + dx, y = c[1] + dy, z = c[2] + dz;
          if (x < 0 || y < 0 || z < 0 || x >= n || y >= n || z >= n) continue;
          const int j = x + n * (y + n * z);
          if (j > i) {
            const Real value = -uniform(rng);
            entries.emplace_back(i, j, value);
            entries.emplace_back(j, i, value);
          }
        }
    entries.emplace_back(i, i, dim == 2 ? 13 : 40);  // above 8 or 26 neighbours x 1.5
  }
  SparseMatrix A(size, size);
  A.setFromTriplets(entries.begin(), entries.end());
  return A;
}

// CHOLMOD picks a supernodal LL^T only where the factor is dense enough (flops / nnz(L) at
// least the measured crossover, direct_solvers.cpp): the 2-D stencil stays simplicial LDL^T,
// the 3-D one goes supernodal unless LinearSolverOptions::simplicial keeps it simplicial.
// Every kind, and CHOLMOD's LL^T (solver.method = cholmod), must solve the system as
// Eigen's own LDL^T does.
TEST(LdltFactorKindTest, SimplicialIn2DSupernodalIn3DEachMatchingEigen) {
  struct Case {
    int n, dim;
    bool simplicial_asked, supernodal_expected;
  };
  for (const Case& c : {Case{64, 2, false, false}, Case{16, 3, false, true}, Case{16, 3, true, false}}) {
    SCOPED_TRACE(::testing::Message() << c.dim << "-D, simplicial asked " << c.simplicial_asked);
    const SparseMatrix A = block_stencil(c.n, c.dim, 11);
    std::mt19937 rng(4);
    std::uniform_real_distribution<Real> uniform(-1, 1);
    const Eigen::VectorXd b = Eigen::VectorXd::NullaryExpr(A.rows(), [&] { return uniform(rng); });
    const Eigen::VectorXd reference = Eigen::SimplicialLDLT<SparseMatrix>(A).solve(b);
    LinearSolverOptions options;
    options.method = LinearSolverMethod::ldlt;
    options.simplicial = c.simplicial_asked;
    auto solver = make_linear_solver(options, int(A.rows()), c.dim);
    Eigen::VectorXd x = Eigen::VectorXd::Zero(A.rows());
    const LinearSolveStats stats = solver->solve(A, b, x);
    ASSERT_TRUE(stats.converged);
    EXPECT_EQ(stats.supernodal, c.supernodal_expected);
    EXPECT_LT(stats.relative_residual, 1e-12);
    EXPECT_LT((x - reference).norm(), 1e-11 * reference.norm());
    // solver.method = cholmod (LL^T) chooses by the same switch.
    options.method = LinearSolverMethod::cholmod;
    auto llt = make_linear_solver(options, int(A.rows()), c.dim);
    Eigen::VectorXd y = Eigen::VectorXd::Zero(A.rows());
    ASSERT_TRUE(llt->solve(A, b, y).converged);
    EXPECT_LT((y - reference).norm(), 1e-11 * reference.norm());
  }
}

// On two threads the simplicial LDL^T computes independent subtrees of the elimination tree
// at once (linear_solver/subtree_factorisation.h): the same factor bit for bit, so the same
// solution as on one thread, and Eigen's.
TEST(LdltFactorKindTest, TwoThreadsFactoriseBySubtreesToTheSameBits) {
  const SparseMatrix A = block_stencil(100, 2, 5);  // 10 000 unknowns: above the two-thread minimum
  std::mt19937 rng(8);
  std::uniform_real_distribution<Real> uniform(-1, 1);
  const Eigen::VectorXd b = Eigen::VectorXd::NullaryExpr(A.rows(), [&] { return uniform(rng); });
  const int threads = omp_get_max_threads();
  Eigen::VectorXd x[2];
  for (int t : {1, 2}) {
    omp_set_num_threads(t);
    auto solver = make_linear_solver(LinearSolverOptions{LinearSolverMethod::ldlt}, int(A.rows()), 2);
    x[t - 1] = Eigen::VectorXd::Zero(A.rows());
    const LinearSolveStats stats = solver->solve(A, b, x[t - 1]);
    ASSERT_TRUE(stats.converged);
    EXPECT_EQ(stats.factor_threads, t);
    EXPECT_LT(stats.relative_residual, 1e-12);
    // The second solve of the same pattern reuses the analysis and its schedule.
    Eigen::VectorXd again = Eigen::VectorXd::Zero(A.rows());
    EXPECT_EQ(solver->solve(A, b, again).factor_threads, t);
    EXPECT_EQ((again - x[t - 1]).cwiseAbs().maxCoeff(), 0);
  }
  omp_set_num_threads(threads);
  EXPECT_EQ((x[1] - x[0]).cwiseAbs().maxCoeff(), 0);
  const Eigen::VectorXd reference = Eigen::SimplicialLDLT<SparseMatrix>(A).solve(b);
  EXPECT_LT((x[1] - reference).norm(), 1e-11 * reference.norm());
}

}  // namespace
}  // namespace iqmpm
