// The pressure solvers (linear_solver.cpp) against a dense solve, IC(0)'s defining
// property, its shifted retry, and iterations that do not depend on the thread count.
#include <Eigen/Dense>
#include <omp.h>

#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "linear_solver/incomplete_cholesky.h"
#include "linear_solver/linear_solver.h"
#include "pressure/pressure_system.h"

namespace iqmpm {
namespace {

// A pressure-like system dt D M^-1 D^T from PressureSystem: random sparse constraint rows
// (each with a few entries, full row rank) and lumped masses.
SparseMatrix random_pressure_system(int rows, int velocities, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<Real> uniform(-1, 1);
  Eigen::VectorXd inverse_mass(velocities);
  for (int k = 0; k < velocities; ++k) inverse_mass[k] = 1 / (1 + 0.5 * (1 + uniform(rng)));
  std::vector<Eigen::Triplet<Real>> entries;
  for (int r = 0; r < rows; ++r) {
    entries.emplace_back(r, r, 2 + uniform(rng));  // full row rank
    for (int k = 0; k < velocities; ++k)
      if (uniform(rng) > 0.92) entries.emplace_back(r, k, uniform(rng));
  }
  PressureSystem system;
  system.reset(inverse_mass);
  system.add_block("rows", rows, entries);
  system.assemble(0.01);
  return system.matrix();
}

// The 5-point (2-D) or 7-point (3-D) Laplacian on an n^dim grid with Dirichlet sides, in
// grid order: the pressure stencil's structure, SPD.
SparseMatrix laplacian(int n, int dim) {
  const int size = dim == 2 ? n * n : n * n * n;
  std::vector<Eigen::Triplet<Real>> entries;
  for (int i = 0; i < size; ++i) {
    entries.emplace_back(i, i, 2.0 * dim);
    int stride = 1;
    for (int a = 0; a < dim; ++a, stride *= n) {
      const int coordinate = (i / stride) % n;
      if (coordinate > 0) entries.emplace_back(i, i - stride, -1);
      if (coordinate < n - 1) entries.emplace_back(i, i + stride, -1);
    }
  }
  SparseMatrix A(size, size);
  A.setFromTriplets(entries.begin(), entries.end());
  return A;
}

TEST(PressureSolversTest, EachMethodMatchesADenseSolve) {
  const SparseMatrix A = random_pressure_system(80, 200, 5);
  std::mt19937 rng(3);
  std::uniform_real_distribution<Real> uniform(-1, 1);
  const Eigen::VectorXd b = Eigen::VectorXd::NullaryExpr(A.rows(), [&] { return uniform(rng); });
  const Eigen::VectorXd dense = Eigen::MatrixXd(A).llt().solve(b);
  for (const auto method : {LinearSolverMethod::pcg, LinearSolverMethod::ldlt, LinearSolverMethod::cholmod})
    for (const auto preconditioner : {Preconditioner::ic0, Preconditioner::ichol, Preconditioner::jacobi, Preconditioner::boomeramg}) {
      if (method != LinearSolverMethod::pcg && preconditioner != Preconditioner::ic0) continue;
      LinearSolverOptions options;
      options.method = method;
      options.preconditioner = preconditioner;
      options.tolerance = 1e-12;
      auto solver = make_linear_solver(options, int(A.rows()), 3);
      SCOPED_TRACE(solver->name());
      Eigen::VectorXd x = Eigen::VectorXd::Zero(A.rows());
      const LinearSolveStats stats = solver->solve(A, b, x);
      ASSERT_TRUE(stats.converged);
      EXPECT_LT((x - dense).norm(), 1e-9 * dense.norm());
    }
}

// IC(0) keeps A's pattern and matches A on it: (L L^T)_ij = A_ij wherever A_ij != 0. On a
// tridiagonal matrix there is no fill at all, so IC(0) is the exact Cholesky factor and
// PCG converges in one iteration.
TEST(IncompleteCholesky0Test, MatchesTheMatrixOnItsPattern) {
  for (const int dim : {1, 2, 3}) {
    SCOPED_TRACE(dim);
    const SparseMatrix A = dim == 1 ? laplacian(40, 2).topLeftCorner(40, 40) : laplacian(dim == 2 ? 12 : 6, dim);
    IncompleteCholesky0 ic0;
    ASSERT_TRUE(ic0.compute(A));
    EXPECT_EQ(ic0.shift(), 0);  // an M-matrix: no breakdown
    const SparseMatrix L = ic0.factor();
    EXPECT_EQ(L.nonZeros(), (A.nonZeros() + A.rows()) / 2);
    const Eigen::MatrixXd product = Eigen::MatrixXd(L) * Eigen::MatrixXd(L).transpose();
    for (int c = 0; c < A.outerSize(); ++c)
      for (SparseMatrix::InnerIterator it(A, c); it; ++it) EXPECT_NEAR(product(it.row(), it.col()), it.value(), 1e-12);
    if (dim == 1) {
      LinearSolverOptions options;
      options.method = LinearSolverMethod::pcg;
      options.tolerance = 1e-12;
      Eigen::VectorXd x = Eigen::VectorXd::Zero(A.rows());
      const auto stats = make_linear_solver(options, int(A.rows()), 2)->solve(A, Eigen::VectorXd::Ones(A.rows()), x);
      EXPECT_EQ(stats.iterations, 1);
    }
  }
}

// PCG with IC(0) (the default preconditioner) from zero to a relative residual of 1e-12;
// whether it converged.
bool solve_by_pcg_ic0(const SparseMatrix& A, const Eigen::VectorXd& b, Eigen::VectorXd& x) {
  LinearSolverOptions options;
  options.method = LinearSolverMethod::pcg;
  options.tolerance = 1e-12;
  x = Eigen::VectorXd::Zero(b.size());
  return make_linear_solver(options, int(b.size()), 2)->solve(A, b, x).converged;
}

// A matrix on which IC(0) meets a negative pivot (SPD, but far from an M-matrix): the
// factorisation is retried on A + alpha diag(A) and PCG still converges to the solution.
TEST(IncompleteCholesky0Test, ShiftsWhenAPivotBreaksDown) {
  // SPD (smallest eigenvalue about 0.9), with the pattern of a 2 x 2 grid; IC(0) drops the
  // fill between unknowns 0 and 3 and the last pivot turns negative.
  Eigen::MatrixXd dense(4, 4);
  dense << 15, -7, -6, 0, -7, 19, 0, 14, -6, 0, 19, -7, 0, 14, -7, 15;
  ASSERT_GT(Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(dense).eigenvalues().minCoeff(), 0);
  const SparseMatrix A = dense.sparseView();
  IncompleteCholesky0 ic0;
  ASSERT_TRUE(ic0.compute(A));
  EXPECT_GT(ic0.shift(), 0);
  Eigen::VectorXd x;
  const Eigen::VectorXd b(Eigen::Vector4d(1, -2, 0.5, 3));
  ASSERT_TRUE(solve_by_pcg_ic0(A, b, x));
  EXPECT_LT((x - dense.llt().solve(b)).norm(), 1e-10);
}

// A semi-definite system with empty rows (an unknown nothing constrains this step; the
// dam break with an obstacle met one at a/32): one row with a stored zero diagonal, one with
// no entry at all. IC(0) takes pivot 1 there, without a shift, and PCG solves the
// consistent system (b = 0 on the empty rows) as a dense solve of the rest does.
TEST(IncompleteCholesky0Test, AnEmptyRowGetsAUnitPivot) {
  Eigen::MatrixXd dense = Eigen::MatrixXd::Zero(5, 5);
  dense.block(0, 0, 3, 3) << 4, -1, -1, -1, 4, -1, -1, -1, 4;
  dense(4, 4) = 3;
  dense(0, 4) = dense(4, 0) = -1;
  SparseMatrix A = dense.sparseView();
  A.coeffRef(3, 3) = 0;  // row 3: an explicitly stored zero (B below: row 1 has no entry)
  IncompleteCholesky0 ic0;
  ASSERT_TRUE(ic0.compute(A));
  EXPECT_EQ(ic0.shift(), 0);
  const Eigen::VectorXd b = (Eigen::VectorXd(5) << 1, -2, 0.5, 0, 3).finished();
  Eigen::VectorXd x;
  ASSERT_TRUE(solve_by_pcg_ic0(A, b, x));
  const std::vector<int> live{0, 1, 2, 4};
  Eigen::MatrixXd reduced(4, 4);
  Eigen::VectorXd rhs(4);
  for (int i = 0; i < 4; ++i) {
    rhs[i] = b[live[i]];
    for (int j = 0; j < 4; ++j) reduced(i, j) = dense(live[i], live[j]);
  }
  const Eigen::VectorXd expected = reduced.llt().solve(rhs);
  for (int i = 0; i < 4; ++i) EXPECT_NEAR(x[live[i]], expected[i], 1e-10);
  EXPECT_EQ(x[3], 0);

  Eigen::MatrixXd hole = dense;
  hole.row(1).setZero();
  hole.col(1).setZero();
  const SparseMatrix B = hole.sparseView();  // no entry in row and column 1
  ASSERT_EQ(B.col(1).nonZeros(), 0);
  ASSERT_TRUE(ic0.compute(B));
  EXPECT_EQ(ic0.shift(), 0);
}

// The products run on the OpenMP threads row by row, each row summed in the same order:
// the iterations, and the solution, do not depend on the thread count.
TEST(PressureSolversTest, IterationsDoNotDependOnThreadCount) {
  const SparseMatrix A = laplacian(24, 3);  // 13 824 unknowns, large enough to be threaded
  const Eigen::VectorXd b = Eigen::VectorXd::LinSpaced(A.rows(), -1, 1);
  LinearSolverOptions options;
  options.method = LinearSolverMethod::pcg;
  std::vector<Eigen::VectorXd> solutions;
  std::vector<int> iterations;
  const int threads = omp_get_max_threads();
  for (const int n : {1, 2}) {
    omp_set_num_threads(n);
    Eigen::VectorXd x = Eigen::VectorXd::Zero(A.rows());
    const auto stats = make_linear_solver(options, int(A.rows()), 3)->solve(A, b, x);
    ASSERT_TRUE(stats.converged);
    iterations.push_back(stats.iterations);
    solutions.push_back(x);
  }
  omp_set_num_threads(threads);
  EXPECT_EQ(iterations[0], iterations[1]);
  EXPECT_EQ(solutions[0], solutions[1]);
}

// solve_again: a second right-hand side for the matrix of the last solve (the position
// correction's, method.md#position-correction) against a dense solve, from every method;
// LDL^T answers it from its kept factor.
TEST(PressureSolversTest, SolveAgainMatchesADenseSolve) {
  const SparseMatrix A = random_pressure_system(80, 200, 7);
  std::mt19937 rng(11);
  std::uniform_real_distribution<Real> uniform(-1, 1);
  const Eigen::VectorXd first = Eigen::VectorXd::NullaryExpr(A.rows(), [&] { return uniform(rng); });
  const Eigen::VectorXd second = Eigen::VectorXd::NullaryExpr(A.rows(), [&] { return uniform(rng); });
  const Eigen::VectorXd dense = Eigen::MatrixXd(A).llt().solve(second);
  for (const auto method : {LinearSolverMethod::pcg, LinearSolverMethod::ldlt, LinearSolverMethod::cholmod}) {
    LinearSolverOptions options;
    options.method = method;
    options.tolerance = 1e-12;
    auto solver = make_linear_solver(options, int(A.rows()), 2);
    SCOPED_TRACE(solver->name());
    Eigen::VectorXd x = Eigen::VectorXd::Zero(A.rows());
    ASSERT_TRUE(solver->solve(A, first, x).converged);
    Eigen::VectorXd y = Eigen::VectorXd::Zero(A.rows());
    const LinearSolveStats stats = solver->solve_again(A, second, y);
    ASSERT_TRUE(stats.converged);
    EXPECT_LT((y - dense).norm(), 1e-9 * dense.norm());
    EXPECT_LT(stats.relative_residual, 1e-10);
  }
}

}  // namespace
}  // namespace iqmpm
