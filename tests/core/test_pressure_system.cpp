// The pressure-only system (method.md §5) on a real fluid configuration: the assembled
// matrix is symmetric positive semi-definite; after the solve the recovered velocity is
// discretely divergence-free (G^fT v = 0) and satisfies the wall constraint B v = b to the
// solver tolerance; the projection does not add kinetic energy; PCG and CHOLMOD agree.
#include <Eigen/Dense>

#include "simulation/simulation.h"
#include "test_helpers.h"

namespace iqmpm {
namespace {

template <class D>
class PressureSystemTest : public ::testing::Test {
 protected:
  static constexpr int dim = D::value;

  // A column of fluid against the lower-left walls, with random particle velocities.
  Simulation<dim> make(const std::string& method, Real tolerance, Real dx) {
    std::vector<Real> fluid_max(dim, 0.35), domain_max(dim, 1.0);
    fluid_max[1] = 0.55;
    Json doc = testing::fluid_box_scene(dim, dx, fluid_max, domain_max);
    doc["jitter"] = 0.5;
    doc["solver"] = {{"method", method}, {"tolerance", tolerance}, {"max_iterations", 100000}};
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
  auto sim = this->make("cholmod", 1e-10, dim == 2 ? 0.05 : 0.125);
  sim.step(1e-3);
  const Eigen::MatrixXd A = Eigen::MatrixXd(sim.pressure_system().matrix());
  ASSERT_GT(A.rows(), 10);
  ASSERT_NE(sim.pressure_system().find("y"), nullptr);  // the wall block is present
  EXPECT_LE((A - A.transpose()).cwiseAbs().maxCoeff(), 1e-12 * A.cwiseAbs().maxCoeff());
  const Eigen::VectorXd eigenvalues = Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(A).eigenvalues();
  EXPECT_GE(eigenvalues.minCoeff(), -1e-10 * eigenvalues.maxCoeff());
}

TYPED_TEST(PressureSystemTest, ProjectionIsDivergenceFreeAndRespectsWalls) {
  constexpr int dim = TypeParam::value;
  const Real tolerance = 1e-9;
  auto sim = this->make("pcg", tolerance, dim == 2 ? 0.025 : 0.0625);
  sim.step(1e-3);
  const auto& system = sim.pressure_system();
  const Eigen::VectorXd& v_star = sim.grid_velocity_before_projection();
  const Eigen::VectorXd& v_next = sim.grid_velocity_after_projection();
  const Eigen::VectorXd rhs = system.rhs(v_star);
  const Eigen::VectorXd constraint = system.constraint() * v_next;  // (G^fT v, B v)
  const auto* pressure = system.find("p_f");
  const auto* walls = system.find("y");
  ASSERT_NE(pressure, nullptr);
  ASSERT_NE(walls, nullptr);
  const Real divergence_before = (system.constraint() * v_star).segment(pressure->offset, pressure->size).norm();
  EXPECT_GT(divergence_before, 1e-3);  // the random field really was divergent
  // G^fT v^{n+1} and B v^{n+1} - b are exactly the residual rows of the solve.
  EXPECT_LE(constraint.segment(pressure->offset, pressure->size).norm(), tolerance * rhs.norm() * 1.01);
  EXPECT_LE(constraint.segment(walls->offset, walls->size).norm(), tolerance * rhs.norm() * 1.01);
  EXPECT_LE(this->kinetic_energy(sim, v_next), this->kinetic_energy(sim, v_star));
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

}  // namespace
}  // namespace iqmpm
