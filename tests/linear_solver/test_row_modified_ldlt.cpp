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

}  // namespace
}  // namespace iqmpm
