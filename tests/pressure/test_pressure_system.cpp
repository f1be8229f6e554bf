// The pressure-only system (method.md §5) on a real fluid configuration: the assembled
// matrix is symmetric positive semi-definite; after the solve the recovered velocity is
// discretely divergence-free (G^fT v = 0) and satisfies the wall constraint (B v = b to the
// solver tolerance with wall faces, a zero normal velocity at every wall corner with walls
// on the corners); the projection does not add kinetic energy; with the transferred mass as
// inertia the particles' momentum changes by the walls' impulse; PCG and CHOLMOD agree.
// The coupled system (interface and ghost-matrix blocks, and the bordered system of the
// solid's stiffness) satisfies its constraints after the solve. The product D W D^T that
// assembles A matches Eigen's and does not depend on the thread count.
#include <Eigen/Dense>

#include <omp.h>

#include <algorithm>
#include <random>

#include "diagnostics/measurements.h"
#include "linear_solver/linear_solver.h"
#include "pressure/pressure_system.h"
#include "simulation/set_up.h"
#include "simulation/simulation.h"
#include "support/run_helpers.h"
#include "support/scenes.h"
#include "support/test_helpers.h"

namespace iqmpm {
namespace {

template <class D>
class PressureSystemTest : public ::testing::Test {
 protected:
  static constexpr int dim = D::value;

  // A column of fluid against the lower-left walls, with random particle velocities.
  Simulation<dim> make(const std::string& method, Real tolerance, Real dx, const std::string& walls = "auto") {
    std::vector<Real> fluid_max(dim, 0.35), domain_max(dim, 1.0);
    fluid_max[1] = 0.55;
    Json doc = testing::fluid_box_scene(dim, dx, fluid_max, domain_max);
    doc["jitter"] = 0.5;
    doc["solver"] = {{"method", method}, {"tolerance", tolerance}, {"max_iterations", 100000}};
    doc["fluid"]["wall_constraint"] = walls;
    Simulation<dim> sim(read_scene(doc));
    std::mt19937 rng(42);
    for (auto& v : sim.fluid().velocity) v = testing::random_vector<dim>(rng, -1, 1);
    return sim;
  }

  static Real kinetic_energy(const Simulation<dim>& sim, const Eigen::VectorXd& v) {
    Real e = 0;
    const auto& mass = sim.fluid_operators().mass;
    for (int i = 0; i < v.size(); ++i) e += 0.5 * mass[i / dim] * v[i] * v[i];
    return e;
  }
};
TYPED_TEST_SUITE(PressureSystemTest, testing::Dimensions);

TYPED_TEST(PressureSystemTest, MatrixIsSymmetricPositiveSemiDefinite) {
  constexpr int dim = TypeParam::value;
  for (const std::string walls : {"faces", "corners"}) {
    SCOPED_TRACE(walls);
    auto sim = this->make("cholmod", 1e-10, dim == 2 ? 0.05 : 0.125, walls);
    sim.step(1e-3);
    const Eigen::MatrixXd A = Eigen::MatrixXd(sim.pressure_system().matrix());
    ASSERT_GT(A.rows(), 10);
    EXPECT_EQ(sim.pressure_system().find("y") != nullptr, walls == "faces");  // the wall block
    EXPECT_LE((A - A.transpose()).cwiseAbs().maxCoeff(), 1e-12 * A.cwiseAbs().maxCoeff());
    const Eigen::VectorXd eigenvalues = Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(A).eigenvalues();
    EXPECT_GE(eigenvalues.minCoeff(), -1e-10 * eigenvalues.maxCoeff());
  }
}

TYPED_TEST(PressureSystemTest, ProjectionIsDivergenceFreeAndRespectsWalls) {
  constexpr int dim = TypeParam::value;
  const Real tolerance = 1e-9;
  for (const std::string walls : {"faces", "corners"}) {
    SCOPED_TRACE(walls);
    auto sim = this->make("pcg", tolerance, dim == 2 ? 0.025 : 0.0625, walls);
    sim.step(1e-3);
    const auto& system = sim.pressure_system();
    const Eigen::VectorXd& v_star = sim.grid_velocity_before_projection();
    const Eigen::VectorXd& v_next = sim.grid_velocity_after_projection();
    const Eigen::VectorXd rhs = system.rhs(v_star);
    const Eigen::VectorXd constraint = system.constraint() * v_next;  // (G^fT v, B v)
    const auto* pressure = system.find("p_f");
    ASSERT_NE(pressure, nullptr);
    const Real divergence_before = (system.constraint() * v_star).segment(pressure->offset, pressure->size).norm();
    EXPECT_GT(divergence_before, 1e-3);  // the random field really was divergent
    // G^fT v^{n+1} and B v^{n+1} - b are exactly the residual rows of the solve.
    EXPECT_LE(constraint.segment(pressure->offset, pressure->size).norm(), tolerance * rhs.norm() * 1.01);
    if (walls == "faces") {
      const auto* rows = system.find("y");
      ASSERT_NE(rows, nullptr);
      EXPECT_LE(constraint.segment(rows->offset, rows->size).norm(), tolerance * rhs.norm() * 1.01);
    } else {  // every corner on a wall moves along it only
      const auto& on_wall = sim.fluid_operators().on_wall;
      int held = 0;
      for (std::size_t d = 0; d < on_wall.size(); ++d)
        for (int a = 0; a < dim; ++a)
          if ((on_wall[d] >> (2 * a)) & 3u) {
            EXPECT_EQ(v_next[d * dim + a], 0);
            ++held;
          }
      EXPECT_GT(held, 0);
    }
    EXPECT_LE(this->kinetic_energy(sim, v_next), this->kinetic_energy(sim, v_star));
  }
}

// fluid.inertia = transfer (docs/method.md#fluid-inertia): in a tank full of crowded water
// (particles heavier than the water their cells hold, as where the dam break's run-up hits
// a corner) every corner's inertia is the mass its particles carried there, so their
// momentum changes by exactly the impulse of the walls: P2G and G2P conserve momentum and
// the pressure's interior forces cancel. With the quadrature's mass M^f each corner passes
// its particles transferred / M^f times its impulse, and the balance fails: what this test
// must be able to see.
TYPED_TEST(PressureSystemTest, TransferredInertiaBalancesTheParticlesMomentumWithTheWalls) {
  constexpr int dim = TypeParam::value;
  const Real dt = 1e-3;
  for (const std::string walls : {"faces", "corners"})
    for (const std::string inertia : {"transfer", "auto", "quadrature"}) {  // auto: transfer without solids
      SCOPED_TRACE(walls + ", " + inertia);
      const std::vector<Real> full(dim, 1.0);
      Json doc = testing::fluid_box_scene(dim, dim == 2 ? 0.05 : 0.125, full, full);
      doc["gravity"] = std::vector<Real>(dim, 0.0);
      doc["jitter"] = 0.5;
      doc["solver"] = {{"method", "cholmod"}};
      doc["fluid"]["inertia"] = inertia;
      doc["fluid"]["wall_constraint"] = walls;
      doc["walls"] = {{"y+", "none"}};  // an open top: the pressure has no constant null mode
      Simulation<dim> sim(read_scene(doc));
      // Particles twice as heavy as the water they stand for (the dam break's crowded
      // corners hold 7-10 particles where 4 were seeded), bunched towards x = 0.5 (0.83 to
      // 1.25 times the seeded density), moving towards the x+ wall and the open top.
      Particles<dim>& fluid = sim.fluid();
      Vec<dim> before = Vec<dim>::Zero();
      for (std::size_t p = 0; p < fluid.size(); ++p) {
        Real& x = fluid.position[p][0];
        x += 0.1 * std::sin(2 * M_PI * x) / M_PI;
        fluid.mass[p] *= 2;
        fluid.velocity[p].setZero();
        fluid.velocity[p][0] = 1;
        fluid.velocity[p][1] = 0.5;
        before += fluid.mass[p] * fluid.velocity[p];
      }
      sim.step(dt);
      Vec<dim> after = Vec<dim>::Zero(), walls_impulse = Vec<dim>::Zero();
      for (std::size_t p = 0; p < fluid.size(); ++p) after += fluid.mass[p] * fluid.velocity[p];
      for (int a = 0; a < dim; ++a) walls_impulse[a] = -dt * (sim.wall_force(a, 0) + sim.wall_force(a, 1));
      const Real mismatch = (after - before - walls_impulse).norm() / walls_impulse.norm();
      ASSERT_GT(walls_impulse.norm(), 0.1 * before.norm());  // the walls really stopped a part of the flow
      if (inertia != "quadrature") {
        for (char exact : sim.fluid_operators().exact_mass) ASSERT_TRUE(exact);  // every corner took it
        EXPECT_LT(mismatch, 1e-9);
      } else {
        EXPECT_GT(mismatch, 1e-3);
      }
    }
}

// add_to_diagonal builds the matrix coeffRef would, entry for entry and in the same
// pattern: adding to stored diagonals, to stored zeros, and creating missing ones, on a
// random sparse matrix with every kind; and when every listed diagonal is stored (the
// in-place path), the same again.
TEST(AddToDiagonalTest, EqualsCoeffRefEntryForEntry) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<Real> value(-1, 1);
  std::uniform_int_distribution<int> index(0, 39);
  std::vector<Eigen::Triplet<Real>> entries;
  for (int k = 0; k < 120; ++k) entries.emplace_back(index(rng), index(rng), value(rng));
  for (int c = 0; c < 40; c += 7) entries.emplace_back(c, c, 0.0);  // stored zeros on the diagonal
  SparseMatrix start(40, 40);
  start.setFromTriplets(entries.begin(), entries.end());
  start.makeCompressed();
  for (int stride : {3, 7}) {  // every third column: some diagonals missing; every seventh: all stored
    SparseMatrix m = start;
    std::vector<std::pair<int, Real>> diagonal;
    for (int c = 0; c < 40; c += stride) diagonal.emplace_back(c, value(rng));
    SparseMatrix expected = m;
    for (const auto& [c, v] : diagonal) expected.coeffRef(c, c) += v;
    expected.makeCompressed();
    add_to_diagonal(m, diagonal);
    m.makeCompressed();
    ASSERT_EQ(m.nonZeros(), expected.nonZeros()) << "stride " << stride;
    if (stride == 7) {
      EXPECT_EQ(m.nonZeros(), start.nonZeros());
    }
    for (int c = 0; c < 40; ++c) {
      SparseMatrix::InnerIterator a(m, c), b(expected, c);
      for (; a && b; ++a, ++b) {
        EXPECT_EQ(a.row(), b.row());
        EXPECT_EQ(a.value(), b.value()) << "(" << a.row() << ", " << c << "), stride " << stride;
      }
      EXPECT_FALSE(a || b) << "column " << c << ", stride " << stride;
    }
  }
}

// Six entries a row in random columns of [first_column, columns), values in (-1, 1); with
// stored_zero, each row's first entry is a stored 0.
std::vector<Eigen::Triplet<Real>> random_constraint_rows(std::mt19937& rng, int rows, int columns, int first_column,
                                                         bool stored_zero) {
  std::uniform_real_distribution<Real> value(-1, 1);
  std::uniform_int_distribution<int> column(first_column, columns - 1);
  std::vector<Eigen::Triplet<Real>> entries;
  for (int i = 0; i < rows; ++i)
    for (int k = 0; k < 6; ++k) entries.emplace_back(i, column(rng), stored_zero && k == 0 ? 0 : value(rng));
  return entries;
}

// weighted_gram's A = s D W D^T against Eigen's sparse product on a random D with a few
// zero weights (whose products stay out of A's pattern): the same entries to round-off,
// and one thread and two give the same matrix bit for bit (rows are independent; 1 500
// rows make six blocks, which the threads share).
TEST(WeightedGramTest, EqualsTheSparseProductAndDoesNotDependOnTheThreadCount) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<Real> value(-1, 1);
  const int rows = 1500, columns = 2400;
  const std::vector<Eigen::Triplet<Real>> entries = random_constraint_rows(rng, rows, columns, 0, false);
  SparseRowMatrix D(rows, columns);
  D.setFromTriplets(entries.begin(), entries.end());
  Eigen::VectorXd weight(columns);
  for (int k = 0; k < columns; ++k) weight[k] = k % 17 == 0 ? 0 : 1 + value(rng);
  const Real scale = 0.01;
  const SparseMatrix by_column = D;
  const SparseMatrix expected = scale * (by_column * weight.asDiagonal() * by_column.transpose());
  const int threads = omp_get_max_threads();
  omp_set_num_threads(1);
  const SparseMatrix one = weighted_gram(D, weight, scale);
  omp_set_num_threads(2);
  const SparseMatrix two = weighted_gram(D, weight, scale);
  omp_set_num_threads(threads);
  ASSERT_EQ(one.nonZeros(), two.nonZeros());
  EXPECT_TRUE(std::equal(one.valuePtr(), one.valuePtr() + one.nonZeros(), two.valuePtr()));
  EXPECT_TRUE(std::equal(one.innerIndexPtr(), one.innerIndexPtr() + one.nonZeros(), two.innerIndexPtr()));
  EXPECT_TRUE(std::equal(one.outerIndexPtr(), one.outerIndexPtr() + rows + 1, two.outerIndexPtr()));
  EXPECT_LE((SparseMatrix(one - expected)).norm(), 1e-14 * expected.norm());
  // The pattern: an entry where some column of non-zero weight joins the two rows.
  int joined = 0;
  for (int c = 0; c < rows; ++c)
    for (SparseMatrix::InnerIterator it(one, c); it; ++it) {
      bool through_weight = false;
      for (SparseRowMatrix::InnerIterator a(D, it.row()); a && !through_weight; ++a)
        through_weight = weight[a.col()] != 0 && D.coeff(c, a.col()) != 0;
      joined += through_weight;
    }
  EXPECT_EQ(joined, one.nonZeros());
}

// A = A^T to the bit, pattern and values, on a random D whose rows also hold stored zeros
// (Eigen keeps a triplet of value 0) and a few zero weights. The upper triangle is each
// row's own pass: A(i,j), i <= j, is stored exactly where a column of non-zero weight has
// a non-zero entry in row j and a stored one in row i; the lower triangle mirrors it. Two
// rows whose products cancel, as the 2-D centre rule's face neighbours do (x and y terms
// of equal size and opposite sign through one weight), keep their entry as an exact zero
// on both sides.
TEST(WeightedGramTest, IsSymmetricToTheBit) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<Real> value(-1, 1);
  const int rows = 600, columns = 900;
  std::vector<Eigen::Triplet<Real>> entries = random_constraint_rows(rng, rows - 2, columns, 2, true);
  // Rows rows-2 and rows-1 meet in columns 0 and 1 (one corner's x and y) only, with
  // products -1/4 and +1/4.
  entries.emplace_back(rows - 2, 0, 0.5);
  entries.emplace_back(rows - 2, 1, 0.5);
  entries.emplace_back(rows - 1, 0, -0.5);
  entries.emplace_back(rows - 1, 1, 0.5);
  SparseRowMatrix D(rows, columns);
  D.setFromTriplets(entries.begin(), entries.end());
  Eigen::VectorXd weight(columns);
  for (int k = 0; k < columns; ++k) weight[k] = k % 13 == 5 ? 0 : 1 + value(rng);
  weight[1] = weight[0];
  const SparseMatrix A = weighted_gram(D, weight, 0.01);
  const SparseMatrix transposed = A.transpose();
  ASSERT_EQ(A.nonZeros(), transposed.nonZeros());
  EXPECT_TRUE(std::equal(A.outerIndexPtr(), A.outerIndexPtr() + rows + 1, transposed.outerIndexPtr()));
  EXPECT_TRUE(std::equal(A.innerIndexPtr(), A.innerIndexPtr() + A.nonZeros(), transposed.innerIndexPtr()));
  EXPECT_TRUE(std::equal(A.valuePtr(), A.valuePtr() + A.nonZeros(), transposed.valuePtr()));
  int joined = 0;
  for (int c = 0; c < rows; ++c)
    for (SparseMatrix::InnerIterator it(A, c); it; ++it) {
      const int high = std::max(int(it.row()), c), low = std::min(int(it.row()), c);
      bool through_weight = false;
      for (SparseRowMatrix::InnerIterator a(D, high); a && !through_weight; ++a) {
        if (weight[a.col()] == 0 || a.value() == 0) continue;
        for (SparseRowMatrix::InnerIterator b(D, low); b && !through_weight; ++b) through_weight = b.col() == a.col();
      }
      joined += through_weight;
    }
  EXPECT_EQ(joined, A.nonZeros());
  int stored_zeros = 0;
  for (int k = 0; k < D.nonZeros(); ++k) stored_zeros += D.valuePtr()[k] == 0;
  EXPECT_GT(stored_zeros, rows / 2);  // the random rows' stored zeros survived setFromTriplets
  EXPECT_EQ(A.coeff(rows - 2, rows - 1), 0);
  bool cancelled_pair_stored = false;
  for (SparseMatrix::InnerIterator it(A, rows - 1); it; ++it) cancelled_pair_stored |= it.row() == rows - 2;
  EXPECT_TRUE(cancelled_pair_stored);
  const SparseMatrix by_column = D;
  const SparseMatrix expected = 0.01 * (by_column * weight.asDiagonal() * by_column.transpose());
  EXPECT_LE((SparseMatrix(A - expected)).norm(), 1e-14 * expected.norm());
}

// fluid.inertia = auto resolves to transfer in a scene without solids and to quadrature
// in one with them (docs/method.md#fluid-inertia).
TEST(FluidInertiaTest, AutoTakesTheTransferredMassOnlyWithoutSolids) {
  EXPECT_TRUE(resolve_step_options(load_scene(testing::scene_path("dam_break/dam_break.json"), {})).inertia_from_transfer);
  EXPECT_FALSE(resolve_step_options(load_scene(testing::scene_path("floating_block/floating_block.json"), {})).inertia_from_transfer);
  EXPECT_TRUE(resolve_step_options(load_scene(testing::scene_path("floating_block/floating_block.json"), {"fluid.inertia=transfer"}))
                  .inertia_from_transfer);
  EXPECT_FALSE(resolve_step_options(load_scene(testing::scene_path("dam_break/dam_break.json"), {"fluid.inertia=quadrature"}))
                   .inertia_from_transfer);
}

TYPED_TEST(PressureSystemTest, PcgAndCholmodAgree) {
  constexpr int dim = TypeParam::value;
  const Real dx = dim == 2 ? 0.05 : 0.125;
  auto direct = this->make("cholmod", 1e-12, dx);
  auto iterative = this->make("pcg", 1e-12, dx);
  direct.step(1e-3);
  iterative.step(1e-3);
  const Eigen::VectorXd& a = direct.grid_velocity_after_projection();
  const Eigen::VectorXd& b = iterative.grid_velocity_after_projection();
  ASSERT_EQ(a.size(), b.size());
  EXPECT_LE((a - b).norm(), 1e-8 * a.norm());
  EXPECT_GT(iterative.last_step().linear.iterations, 0);
}
// Coupled system (method.md §5) on the submerged block after one step: the assembled matrix
// is symmetric, it holds the h block, and the recovered velocities satisfy every
// constraint row (incompressibility, walls, the interface's normal-velocity jump) to the
// direct solver's precision (auto is LDL^T in 2-D; named in 3-D, where auto is CG). This
// checks the algebra of the coupling; the physics of the benchmark is still open (issue #4
// notes: leakage through the per-cell constraint). With experimental.solid_response =
// stiffness the solid's velocities are unknowns of a bordered system (pressure_system.h);
// the same constraints must hold. Typed over the dimension and the solid's response.
template <int d, bool stiffness_response>
struct CoupledCase {
  static constexpr int dim = d;
  static constexpr bool stiffness = stiffness_response;
};
using CoupledCases = ::testing::Types<CoupledCase<2, false>, CoupledCase<2, true>, CoupledCase<3, false>, CoupledCase<3, true>>;
struct CoupledCaseNames {
  template <class Case>
  static std::string GetName(int) {
    return std::string(Case::stiffness ? "Stiffness" : "Mass") + std::to_string(Case::dim);
  }
};
template <class Case>
class CoupledSystemTest : public ::testing::Test {
 protected:
  const testing::OneThread one_thread_;  // 3-D: as the coupled runs (run_helpers.h)
};
TYPED_TEST_SUITE(CoupledSystemTest, CoupledCases, CoupledCaseNames);

TYPED_TEST(CoupledSystemTest, ConstraintsHoldAfterTheSolve) {
  constexpr int dim = TypeParam::dim;
  std::vector<std::string> overrides = {std::string("experimental.solid_response=\"") +
                                        (TypeParam::stiffness ? "stiffness" : "mass") + "\""};
  if (dim == 3) overrides.push_back("solver.method=\"ldlt\"");
  Simulation<dim> sim(read_scene(testing::submerged_block_document<dim>("submerged_block.json", overrides)));
  sim.step(0.005);
  ASSERT_EQ(sim.pressure_system().has_mass_block(), TypeParam::stiffness);
  ASSERT_GT(sim.interface_points(), 0);
  const PressureSystem& system = sim.pressure_system();
  const auto* h = system.find("h");
  const auto* pf = system.find("p_f");
  ASSERT_NE(h, nullptr);
  ASSERT_NE(pf, nullptr);
  const SparseMatrix& A = system.matrix();
  EXPECT_LT((A - SparseMatrix(A.transpose())).norm(), 1e-12 * A.norm());
  const Eigen::VectorXd v = sim.grid_velocity_after_projection();
  const Eigen::VectorXd dv = system.constraint() * v;  // D v^{n+1}: zero on p_f, y and h rows
  const Eigen::VectorXd d_star = system.constraint() * sim.grid_velocity_before_projection();
  EXPECT_LT(dv.segment(h->offset, h->size).norm(), 1e-8 * d_star.norm());
  EXPECT_LT(dv.segment(pf->offset, pf->size).norm(), 1e-8 * d_star.norm());
  // The health check's residual (diagnostics/health.h) is round-off after the direct solve,
  // and for a solution off by delta it is ||(A delta) over the multiplier rows|| / ||r||
  // (D v^{n+1} + offset - C lambda = r - A lambda with v^{n+1} recovered from lambda).
  const Eigen::VectorXd& x = sim.pressure_solution();
  const Eigen::VectorXd v_star = sim.grid_velocity_before_projection();
  EXPECT_LT(system.relative_constraint_residual(v_star, v, x), 1e-9);
  std::mt19937 rng(3);
  Eigen::VectorXd delta(x.size());
  for (int i = 0; i < delta.size(); ++i) delta[i] = 1e-3 * (x.cwiseAbs().maxCoeff() + 1) * std::uniform_real_distribution<Real>(-1, 1)(rng);
  const Eigen::VectorXd off = x + delta;
  const Eigen::VectorXd r = system.rhs(v_star);
  const int m = system.unknowns();
  const Real expected = (A * delta).head(m).norm() / r.head(m).norm();
  EXPECT_NEAR(system.relative_constraint_residual(v_star, system.corrected_velocity(v_star, off), off), expected, 1e-9 * expected);
  // The fluid pushes the block up (buoyancy, 196.2 N/m in 2-D): the sign and rough size of
  // the force, and nothing sideways (a symmetric set-up).
  const Vec<dim> force = body_interface_force(sim, 0);
  EXPECT_GT(force[1], 0.5 * 1000 * 9.81 * testing::submerged_block_volume<dim>());
  for (int a = 0; a < dim; ++a)
    if (a != 1) {
      EXPECT_NEAR(force[a], 0, 1e-6) << "axis " << a;
    }
}

}  // namespace
}  // namespace iqmpm

namespace iqmpm {
namespace {

// The bordered system of coupling.solid_response = stiffness (pressure_system.h) on random
// operators: eliminating its velocity unknowns u gives the pressure-only system with H^-1 in
// place of the lumped inverse mass on the bordered entries, so lambda and the recovered
// velocities equal those of the dense formula; with H = M it is the plain system (36).
TEST(BorderedPressureSystemTest, EqualsThePressureOnlySystemWithTheInverseOfH) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<Real> uniform(-1, 1);
  const int velocities = 14, rows = 6;
  const Real dt = 0.01;
  const std::vector<int> bordered = {1, 2, 3, 7, 8};
  Eigen::VectorXd inverse_mass(velocities), v_star(velocities);
  for (int k = 0; k < velocities; ++k) inverse_mass[k] = 1 / (1 + 0.5 * (1 + uniform(rng))), v_star[k] = uniform(rng);
  std::vector<Eigen::Triplet<Real>> entries;
  for (int r = 0; r < rows; ++r)
    for (int k = 0; k < velocities; ++k)
      if (uniform(rng) > 0.2) entries.emplace_back(r, k, uniform(rng));
  std::vector<Real> compliance(rows, 0), offset(rows, 0);
  compliance[0] = 0.3, offset[0] = 0.2;  // a ghost-matrix-like row
  const int nb = int(bordered.size());
  const Eigen::MatrixXd R = Eigen::MatrixXd::NullaryExpr(nb, nb, [&] { return uniform(rng); });
  Eigen::MatrixXd H = R * R.transpose() + Eigen::MatrixXd::Identity(nb, nb);  // SPD, M + dt^2 K-like
  for (int k = 0; k < nb; ++k) H(k, k) += 1 / inverse_mass[bordered[k]];

  // Reference: A = dt D W D^T + C with W = M^-1 except W_bb = H^-1; v = v* - dt W D^T lambda.
  SparseMatrix D(rows, velocities);
  D.setFromTriplets(entries.begin(), entries.end());
  Eigen::MatrixXd W = Eigen::MatrixXd(inverse_mass.asDiagonal());
  const Eigen::MatrixXd H_inverse = H.inverse();
  for (int a = 0; a < nb; ++a) {
    W(bordered[a], bordered[a]) = 0;
    for (int b = 0; b < nb; ++b) W(bordered[a], bordered[b]) = H_inverse(a, b);
  }
  const Eigen::MatrixXd Dd = Eigen::MatrixXd(D);
  Eigen::MatrixXd A = dt * Dd * W * Dd.transpose();
  Eigen::VectorXd r = Dd * v_star;
  for (int i = 0; i < rows; ++i) A(i, i) += compliance[i], r[i] += offset[i];
  const Eigen::VectorXd lambda = A.ldlt().solve(r);
  const Eigen::VectorXd v_next = v_star - dt * W * Dd.transpose() * lambda;

  auto solve_bordered = [&](const Eigen::MatrixXd& mass) {
    PressureSystem system;
    system.reset(inverse_mass);
    system.add_block("rows", rows, entries, compliance, offset);
    system.set_mass_block(bordered, Eigen::MatrixXd(mass).sparseView());
    system.assemble(dt);
    EXPECT_EQ(system.size(), rows + nb);
    const SparseMatrix& K = system.matrix();
    EXPECT_LT((K - SparseMatrix(K.transpose())).norm(), 1e-14 * K.norm());
    Eigen::VectorXd x = Eigen::VectorXd::Zero(system.size());
    const auto stats = make_linear_solver(LinearSolverOptions{LinearSolverMethod::ldlt}, system.size(), 2)->solve(K, system.rhs(v_star), x);
    EXPECT_TRUE(stats.converged);
    EXPECT_LT(stats.relative_residual, 1e-12);
    return std::make_pair(Eigen::VectorXd(x.head(rows)), system.corrected_velocity(v_star, x));
  };
  const auto [lambda_h, v_h] = solve_bordered(H);
  EXPECT_LT((lambda_h - lambda).norm(), 1e-10 * lambda.norm());
  EXPECT_LT((v_h - v_next).norm(), 1e-10 * v_next.norm());

  // H = M on the bordered entries: the lumped system (36).
  Eigen::MatrixXd M = Eigen::MatrixXd::Zero(nb, nb);
  for (int k = 0; k < nb; ++k) M(k, k) = 1 / inverse_mass[bordered[k]];
  PressureSystem lumped;
  lumped.reset(inverse_mass);
  lumped.add_block("rows", rows, entries, compliance, offset);
  lumped.assemble(dt);
  const Eigen::VectorXd lambda_m = Eigen::MatrixXd(lumped.matrix()).ldlt().solve(lumped.rhs(v_star));
  const auto [lambda_b, v_b] = solve_bordered(M);
  EXPECT_LT((lambda_b - lambda_m).norm(), 1e-10 * lambda_m.norm());
  EXPECT_LT((v_b - lumped.corrected_velocity(v_star, lambda_m)).norm(), 1e-10 * v_b.norm());
  // The stiffer solid moves less under the same constraints: a different solution.
  EXPECT_GT((lambda_h - lambda_m).norm(), 1e-3 * lambda_m.norm());
}

}  // namespace
}  // namespace iqmpm

namespace iqmpm {
namespace {

// A row of D that touches only held velocities (zero inverse mass: a fluid cell inside a
// clamped body) is an empty row of A (pressure_system.h): it becomes a unit row with zero
// right-hand side, so a direct solver factorises without the diagonal shift it needed
// before (1091 shifted solves in a dam_break_obstacle run), its multiplier and force are
// zero, and the other rows' solution is the one of the system without it.
TEST(PressureSystemVacantRowTest, RowOnHeldVelocitiesIsAUnitRowWithZeroMultiplier) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<Real> uniform(-1, 1);
  const int velocities = 12, rows = 5;
  const Real dt = 0.01;
  Eigen::VectorXd inverse_mass(velocities), v_star(velocities);
  for (int k = 0; k < velocities; ++k) inverse_mass[k] = 1 + 0.5 * uniform(rng), v_star[k] = uniform(rng);
  inverse_mass[10] = inverse_mass[11] = 0;  // held
  std::vector<Eigen::Triplet<Real>> entries;
  for (int r = 0; r < rows - 1; ++r)
    for (int k = 0; k < 10; ++k)
      if (uniform(rng) > 0.1) entries.emplace_back(r, k, uniform(rng));
  entries.emplace_back(2, 10, 0.7);                                        // a live row may touch a held velocity
  entries.emplace_back(rows - 1, 10, 1.0), entries.emplace_back(rows - 1, 11, -0.5);  // the vacant row
  PressureSystem system;
  system.reset(inverse_mass);
  system.add_block("rows", rows, entries);
  system.assemble(dt);
  ASSERT_EQ(system.vacant_rows(), 1);
  EXPECT_TRUE(system.vacant(rows - 1));
  EXPECT_EQ(system.matrix().coeff(rows - 1, rows - 1), 1);
  const Eigen::VectorXd r = system.rhs(v_star);
  EXPECT_EQ(r[rows - 1], 0);
  EXPECT_NE(Eigen::VectorXd(system.constraint() * v_star)[rows - 1], 0);  // D v* there is not zero: the row is unenforceable
  Eigen::VectorXd x = Eigen::VectorXd::Zero(system.size());
  const auto stats = make_linear_solver(LinearSolverOptions{LinearSolverMethod::ldlt}, system.size(), 2)->solve(system.matrix(), r, x);
  EXPECT_FALSE(stats.shifted);
  EXPECT_LT(stats.relative_residual, 1e-12);
  EXPECT_EQ(x[rows - 1], 0);
  // The live rows: the same solution as the system assembled without the vacant row.
  PressureSystem live;
  live.reset(inverse_mass);
  std::vector<Eigen::Triplet<Real>> live_entries;
  for (const auto& t : entries)
    if (t.row() < rows - 1) live_entries.push_back(t);
  live.add_block("rows", rows - 1, live_entries);
  live.assemble(dt);
  EXPECT_EQ(live.vacant_rows(), 0);
  const Eigen::VectorXd y = Eigen::MatrixXd(live.matrix()).ldlt().solve(live.rhs(v_star));
  EXPECT_LT((x.head(rows - 1) - y).norm(), 1e-12 * y.norm());
  const Eigen::VectorXd v_next = system.corrected_velocity(v_star, x);
  EXPECT_LT((v_next - live.corrected_velocity(v_star, y)).norm(), 1e-12 * v_next.norm());
  EXPECT_LT(system.relative_constraint_residual(v_star, v_next, x), 1e-12);  // the vacant row is not counted
}

// D is copied straight into compressed rows when the blocks' triplets come by row with
// rising columns and no repeats (as the fluid operators emit them), and built by Eigen's
// setFromTriplets otherwise (repeats summed): both give Eigen's matrix, bit for bit, and
// the same A. An explicit zero is kept as an entry, as setFromTriplets keeps it.
TEST(PressureSystemAssemblyTest, DFromOrderedTripletsEqualsSetFromTripletsAndRepeatsAreSummed) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<Real> uniform(-1, 1);
  const int velocities = 40, rows = 12, wall_rows = 3;
  Eigen::VectorXd inverse_mass(velocities);
  for (int k = 0; k < velocities; ++k) inverse_mass[k] = 1 + 0.5 * uniform(rng);
  std::vector<Eigen::Triplet<Real>> divergence, wall;
  for (int r = 0; r < rows; ++r)
    for (int k = 0; k < velocities; ++k)
      if (uniform(rng) > 0.6) divergence.emplace_back(r, k, r == 3 && k < 8 ? 0.0 : uniform(rng));
  for (int r = 0; r < wall_rows; ++r) wall.emplace_back(r, 2 * r + 1, uniform(rng));
  auto reference = [&](const std::vector<Eigen::Triplet<Real>>& all) {
    SparseRowMatrix D(rows + wall_rows, velocities);
    D.setFromTriplets(all.begin(), all.end());
    return D;
  };
  auto same = [](const SparseRowMatrix& a, const SparseRowMatrix& b) {
    return a.nonZeros() == b.nonZeros() && std::equal(a.outerIndexPtr(), a.outerIndexPtr() + a.rows() + 1, b.outerIndexPtr()) &&
           std::equal(a.innerIndexPtr(), a.innerIndexPtr() + a.nonZeros(), b.innerIndexPtr()) &&
           std::equal(a.valuePtr(), a.valuePtr() + a.nonZeros(), b.valuePtr());
  };
  std::vector<Eigen::Triplet<Real>> stacked = divergence;
  for (const auto& t : wall) stacked.emplace_back(t.row() + rows, t.col(), t.value());
  {
    PressureSystem system;
    system.reset(inverse_mass);
    system.add_block("divergence", rows, divergence);
    system.add_block("wall", wall_rows, wall);
    system.assemble(0.01);
    EXPECT_TRUE(same(system.constraint(), reference(stacked)));
  }
  // Out of order, one entry split in two: setFromTriplets' sum.
  std::vector<Eigen::Triplet<Real>> shuffled = divergence;
  std::shuffle(shuffled.begin(), shuffled.end(), rng);
  const Eigen::Triplet<Real> split = shuffled.back();
  shuffled.back() = Eigen::Triplet<Real>(split.row(), split.col(), 0.25 * split.value());
  shuffled.emplace_back(split.row(), split.col(), 0.75 * split.value());
  PressureSystem system;
  system.reset(inverse_mass);
  system.add_block("divergence", rows, shuffled);
  system.add_block("wall", wall_rows, wall);
  system.assemble(0.01);
  std::vector<Eigen::Triplet<Real>> shuffled_stacked = shuffled;
  for (const auto& t : wall) shuffled_stacked.emplace_back(t.row() + rows, t.col(), t.value());
  EXPECT_TRUE(same(system.constraint(), reference(shuffled_stacked)));
  EXPECT_EQ(system.constraint().nonZeros(), reference(stacked).nonZeros());
}

}  // namespace
}  // namespace iqmpm
