// Warm starts of the pressure solve (pressure/warm_start.h, docs/method.md#warm-start):
// the Map to dense grid fields and back, the exactness of extrapolation and projection on
// sequences they must reproduce, and runs whose results do not depend on the warm start
// beyond the solver's tolerance.
#include <Eigen/SparseCholesky>
#include <cmath>
#include <functional>
#include <random>

#include "core/errors.h"
#include "pressure/learned_warm_start.h"
#include "pressure/warm_start.h"
#include "simulation/simulation.h"
#include "support/scenes.h"
#include "support/test_helpers.h"

namespace iqmpm {
namespace {

template <class D>
class WarmStartMapTest : public ::testing::Test {};
TYPED_TEST_SUITE(WarmStartMapTest, testing::Dimensions);

// A coupled scene after a few steps (2-D: the floating block with its wall rows; 3-D: the
// cube): every multiplier of the system is found again at its grid location, and nothing
// else is active on the grid.
TYPED_TEST(WarmStartMapTest, MapThenInvmapIsTheIdentityOnActiveCells) {
  constexpr int dim = TypeParam::value;
  const Json doc = dim == 2 ? testing::benchmark_document("floating_block/floating_block.json", {"solver.method=pcg"})
                            : testing::benchmark_document("floating_block_3d/floating_block_3d.json", {});
  Simulation<dim> sim(read_scene(doc));
  for (int s = 0; s < 3; ++s) sim.step(2e-3);
  const UnknownLocations& where = sim.unknown_locations();
  const Eigen::VectorXd& x = sim.pressure_solution();
  int unknowns = 0;
  for (int b = 0; b < block_count; ++b) unknowns += int(where.location[b].size());
  EXPECT_GT(where.location[ghost_block].size(), 0u);
  EXPECT_GT(where.location[pressure_block].size(), 0u);
  EXPECT_GT(where.location[interface_block].size(), 0u);
  EXPECT_EQ(where.location[wall_block].size() > 0, dim == 2);  // 3-D holds its walls on the corners
  const GridSolution grid = sim.pressure_fields();
  int active = 0;
  for (int b = 0; b < block_count; ++b)
    for (auto a : grid.active[b]) active += a;
  EXPECT_EQ(active, unknowns);
  Eigen::VectorXd back = Eigen::VectorXd::Constant(x.size(), 12345.0);
  map_from_grid(grid, where, back);
  EXPECT_EQ(unknowns, x.size());
  EXPECT_EQ((back - x).cwiseAbs().maxCoeff(), 0.0);
}

// Two blocks of unknowns on a 10-location grid; the second step loses one location and
// gains another.
struct TwoSteps {
  UnknownLocations before, after;
  TwoSteps() {
    for (UnknownLocations* w : {&before, &after}) {
      w->locations = {10, 10, 40, 10};
      w->offset = {-1, 0, -1, 4};
    }
    before.location[pressure_block] = {1, 2, 3, 4};
    before.location[interface_block] = {7, 8};
    after.location[pressure_block] = {2, 3, 4, 5};
    after.location[interface_block] = {7, 8};
  }
};

Eigen::VectorXd field_at(const UnknownLocations& where, const std::function<Real(int block, int location)>& f) {
  Eigen::VectorXd x(6);
  for (int b : {pressure_block, interface_block})
    for (std::size_t i = 0; i < where.location[b].size(); ++i) x[where.offset[b] + i] = f(b, where.location[b][i]);
  return x;
}

// A field linear in time, u(t) = a + c t, at unequal steps: extrapolation through the last
// two solutions is exact where both had the location; a new location takes 0 (none before).
TEST(WarmStartTest, ExtrapolationIsExactForAFieldLinearInTime) {
  const TwoSteps grid;
  auto u = [](Real t) { return [t](int b, int l) { return 1.0 + b + 0.5 * l + (3.0 - l) * t; }; };
  WarmStartSpec spec;
  spec.kind = WarmStartKind::extrapolate;
  WarmStart warm(spec, 2, {5, 2});
  warm.remember(grid.before, field_at(grid.before, u(0.10)), 0.10);
  warm.remember(grid.before, field_at(grid.before, u(0.13)), 0.13);
  const Eigen::SparseMatrix<Real> identity = Eigen::VectorXd::Ones(6).asDiagonal().toDenseMatrix().sparseView();
  Eigen::VectorXd guess;
  warm.guess(grid.after, identity, Eigen::VectorXd::Zero(6), 0.20, guess);
  const Eigen::VectorXd exact = field_at(grid.after, u(0.20));
  for (int i = 0; i < 6; ++i) {
    const bool new_location = i == 3;  // p_f at location 5
    EXPECT_NEAR(guess[i], new_location ? 0.0 : exact[i], 1e-12) << "unknown " << i;
  }
}

Eigen::SparseMatrix<Real> random_spd(int n, std::mt19937& rng) {
  std::uniform_real_distribution<Real> uniform(-1, 1);
  Eigen::MatrixXd M = Eigen::MatrixXd::NullaryExpr(n, n, [&] { return uniform(rng); });
  Eigen::MatrixXd A = M * M.transpose() + n * Eigen::MatrixXd::Identity(n, n);
  return A.sparseView();
}

// Fischer's projection: a solution in the span of the kept ones is found exactly, and for
// any right-hand side the guess is at least as close in the A-norm as any kept solution
// or the extrapolation through the last two.
TEST(WarmStartTest, ProjectionIsExactInTheSpanAndAtLeastAsGoodAsTheOthers) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<Real> uniform(-1, 1);
  UnknownLocations where;
  where.locations = {0, 6, 0, 0};
  where.offset = {-1, 0, -1, -1};
  where.location[pressure_block] = {0, 1, 2, 3, 4, 5};
  const Eigen::SparseMatrix<Real> A = random_spd(6, rng);
  WarmStartSpec spec;
  spec.kind = WarmStartKind::projection;
  spec.history = 3;
  WarmStart warm(spec, 2, {3, 2});
  std::vector<Eigen::VectorXd> kept;
  for (int k = 0; k < 4; ++k) {  // the first falls out of a history of 3
    kept.push_back(Eigen::VectorXd::NullaryExpr(6, [&] { return uniform(rng); }));
    warm.remember(where, kept.back(), 0.1 * (k + 1));
  }
  const Eigen::VectorXd in_span = 2 * kept[1] - 3 * kept[3] + 0.5 * kept[2];
  Eigen::VectorXd guess;
  warm.guess(where, A, A * in_span, 0.5, guess);
  EXPECT_LT((guess - in_span).norm(), 1e-10 * in_span.norm());

  const Eigen::VectorXd b = Eigen::VectorXd::NullaryExpr(6, [&] { return uniform(rng); });
  const Eigen::VectorXd solution = Eigen::SimplicialLDLT<Eigen::SparseMatrix<Real>>(A).solve(b);
  auto a_error = [&](const Eigen::VectorXd& x) { return std::sqrt((x - solution).dot(A * (x - solution))); };
  warm.guess(where, A, b, 0.5, guess);
  for (int k = 1; k < 4; ++k) EXPECT_LE(a_error(guess), a_error(kept[k]) * (1 + 1e-12));
  EXPECT_LE(a_error(guess), a_error(2 * kept[3] - kept[2]) * (1 + 1e-12));
}

// A learned warm start in a build without libtorch is refused as input (exit 2), naming
// the kinds that remain; with libtorch, a missing model file is refused likewise.
TEST(WarmStartTest, LearnedWithoutAUsableModelIsBadInput) {
  WarmStartSpec spec;
  spec.kind = WarmStartKind::learned;
  spec.model = "no_such_model.pt";
  try {
    WarmStart warm(spec, 2, {4, 4});
    FAIL() << "accepted a missing model";
  } catch (const InputError& error) {
    const std::string what = error.what();
    if (learned_warm_start_available())
      EXPECT_NE(what.find("no such file"), std::string::npos) << what;
    else
      EXPECT_NE(what.find("without libtorch"), std::string::npos) << what;
  }
}

template <class D>
class WarmStartRunTest : public ::testing::Test {};
TYPED_TEST_SUITE(WarmStartRunTest, testing::Dimensions);

// The floating block (2-D, PCG) and cube (3-D), coarse, for 12 steps with each classical
// warm start: the solve stops at the same relative residual (1e-10 here) whatever its
// first guess, so the block's height differs from the cold start's by round-off carried
// through the steps (measured: below 1e-12 m), far below the 1e-9 m asserted; and a
// guess from the last steps saves iterations.
TYPED_TEST(WarmStartRunTest, ResultsDoNotDependOnTheWarmStart) {
  constexpr int dim = TypeParam::value;
  const Json doc = dim == 2 ? testing::benchmark_document("floating_block/floating_block.json",
                                                          {"solver.method=pcg", "solver.tolerance=1e-10", "dx=0.025"})
                            : testing::benchmark_document("floating_block_3d/floating_block_3d.json",
                                                          {"solver.tolerance=1e-10", "dx=0.125"});
  struct Outcome {
    Real height = 0;
    int iterations = 0;
  };
  auto run = [&](WarmStartKind kind) {
    SceneSpec scene = read_scene(doc);
    scene.warm_start.kind = kind;
    Simulation<dim> sim(scene);
    Outcome outcome;
    for (int s = 0; s < 12; ++s) {
      sim.step(2e-3);
      outcome.iterations += sim.last_step().linear.iterations;
    }
    for (const auto& x : sim.solid().position) outcome.height += x[sim.up_axis()] / sim.solid().size();
    return outcome;
  };
  const Outcome cold = run(WarmStartKind::none);
  for (WarmStartKind kind : {WarmStartKind::previous, WarmStartKind::extrapolate, WarmStartKind::projection}) {
    const Outcome warm = run(kind);
    EXPECT_NEAR(warm.height, cold.height, 1e-9) << "warm start " << int(kind);
    EXPECT_LT(warm.iterations, cold.iterations) << "warm start " << int(kind);
    std::printf("warm start %d: height - cold %.3g m, iterations %d (cold %d)\n", int(kind), warm.height - cold.height,
                warm.iterations, cold.iterations);
  }
}

}  // namespace
}  // namespace iqmpm
