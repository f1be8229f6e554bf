// PCG with hypre's BoomerAMG (linear_solver/boomeramg.h, docs/method.md#linear-solver) on
// Q1-P0 pressure systems: the solution of a dense solve with and without the checkerboard
// flip, a bound on the iterations (a broken hierarchy or an unsymmetric cycle would exceed
// it), iterations that do not depend on the thread count, rows that nothing constrains; and
// in a 3-D run, the simulation's signs reach the solver and the results are IC(0)'s.
#include <Eigen/Dense>
#include <omp.h>

#include <vector>

#include <gtest/gtest.h>

#include "linear_solver/linear_solver.h"
#include "pressure/pressure_system.h"
#include "simulation/simulation.h"
#include "support/scenes.h"

namespace iqmpm {
namespace {

// The Q1-P0 pressure system dt D M^-1 D^T on n^dim unit cells: one pressure per cell (in
// grid order), velocities at the corners, slip walls on every side but the top (the corner
// velocity component normal to a wall is held), a free surface on top. Its lowest modes are
// checkerboards under a smooth envelope, as in the solver's 3-D systems.
struct Q1P0System {
  SparseMatrix matrix;
  std::vector<signed char> checkerboard;  // (-1)^(i+j[+k]) of each cell
};

Q1P0System q1p0_system(int n, int dim) {
  const int corners_per_axis = n + 1;
  int corner_count = 1, cell_count = 1;
  for (int a = 0; a < dim; ++a) corner_count *= corners_per_axis, cell_count *= n;
  // Velocity unknown (corner, axis), or -1 where a wall holds it.
  std::vector<int> dof(corner_count * dim, -1);
  int velocities = 0;
  for (int c = 0; c < corner_count; ++c)
    for (int a = 0; a < dim; ++a) {
      int stride = 1;
      for (int b = 0; b < a; ++b) stride *= corners_per_axis;
      const int coordinate = (c / stride) % corners_per_axis;
      const bool top = a == 1 && coordinate == n;
      if ((coordinate == 0 || coordinate == n) && !top) continue;
      dof[c * dim + a] = velocities++;
    }
  Q1P0System system;
  std::vector<Eigen::Triplet<Real>> rows;
  const Real weight = 1.0 / (dim == 2 ? 2 : 4);  // the integral of dN/dx_a over a unit cell
  for (int cell = 0; cell < cell_count; ++cell) {
    std::vector<int> index(dim);
    int parity = 0;
    for (int a = 0, rest = cell; a < dim; ++a, rest /= n) parity += index[a] = rest % n;
    system.checkerboard.push_back(parity % 2 ? -1 : 1);
    for (int corner = 0; corner < (1 << dim); ++corner) {
      int c = 0;
      for (int a = dim - 1; a >= 0; --a) c = c * corners_per_axis + index[a] + ((corner >> a) & 1);
      for (int a = 0; a < dim; ++a)
        if (dof[c * dim + a] >= 0) rows.emplace_back(cell, dof[c * dim + a], ((corner >> a) & 1 ? weight : -weight));
    }
  }
  Eigen::VectorXd inverse_mass(velocities);
  for (int k = 0; k < velocities; ++k) inverse_mass[k] = 1 / (1 + 0.3 * std::sin(0.7 * k));  // uneven masses
  PressureSystem pressure;
  pressure.reset(inverse_mass);
  pressure.add_block("p_f", cell_count, rows);
  pressure.assemble(0.01);
  system.matrix = pressure.matrix();
  return system;
}

struct Solved {
  Eigen::VectorXd x;
  LinearSolveStats stats;
};

Solved solve_with_boomeramg(const SparseMatrix& A, const Eigen::VectorXd& b, CheckerboardFlip flip,
                            const std::vector<signed char>& signs, int dim, Real tolerance = 1e-12) {
  LinearSolverOptions options;
  options.method = LinearSolverMethod::pcg;
  options.preconditioner = Preconditioner::boomeramg;
  options.checkerboard_flip = flip;
  options.tolerance = tolerance;
  auto solver = make_linear_solver(options, int(A.rows()), dim);
  EXPECT_EQ(solver->wants_checkerboard_signs(), flip == CheckerboardFlip::on || (flip == CheckerboardFlip::automatic && dim == 3));
  if (solver->wants_checkerboard_signs()) solver->suggest_checkerboard_signs(signs);
  Solved solved;
  solved.x = Eigen::VectorXd::Zero(A.rows());
  solved.stats = solver->solve(A, b, solved.x);
  return solved;
}

Eigen::VectorXd smooth_and_rough_rhs(int n) {
  Eigen::VectorXd b(n);
  for (int i = 0; i < n; ++i) b[i] = 1 + std::sin(0.37 * i) + 0.5 * ((i * 7919) % 13 - 6) / 6.0;
  return b;
}

// Measured to 1e-12 from zero (IC(0): 42 in 2-D, 28 in 3-D): without / with the flip 12 / 22
// iterations in 2-D and 48 / 29 in 3-D, the pattern of the solver's own systems
// (benchmarks/solvers/README.md) that solver.amg_checkerboard_flip = auto follows. The
// bounds leave about 25 % for another hypre version; a V-cycle that is not a symmetric
// positive definite operator, or a hierarchy that misses the smooth modes, needs far more.
TEST(BoomerAmgTest, MatchesADenseSolveWithAndWithoutTheFlip) {
  for (const int dim : {2, 3}) {
    const Q1P0System system = q1p0_system(dim == 2 ? 24 : 9, dim);
    const SparseMatrix& A = system.matrix;
    const Eigen::VectorXd b = smooth_and_rough_rhs(int(A.rows()));
    const Eigen::VectorXd dense = Eigen::MatrixXd(A).llt().solve(b);
    std::vector<int> iterations;
    for (const auto flip : {CheckerboardFlip::off, CheckerboardFlip::on}) {
      SCOPED_TRACE(::testing::Message() << dim << "-D, flip " << (flip == CheckerboardFlip::on));
      const Solved solved = solve_with_boomeramg(A, b, flip, system.checkerboard, dim);
      ASSERT_TRUE(solved.stats.converged);
      EXPECT_LT((solved.x - dense).norm(), 1e-9 * dense.norm());
      iterations.push_back(solved.stats.iterations);
    }
    const std::vector<int> bound = dim == 2 ? std::vector<int>{15, 28} : std::vector<int>{60, 36};
    EXPECT_LE(iterations[0], bound[0]) << dim << "-D without the flip";
    EXPECT_LE(iterations[1], bound[1]) << dim << "-D with the flip";
    if (dim == 3) {
      EXPECT_LT(iterations[1], iterations[0]) << "3-D: the flip should help";
    } else {
      EXPECT_LT(iterations[0], iterations[1]) << "2-D: the flip should not help";
    }
  }
}

// hypre here is built without OpenMP and runs its cycle on one thread; the products with A
// run on the OpenMP threads row by row in a fixed order. So the iterations and the
// solution are the same bits for 1 and 2 threads.
TEST(BoomerAmgTest, IterationsDoNotDependOnThreadCount) {
  const Q1P0System system = q1p0_system(22, 3);  // 10 648 unknowns, large enough to be threaded
  const Eigen::VectorXd b = smooth_and_rough_rhs(int(system.matrix.rows()));
  const int threads = omp_get_max_threads();
  std::vector<Solved> runs;
  for (const int n : {1, 2}) {
    omp_set_num_threads(n);
    runs.push_back(solve_with_boomeramg(system.matrix, b, CheckerboardFlip::automatic, system.checkerboard, 3, 1e-8));
    ASSERT_TRUE(runs.back().stats.converged);
  }
  omp_set_num_threads(threads);
  EXPECT_EQ(runs[0].stats.iterations, runs[1].stats.iterations);
  EXPECT_EQ(runs[0].x, runs[1].x);
}

// An unknown that nothing constrains this step has a zero row and column in the
// semi-definite A (stored zero diagonal, or no entry at all); BoomerAMG's copy gets a unit
// diagonal there, and PCG solves the consistent system (b = 0 on those rows) like a dense
// solve of the rest, leaving those unknowns at zero.
TEST(BoomerAmgTest, LeavesUnconstrainedRowsAlone) {
  const Q1P0System system = q1p0_system(8, 2);
  const int n = int(system.matrix.rows());
  const std::vector<int> vacant{5, 30};
  Eigen::MatrixXd dense = Eigen::MatrixXd(system.matrix);
  for (int v : vacant) dense.row(v).setZero(), dense.col(v).setZero();
  SparseMatrix A = dense.sparseView();
  A.coeffRef(vacant[0], vacant[0]) = 0;  // a stored zero; vacant[1] has no entry at all
  Eigen::VectorXd b = smooth_and_rough_rhs(n);
  for (int v : vacant) b[v] = 0;
  for (int v : vacant) dense(v, v) = 1;  // the dense reference solves the rest, 0 there
  const Eigen::VectorXd expected = dense.llt().solve(b);
  for (const auto flip : {CheckerboardFlip::off, CheckerboardFlip::on}) {
    const Solved solved = solve_with_boomeramg(A, b, flip, system.checkerboard, 2);
    ASSERT_TRUE(solved.stats.converged);
    EXPECT_LT((solved.x - expected).norm(), 1e-9 * expected.norm());
    for (int v : vacant) EXPECT_EQ(solved.x[v], 0);
  }
}

// The 3-D floating cube (dx 0.05, 4 080 unknowns) for 12 steps, to a tolerance of 1e-10:
// the cube's height is the same with IC(0) and with BoomerAMG, with the flip (auto in 3-D,
// signs from the simulation's grid) and without; measured 1.6e-8 and 2.3e-9 m apart (2e-9
// at a tolerance of 1e-12: round-off carried over the steps). The flip must change the
// iterations: had the signs not reached the solver, it would have built the same hierarchy
// of A (measured 285 against 553, IC(0) 355).
TEST(BoomerAmgRunTest, FloatingCubeMatchesIncompleteCholesky) {
  const Json doc = testing::benchmark_document("floating_block_3d/floating_block_3d.json", {"solver.tolerance=1e-10", "dx=0.05"});
  struct Outcome {
    Real height = 0;
    int iterations = 0;
    std::string method;
  };
  auto run = [&](Preconditioner preconditioner, CheckerboardFlip flip) {
    SceneSpec scene = read_scene(doc);
    scene.solver.preconditioner = preconditioner;
    scene.solver.checkerboard_flip = flip;
    Simulation<3> sim(scene);
    Outcome outcome;
    for (int s = 0; s < 12; ++s) {
      sim.step(2e-3);
      outcome.iterations += sim.last_step().linear.iterations;
      outcome.method = sim.last_step().linear.method;
    }
    for (const auto& x : sim.solid().position) outcome.height += x[sim.up_axis()] / sim.solid().size();
    return outcome;
  };
  const Outcome ic0 = run(Preconditioner::ic0, CheckerboardFlip::automatic);
  const Outcome flipped = run(Preconditioner::boomeramg, CheckerboardFlip::automatic);
  const Outcome plain = run(Preconditioner::boomeramg, CheckerboardFlip::off);
  EXPECT_EQ(flipped.method, "pcg-boomeramg-flip");
  EXPECT_EQ(plain.method, "pcg-boomeramg");
  EXPECT_NEAR(flipped.height, ic0.height, 1e-7);
  EXPECT_NEAR(plain.height, ic0.height, 1e-7);
  EXPECT_NE(flipped.iterations, plain.iterations);
  std::printf("iterations over 12 steps: ic0 %d, boomeramg with the flip %d, without %d\n", ic0.iterations, flipped.iterations,
              plain.iterations);
}

}  // namespace
}  // namespace iqmpm
