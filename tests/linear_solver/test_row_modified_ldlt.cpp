// The LDL^T solver's row modification (linear_solver.cpp) against fresh factorisations, on
// systems assembled by PressureSystem as the unilateral interface's active-set rounds
// change them.
#include <Eigen/Dense>

#include <cstdint>
#include <random>
#include <vector>

#include <gtest/gtest.h>

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

}  // namespace
}  // namespace iqmpm
