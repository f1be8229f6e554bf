// Tests of the implicit solid step (method.md §3 step 2): the incremental potential's
// derivatives by finite differences, the projected Hessian, invariance under translation,
// Newton's convergence rate, Dirichlet nodes and a clamped block under gravity.
// One suite runs over both materials in 2-D and 3-D, one over the dimensions only. The
// potential is instantiated, and solid_step called, as the simulation's Newton stage does
// (simulation/solid_stage.h): with SolidMaterial (the model chosen at run time) and the
// Newton options resolved from a scene (simulation/set_up.h).
#include <Eigen/Dense>
#include <Eigen/Eigenvalues>
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "support/finite_differences.h"
#include "support/test_helpers.h"
#include "materials/fixed_corotated.h"
#include "materials/neo_hookean.h"
#include "materials/solid_material.h"
#include "particles/particles.h"
#include "simulation/set_up.h"
#include "solid/solid_step.h"
#include "transfer/apic.h"

namespace iqmpm {
namespace {

using Vector = Eigen::Matrix<Real, Eigen::Dynamic, 1>;
using DenseMatrix = Eigen::Matrix<Real, Eigen::Dynamic, Eigen::Dynamic>;

constexpr Real kDensity = 1000;
constexpr Real kDx = 0.1;

template <class Material>
struct DimOf;
template <int d>
struct DimOf<FixedCorotated<d>> {
  static constexpr int value = d;
};
template <int d>
struct DimOf<NeoHookean<d>> {
  static constexpr int value = d;
};

// The material as the simulation holds it (materials/solid_material.h: the model chosen
// per body at run time), the one the simulation's Newton step instantiates the potential
// and solid_step with; `Model` gives the model and its Lame parameters from E and nu.
template <class Model>
SolidMaterial<DimOf<Model>::value> material_of(Real youngs_modulus = 1e5, Real poisson_ratio = 0.3) {
  constexpr int dim = DimOf<Model>::value;
  const Model model = Model::from_young_poisson(youngs_modulus, poisson_ratio);
  return {std::is_same_v<Model, NeoHookean<dim>> ? SolidModel::neo_hookean : SolidModel::fixed_corotated, model.mu,
          model.lambda};
}

template <int dim>
using Potential = SolidIncrementalPotential<dim, SolidMaterial<dim>>;

// Newton's options as the simulation resolves them from a scene's defaults
// (simulation/set_up.h): the direction by LDL^T in 2-D, by CG in 3-D.
template <int dim>
ProjectedNewtonOptions newton_options() {
  return resolve_step_options(read_scene(testing::fluid_box_scene(dim, 0.1, std::vector<Real>(dim, 0.5),
                                                                  std::vector<Real>(dim, 1.0))))
      .newton;
}

// The potential's unknowns from node velocities dense over Grid::nodes() (solid_step's v*).
template <int dim>
Vector unknowns_of(const Potential<dim>& potential, const std::vector<Vec<dim>>& node_velocity) {
  Vector v(potential.unknowns());
  for (int r = 0; r * dim < potential.unknowns(); ++r) v.segment<dim>(dim * r) = node_velocity[potential.dense_node(r)];
  return v;
}

// A block of solid particles in the unit box (dx = 0.1), cells [first, first + cells)^dim,
// 2^dim particles per cell on a slightly jittered lattice, every F_p^n = F(p).
template <int dim>
struct Block {
  Grid<dim> grid;
  Particles<dim> particles;
  SolidNodes<dim> nodes;
};

template <int dim, class DeformationOf>
Block<dim> make_block(int first, int cells, std::mt19937& rng, DeformationOf deformation_of,
                      const Vec<dim>& particle_velocity = Vec<dim>::Zero()) {
  Block<dim> block;
  block.grid = Grid<dim>(Vec<dim>::Zero(), Vec<dim>::Ones(), kDx);
  const Real volume = std::pow(kDx / 2, dim);
  const IVec<dim> sub_cells = IVec<dim>::Constant(2 * cells);
  const GridLayout<dim> lattice(IVec<dim>::Zero(), sub_cells);
  for (int k = 0; k < lattice.size(); ++k) {
    const Vec<dim> cell = lattice.multi_index(k).template cast<Real>();
    const Vec<dim> x = kDx * (Vec<dim>::Constant(first) + (cell + Vec<dim>::Constant(0.5)) / 2 +
                              testing::random_vector<dim>(rng, -0.1, 0.1));
    block.particles.add(x, particle_velocity, kDensity * volume, volume);
    block.particles.deformation_gradient.push_back(deformation_of(rng));
  }
  const ParticleBins<dim> bins = sort_particles_by_cell(block.grid, block.particles);
  GridMomentum<dim> momentum;
  solid_particles_to_grid(block.grid, block.particles, bins, momentum);
  block.nodes.mass = momentum.mass;
  block.nodes.velocity.assign(momentum.mass.size(), Vec<dim>::Zero());
  for (std::size_t i = 0; i < momentum.mass.size(); ++i)
    if (momentum.mass[i] > 0) block.nodes.velocity[i] = momentum.momentum[i] / momentum.mass[i];
  return block;
}

template <int dim>
Mat<dim> random_deformation(std::mt19937& rng) {
  for (;;) {
    const Mat<dim> F = Mat<dim>::Identity() + testing::random_matrix<dim>(rng, -0.25, 0.25);
    if (F.determinant() > 0.3) return F;
  }
}

template <int dim>
Mat<dim> random_rotation(std::mt19937& rng) {
  const Eigen::HouseholderQR<Mat<dim>> qr(testing::random_matrix<dim>(rng, -1, 1));
  Mat<dim> Q = qr.householderQ();
  if (Q.determinant() < 0) Q.col(0) *= -1;
  return Q;
}

// Clamps the active nodes whose first index is <= last_index, at `velocity`.
template <int dim>
int clamp_nodes_up_to(Block<dim>& block, int last_index, const Vec<dim>& velocity) {
  const GridLayout<dim> layout = block.grid.nodes();
  block.nodes.clamped.assign(layout.size(), 0);
  block.nodes.clamped_velocity.assign(layout.size(), Vec<dim>::Zero());
  int count = 0;
  for (int k = 0; k < layout.size(); ++k)
    if (block.nodes.mass[k] > 0 && layout.multi_index(k)[0] <= last_index) {
      block.nodes.clamped[k] = 1;
      block.nodes.clamped_velocity[k] = velocity;
      ++count;
    }
  return count;
}

// An undeformed block of `cells`^dim cells from cell 2, at rest with v^n = dt g, its
// active nodes with first index <= 2 clamped at rest (a side held: at least one node).
template <int dim>
Block<dim> clamped_block_under_gravity(int cells, std::mt19937& rng, Real dt) {
  Vec<dim> gravity_velocity = Vec<dim>::Zero();
  gravity_velocity[1] = -9.81 * dt;
  Block<dim> block = make_block<dim>(
      2, cells, rng, [](std::mt19937&) { return Mat<dim>(Mat<dim>::Identity()); }, gravity_velocity);
  if (clamp_nodes_up_to<dim>(block, 2, Vec<dim>::Zero()) == 0) throw std::logic_error("test block: no node clamped");
  return block;
}

template <int dim>
int active_nodes(const Block<dim>& block) {
  int count = 0;
  for (Real m : block.nodes.mass) count += m > 0;
  return count;
}

Vector random_vector(std::mt19937& rng, int size, Real lo, Real hi) {
  std::uniform_real_distribution<Real> u(lo, hi);
  Vector v(size);
  for (int k = 0; k < size; ++k) v[k] = u(rng);
  return v;
}

// ---------------------------------------------------------------------------------------
template <class Material>
class SolidPotentialTest : public ::testing::Test {};

using Materials = ::testing::Types<FixedCorotated<2>, FixedCorotated<3>, NeoHookean<2>, NeoHookean<3>>;
struct MaterialNames {
  template <class Material>
  static std::string GetName(int) {
    return std::string(std::is_same_v<Material, FixedCorotated<DimOf<Material>::value>> ? "FixedCorotated"
                                                                                        : "NeoHookean") +
           std::to_string(DimOf<Material>::value);
  }
};
TYPED_TEST_SUITE(SolidPotentialTest, Materials, MaterialNames);

// (a) g = dE/dv against central differences of E, and H = dg/dv (unprojected) against
// central differences of g, at a random v on a block with random F^n, random v^n and a
// clamped side with a non-zero prescribed velocity (F_p(v) then has a constant part, at which
// the derivatives are taken; its value is checked by the step tests), for both
// time-integration rules (the midpoint rule with random start velocities u).
// Errors are measured against the elastic parts of g and H (the kinetic parts are exact),
// so a wrong elastic term cannot hide behind the mass matrix.
TYPED_TEST(SolidPotentialTest, DerivativesMatchFiniteDifferences) {
  constexpr int dim = DimOf<TypeParam>::value;
  std::mt19937 rng(20240601 + dim);
  Block<dim> block = make_block<dim>(3, 3, rng, random_deformation<dim>);
  for (Vec<dim>& v : block.nodes.velocity) v = testing::random_vector<dim>(rng, -1, 1);
  clamp_nodes_up_to<dim>(block, 2, testing::random_vector<dim>(rng, -1, 1));
  block.nodes.start_velocity.resize(block.nodes.velocity.size());
  for (Vec<dim>& u : block.nodes.start_velocity) u = testing::random_vector<dim>(rng, -1, 1);
  const Real dt = 1e-2;
  for (const SolidTimeIntegration rule : {SolidTimeIntegration::implicit_euler, SolidTimeIntegration::midpoint}) {
    SCOPED_TRACE(rule == SolidTimeIntegration::midpoint ? "midpoint" : "implicit Euler");
    const Potential<dim> potential(block.grid, block.particles, std::vector{material_of<TypeParam>()}, {}, block.nodes,
                                   dt, rule);
    const int n = potential.unknowns();
    const Vector v = random_vector(rng, n, -1, 1);
    ASSERT_TRUE(std::isfinite(potential.energy(v)));

    const Vector g = potential.gradient(v);
    const testing::CentralDifferences differences = testing::central_differences(potential, v, 1e-6);
    const Vector& g_fd = differences.gradient;
    const DenseMatrix& H_fd = differences.hessian;
    const Vector kinetic_gradient = potential.mass_diagonal().cwiseProduct(v - potential.initial_velocity());
    const Vector elastic_gradient = g - kinetic_gradient;
    const Real gradient_error = (g_fd - g).norm() / elastic_gradient.norm();
    EXPECT_LT(gradient_error, 1e-6) << "relative error |g_fd - g| / |g_elastic| must be < 1e-6 (n = " << n << ")";

    std::cout << "[          ] n = " << n << ", gradient error " << gradient_error;
    const DenseMatrix H = DenseMatrix(potential.hessian(v, /*project_to_psd=*/false));
    const DenseMatrix mass = potential.mass_diagonal().asDiagonal();
    const Real hessian_error = (H_fd - H).norm() / (H - mass).norm();
    std::cout << ", Hessian error " << hessian_error << '\n';
    EXPECT_LT(hessian_error, 1e-6) << "relative error |H_fd - H|_F / |H_elastic|_F must be < 1e-6 (n = " << n << ")";
    // The elastic part is not negligible next to the mass (else the checks above are weak).
    EXPECT_GT((H - mass).norm(), 0.1 * mass.norm());
  }
}

// (b) The projected Hessian is exactly symmetric and its elastic part PSD, on a strongly
// compressed block where the unprojected elastic part is indefinite (so the projection
// is exercised, not just passed through).
TYPED_TEST(SolidPotentialTest, ProjectedHessianIsSymmetricPositiveSemidefinite) {
  constexpr int dim = DimOf<TypeParam>::value;
  std::mt19937 rng(7 + dim);
  Block<dim> block = make_block<dim>(3, 3, rng, [](std::mt19937& r) {
    return Mat<dim>(random_rotation<dim>(r) * Real(0.6) * random_deformation<dim>(r));
  });
  const Potential<dim> potential(block.grid, block.particles, material_of<TypeParam>(), block.nodes, /*dt=*/1e-2);
  const Vector v = random_vector(rng, potential.unknowns(), -0.5, 0.5);
  ASSERT_TRUE(std::isfinite(potential.energy(v)));
  const DenseMatrix mass = potential.mass_diagonal().asDiagonal();

  const DenseMatrix projected = DenseMatrix(potential.hessian(v, true));
  EXPECT_EQ((projected - projected.transpose()).norm(), 0) << "projected Hessian not symmetric";
  const Eigen::VectorXd eigen_projected =
      Eigen::SelfAdjointEigenSolver<DenseMatrix>(projected - mass, Eigen::EigenvaluesOnly).eigenvalues();
  EXPECT_GE(eigen_projected.minCoeff(), -1e-12 * eigen_projected.cwiseAbs().maxCoeff())
      << "elastic part of the projected Hessian has eigenvalue " << eigen_projected.minCoeff() << " (largest "
      << eigen_projected.maxCoeff() << ")";

  const DenseMatrix unprojected = DenseMatrix(potential.hessian(v, false));
  const Eigen::VectorXd eigen_unprojected =
      Eigen::SelfAdjointEigenSolver<DenseMatrix>(unprojected - mass, Eigen::EigenvaluesOnly).eigenvalues();
  EXPECT_LT(eigen_unprojected.minCoeff(), -1e-6 * eigen_unprojected.maxCoeff())
      << "test case too weak: the unprojected elastic Hessian is already PSD";
}

// (c) The matrix-free Hessian that CG uses (3-D Newton directions) is the assembled one:
// products H x and the diagonal agree to round-off, projected and not, with clamped nodes
// and wall-held components (identity-times-mass rows and columns).
TYPED_TEST(SolidPotentialTest, HessianProductsMatchTheAssembledHessian) {
  constexpr int dim = DimOf<TypeParam>::value;
  std::mt19937 rng(31 + dim);
  Block<dim> block = make_block<dim>(3, 3, rng, [](std::mt19937& r) {
    return Mat<dim>(random_rotation<dim>(r) * Real(0.7) * random_deformation<dim>(r));
  });
  clamp_nodes_up_to<dim>(block, 2, testing::random_vector<dim>(rng, -1, 1));
  const GridLayout<dim> layout = block.grid.nodes();
  block.nodes.fixed_axes.assign(layout.size(), 0);
  int held = 0;
  for (int k = 0; k < layout.size(); ++k)
    if (block.nodes.mass[k] > 0 && !block.nodes.clamped[k] && layout.multi_index(k)[1] <= 3)
      block.nodes.fixed_axes[k] = 1u << 1, ++held;
  ASSERT_GT(held, 0);
  const Potential<dim> potential(block.grid, block.particles, material_of<TypeParam>(), block.nodes, /*dt=*/1e-2);
  const Vector v = random_vector(rng, potential.unknowns(), -0.5, 0.5);
  ASSERT_TRUE(std::isfinite(potential.energy(v)));
  for (bool project : {true, false}) {
    const auto H = potential.hessian(v, project);
    const auto linear = potential.linearize(v, project);
    const Vector diagonal = H.diagonal();
    EXPECT_LT((linear.diagonal - diagonal).norm(), 1e-12 * diagonal.norm()) << "project " << project;
    for (int trial = 0; trial < 3; ++trial) {
      const Vector x = random_vector(rng, potential.unknowns(), -1, 1);
      const Vector assembled = H * x;
      EXPECT_LT((potential.hessian_product(linear, x) - assembled).norm(), 1e-12 * assembled.norm())
          << "project " << project;
    }
  }
}

// (d) Newton's local rate: a compressed block (F^n = 0.8 I, at rest) expands in one large
// step (solid_step, with the simulation's options but for the tolerances). With the exact
// Hessian (project_hessian = false, which stays SPD here through the mass) and the
// direction by LDL^T (2-D) or by CG to a tolerance ~ ||g_k|| (3-D),
// ||g_{k+1}|| <= C ||g_k||^2 / ||g_0|| once ||g_k|| is small. The projected default must
// converge too (at a rate the test does not assert).
TYPED_TEST(SolidPotentialTest, NewtonConvergesQuadraticallyNearTheSolution) {
  constexpr int dim = DimOf<TypeParam>::value;
  std::mt19937 rng(99 + dim);
  Block<dim> block = make_block<dim>(3, 3, rng, [](std::mt19937&) { return Mat<dim>(Real(0.8) * Mat<dim>::Identity()); });
  const Real dt = 2e-2;
  const Potential<dim> potential(block.grid, block.particles, material_of<TypeParam>(), block.nodes, dt);
  ProjectedNewtonOptions options = newton_options<dim>();
  options.project_hessian = false;
  options.relative_tolerance = options.cg_relative_tolerance = 1e-13;
  options.absolute_tolerance = 0;
  options.max_iterations = 30;
  std::vector<Vec<dim>> velocity;
  const NewtonResult exact = solid_step(block.grid, block.particles, material_of<TypeParam>(), block.nodes, dt, options, velocity);
  const Vector v = unknowns_of(potential, velocity);
  const std::vector<Real>& g = exact.gradient_norms;
  const std::string message = "exact-Hessian Newton: " + exact.summary();
  std::cout << "[          ] " << message << '\n';
  ASSERT_TRUE(exact.converged) << message;
  ASSERT_GE(exact.iterations, 3) << "too easy to show a rate; " << message;

  // Pairs in the asymptotic regime: ||g_k|| / ||g_0|| < 1e-2, ||g_{k+1}|| above roundoff.
  const Real C = 10;
  int checked = 0;
  for (std::size_t k = 0; k + 1 < g.size(); ++k) {
    const Real rk = g[k] / g[0], rk1 = g[k + 1] / g[0];
    if (rk >= 1e-2 || rk1 < 1e-12) continue;
    ++checked;
    EXPECT_LE(rk1, C * rk * rk) << "not quadratic at k = " << k << " (C = " << C << "); " << message;
  }
  EXPECT_GE(checked, 1) << "no iteration in the asymptotic regime; " << message;

  options.project_hessian = true;
  options.relative_tolerance = options.cg_relative_tolerance = 1e-8;
  const NewtonResult projected =
      solid_step(block.grid, block.particles, material_of<TypeParam>(), block.nodes, dt, options, velocity);
  const Vector w = unknowns_of(potential, velocity);
  std::cout << "[          ] projected Newton: " << projected.summary() << '\n';
  EXPECT_TRUE(projected.converged) << projected.summary();
  EXPECT_LT((w - v).norm(), 1e-5 * v.norm()) << "projected and exact Newton found different minima";
}

// (e) The midpoint rule (method.md#solid-time-integration) keeps a free vibration's energy
// over one step, implicit Euler removes it. A block with random F^n and random nodal
// velocities u (no gravity, so v^n = u) takes one step of each rule; the energy
// sum m |v|^2 / 2 + sum V0 Psi(F^{n+1}) against the start's, with F^{n+1} as G2P makes it
// (simulation/transfer_stages.h): (I + dt grad w(x_p)) F^n of the velocity the material moves
// with, (u + v) / 2 for the midpoint, v for implicit Euler (transfer/apic.h). Midpoint: exact
// for a quadratic Psi, so the change is of third order in the step's strain increment
// (halving dt divides it by 8; at least 4 asked); implicit Euler loses a few per cent of the
// energy a step (the random velocities excite the grid's stiffest modes, omega dt of order
// 1). Measured over the four materials: midpoint 3e-6 to 4e-5 (dt) and 1e-7 to 2e-6 (dt/2),
// implicit Euler -3.8 to -6.0 % and -1.1 to -1.9 %.
TYPED_TEST(SolidPotentialTest, MidpointStepKeepsTheEnergyThatImplicitEulerRemoves) {
  constexpr int dim = DimOf<TypeParam>::value;
  std::mt19937 rng(7 + dim);
  Block<dim> block = make_block<dim>(3, 3, rng, random_deformation<dim>);
  for (std::size_t k = 0; k < block.nodes.mass.size(); ++k)
    if (block.nodes.mass[k] > 0) block.nodes.velocity[k] = testing::random_vector<dim>(rng, -0.5, 0.5);
  block.nodes.start_velocity = block.nodes.velocity;
  const auto material = material_of<TypeParam>();
  ProjectedNewtonOptions options = newton_options<dim>();
  options.relative_tolerance = options.cg_relative_tolerance = 1e-12;
  options.absolute_tolerance = 0;
  options.max_iterations = 60;

  auto energy = [&](const std::vector<Vec<dim>>& node_velocity, const std::vector<Mat<dim>>& F) {
    Real e = 0;
    for (std::size_t k = 0; k < node_velocity.size(); ++k) e += Real(0.5) * block.nodes.mass[k] * node_velocity[k].squaredNorm();
    for (std::size_t p = 0; p < F.size(); ++p) e += block.particles.initial_volume[p] * material.energy_density(F[p]);
    return e;
  };
  const Real start = energy(block.nodes.velocity, block.particles.deformation_gradient);
  // The energy change of one step of `rule` at dt, as a fraction of the start's energy.
  auto change = [&](SolidTimeIntegration rule, Real dt) {
    std::vector<Vec<dim>> velocity;
    const NewtonResult result = solid_step(block.grid, block.particles, std::vector{material}, {}, block.nodes, dt,
                                           options, velocity, nullptr, rule);
    EXPECT_TRUE(result.converged) << result.summary();
    std::vector<Vec<dim>> moving = velocity;
    if (rule == SolidTimeIntegration::midpoint)
      for (std::size_t k = 0; k < moving.size(); ++k) moving[k] = Real(0.5) * (block.nodes.start_velocity[k] + velocity[k]);
    std::vector<Vec<dim>> particle_velocity;
    std::vector<Mat<dim>> gradient;
    interpolate_solid_velocity(block.grid, moving, block.particles, particle_velocity, gradient);
    std::vector<Mat<dim>> F(block.particles.size());
    for (std::size_t p = 0; p < F.size(); ++p)
      F[p] = (Mat<dim>::Identity() + dt * gradient[p]) * block.particles.deformation_gradient[p];
    return (energy(velocity, F) - start) / start;
  };
  const Real dt = 4e-3;
  const Real midpoint = change(SolidTimeIntegration::midpoint, dt), euler = change(SolidTimeIntegration::implicit_euler, dt);
  const Real midpoint_half = change(SolidTimeIntegration::midpoint, dt / 2), euler_half = change(SolidTimeIntegration::implicit_euler, dt / 2);
  std::cout << "[          ] energy change of one step, dt / dt/2: midpoint " << midpoint << " / " << midpoint_half
            << ", implicit Euler " << euler << " / " << euler_half << '\n';
  EXPECT_LT(euler, -0.01);
  EXPECT_LT(euler_half, -0.005);
  EXPECT_LT(std::abs(midpoint), 1e-2 * std::abs(euler));
  EXPECT_LT(std::abs(midpoint_half), std::abs(midpoint) / 4);
}

// ---------------------------------------------------------------------------------------
template <class D>
class SolidStepTest : public ::testing::Test {};
TYPED_TEST_SUITE(SolidStepTest, testing::Dimensions);

// (c) A uniform velocity does not deform (sum_i grad w_ip = 0): the elastic energy is
// unchanged by adding one to any field, and a translating undeformed block is a solution.
TYPED_TEST(SolidStepTest, RigidTranslationCostsNoElasticEnergy) {
  constexpr int dim = TypeParam::value;
  std::mt19937 rng(31 + dim);
  Block<dim> block = make_block<dim>(3, 3, rng, random_deformation<dim>);
  const auto material = material_of<FixedCorotated<dim>>(1e5, 0.3);
  const Potential<dim> deformed(block.grid, block.particles, material, block.nodes, 1e-2);
  const Vector v = random_vector(rng, deformed.unknowns(), -1, 1);
  const Vec<dim> shift = testing::random_vector<dim>(rng, -3, 3);
  const Vector shifted = v + shift.replicate(deformed.unknowns() / dim, 1);
  EXPECT_NEAR(deformed.elastic_energy(shifted), deformed.elastic_energy(v), 1e-12 * deformed.elastic_energy(v));

  // F^n = I, v^n = a translation, no clamps: v* = v^n with zero Newton iterations.
  const Vec<dim> translation = testing::random_vector<dim>(rng, -2, 2);
  Block<dim> rest = make_block<dim>(3, 3, rng, [](std::mt19937&) { return Mat<dim>(Mat<dim>::Identity()); },
                                    translation);
  std::vector<Vec<dim>> velocity;
  const NewtonResult result =
      solid_step(rest.grid, rest.particles, material, rest.nodes, /*dt=*/1e-2, newton_options<dim>(), velocity);
  EXPECT_TRUE(result.converged) << result.summary();
  EXPECT_LE(result.iterations, 1) << result.summary();
  for (std::size_t k = 0; k < velocity.size(); ++k) {
    if (rest.nodes.mass[k] > 0) {
      EXPECT_LT((velocity[k] - translation).norm(), 1e-12 * translation.norm()) << "node " << k;
    }
  }
}

// (e) Clamped nodes are not unknowns and keep their prescribed (non-zero) velocity.
TYPED_TEST(SolidStepTest, ClampedNodesKeepTheirPrescribedVelocity) {
  constexpr int dim = TypeParam::value;
  std::mt19937 rng(5 + dim);
  Block<dim> block = make_block<dim>(3, 4, rng, random_deformation<dim>);
  for (Vec<dim>& v : block.nodes.velocity) v = testing::random_vector<dim>(rng, -0.5, 0.5);
  const Vec<dim> prescribed = testing::random_vector<dim>(rng, -1, 1);
  const int clamped = clamp_nodes_up_to<dim>(block, 3, prescribed);
  ASSERT_GT(clamped, 0);
  const auto material = material_of<NeoHookean<dim>>(1e5, 0.3);
  const Potential<dim> potential(block.grid, block.particles, material, block.nodes, 1e-2);
  EXPECT_EQ(potential.unknowns(), dim * (active_nodes(block) - clamped));

  std::vector<Vec<dim>> velocity;
  const NewtonResult result =
      solid_step(block.grid, block.particles, material, block.nodes, 1e-2, newton_options<dim>(), velocity);
  EXPECT_TRUE(result.converged) << result.summary();
  for (std::size_t k = 0; k < velocity.size(); ++k) {
    if (block.nodes.clamped[k]) {
      EXPECT_EQ(velocity[k], prescribed) << "clamped node " << k;
    }
  }

  // The clamped nodes drive the free ones: an undeformed block whose clamped side moves
  // with v^n has the rigid translation as its solution, which needs the clamped nodes'
  // velocities inside F_p(v).
  Block<dim> rest = make_block<dim>(3, 4, rng, [](std::mt19937&) { return Mat<dim>(Mat<dim>::Identity()); },
                                    prescribed);
  clamp_nodes_up_to<dim>(rest, 3, prescribed);
  const NewtonResult rigid =
      solid_step(rest.grid, rest.particles, material, rest.nodes, 1e-2, newton_options<dim>(), velocity);
  EXPECT_TRUE(rigid.converged) << rigid.summary();
  for (std::size_t k = 0; k < velocity.size(); ++k) {
    if (rest.nodes.mass[k] > 0) {
      EXPECT_LT((velocity[k] - prescribed).norm(), 1e-10 * prescribed.norm()) << "node " << k;
    }
  }
}

// (f) A block hanging from a clamped side, with v^n = dt g, converges in one large step
// (dt = 2e-2, ten times dx / c_p = 0.1 / 46 m/s, the explicit limit before its safety
// factor), lowers the energy, and the support slows the fall without reversing it. The
// step is solid_step with the simulation's options; the potential evaluates its v*.
TYPED_TEST(SolidStepTest, ClampedBlockUnderGravityConverges) {
  constexpr int dim = TypeParam::value;
  std::mt19937 rng(11 + dim);
  const Real dt = 2e-2;
  const Block<dim> block = clamped_block_under_gravity<dim>(5, rng, dt);
  const auto material = material_of<NeoHookean<dim>>(1e6, 0.4);
  const Potential<dim> potential(block.grid, block.particles, material, block.nodes, dt);
  const Real start_energy = potential.energy(potential.initial_velocity());
  std::vector<Vec<dim>> velocity;
  const NewtonResult result = solid_step(block.grid, block.particles, material, block.nodes, dt, newton_options<dim>(), velocity);
  std::cout << "[          ] " << result.summary() << '\n';
  ASSERT_TRUE(result.converged) << result.summary();
  const Vector v = unknowns_of(potential, velocity);
  ASSERT_TRUE(v.allFinite());
  EXPECT_LT(result.iterations, 20) << result.summary();
  EXPECT_LT(potential.energy(v), start_energy);
  Real mass = 0, momentum = 0;
  for (int r = 0; r < potential.unknowns() / dim; ++r) {
    mass += potential.mass_diagonal()[dim * r];
    momentum += potential.mass_diagonal()[dim * r] * v[dim * r + 1];
  }
  const Real mean_fall = momentum / mass;
  EXPECT_LT(mean_fall, 0);
  EXPECT_GT(mean_fall, -9.81 * dt);
}

// (g) Inexact Newton asks CG for the step's accuracy at once: a stiff clamped block under
// gravity (strains ~1e-4, a nearly quadratic energy) reaches its stop (here the momentum
// scale's) in at most two Newton iterations with CG directions. With
// eta_k = min(0.5, ||g_k|| / ||g_0||) each iteration only thirds, then squares, the
// gradient: 4 iterations here.
TYPED_TEST(SolidStepTest, CgNewtonTakesANearlyLinearStepInTwoIterations) {
  constexpr int dim = TypeParam::value;
  std::mt19937 rng(23 + dim);
  const Real dt = 1e-3;
  const Block<dim> block = clamped_block_under_gravity<dim>(4, rng, dt);
  const auto material = material_of<FixedCorotated<dim>>(1e7, 0.3);
  ProjectedNewtonOptions options = newton_options<dim>();
  options.direct = false;
  std::vector<Vec<dim>> velocity;
  const NewtonResult result = solid_step(block.grid, block.particles, material, block.nodes, dt, options, velocity);
  std::cout << "[          ] " << result.summary() << '\n';
  ASSERT_TRUE(result.converged) << result.summary();
  EXPECT_GT(result.tolerance, options.cg_relative_tolerance * result.gradient_norms.front()) << "not the momentum stop";
  EXPECT_LE(result.iterations, 2) << result.summary();
  EXPECT_EQ(result.cg_unfinished, 0) << result.summary();
}

// A neo-Hookean block collapsing along the first axis so fast that v^n itself would invert
// it (dt d_0 v_0^n = -1.5, F_00 = -0.5): E(v^n) is infinite, Newton starts from v = 0
// (F = F^n) and its line search rejects every inverting trial; the step converges with
// det F_p(v*) > 0. The step is solid_step with the simulation's options; the potential
// evaluates its start and its v*.
TYPED_TEST(SolidStepTest, NeoHookeanStepRejectsInvertingTrials) {
  constexpr int dim = TypeParam::value;
  std::mt19937 rng(17 + dim);
  const Real dt = 1e-2;
  Block<dim> block = make_block<dim>(3, 3, rng, [](std::mt19937&) { return Mat<dim>(Mat<dim>::Identity()); });
  const GridLayout<dim> layout = block.grid.nodes();
  const Vec<dim> centre = Vec<dim>::Constant(0.45);
  for (int k = 0; k < layout.size(); ++k)
    block.nodes.velocity[k][0] = -(1.5 / dt) * (block.grid.dual_cell_centre(layout.multi_index(k))[0] - centre[0]);
  const auto material = material_of<NeoHookean<dim>>(1e5, 0.3);
  const Potential<dim> potential(block.grid, block.particles, material, block.nodes, dt);
  ASSERT_FALSE(std::isfinite(potential.energy(potential.initial_velocity())))
      << "test case too weak: v^n does not invert the block";
  std::vector<Vec<dim>> velocity;
  const NewtonResult result = solid_step(block.grid, block.particles, material, block.nodes, dt, newton_options<dim>(), velocity);
  const Vector v = unknowns_of(potential, velocity);
  std::cout << "[          ] " << result.summary() << '\n';
  EXPECT_TRUE(result.started_from_zero);
  ASSERT_TRUE(result.converged) << result.summary();
  for (int p = 0; p < potential.particle_count(); ++p)
    EXPECT_GT(potential.deformation_gradient(p, v).determinant(), 0) << "particle " << p;
}

// The line search on its own: E(x) = x - log x (minimum at 1, +inf for x <= 0) from x = 4,
// where the full Newton step lands at x = -8. The trial must be rejected and halved.
struct BarrierPotential {
  using SparseMatrix = Eigen::SparseMatrix<Real, Eigen::RowMajor, int>;
  Real energy(const Vector& x) const {
    return x[0] > 0 ? x[0] - std::log(x[0]) : std::numeric_limits<Real>::infinity();
  }
  Vector gradient(const Vector& x) const { return Vector::Constant(1, 1 - 1 / x[0]); }
  SparseMatrix hessian(const Vector& x, bool) const {
    SparseMatrix H(1, 1);
    H.insert(0, 0) = 1 / (x[0] * x[0]);
    return H;
  }
  Real gradient_scale() const { return 1; }
};

TEST(ProjectedNewton, LineSearchRejectsNonFiniteTrials) {
  Vector x = Vector::Constant(1, 4);
  const NewtonResult result = minimize_projected_newton(BarrierPotential{}, x, ProjectedNewtonOptions{});
  EXPECT_TRUE(result.converged) << result.summary();
  EXPECT_GT(result.backtracks, 0) << result.summary();
  EXPECT_NEAR(x[0], 1, 1e-5);
  for (std::size_t k = 1; k < result.energies.size(); ++k)
    EXPECT_LE(result.energies[k], result.energies[k - 1]) << "energy increased at iteration " << k;
}

// A gradient with a round-off floor: E = C + x^2 / 2 + f |x| with a large constant C, so
// that the energy cannot tell the iterates apart (its round-off, 1e-8, exceeds f^2), and
// g = x + f sign(x): the Newton step of the smooth part overshoots to -f sign(x) and the
// iterates flip between +-f with |g| = 2f, as the elastic gate's Newton did at dt = 1e-4 s.
// Just above the direct stop (within stall_factor) that counts as converged, flagged as the
// round-off floor, with either direction: a CG stop far below the floor does not make the
// step fail. Far above the direct stop it does not count.
struct FlooredPotential {
  using SparseMatrix = Eigen::SparseMatrix<Real, Eigen::RowMajor, int>;
  Real floor = 1.5e-9;
  Real energy(const Vector& x) const { return 1e8 + 0.5 * x.squaredNorm() + floor * x.cwiseAbs().sum(); }
  Vector gradient(const Vector& x) const {
    Vector g = x;
    for (int i = 0; i < x.size(); ++i) g[i] += x[i] >= 0 ? floor : -floor;
    return g;
  }
  SparseMatrix hessian(const Vector& x, bool) const {
    SparseMatrix H(x.size(), x.size());
    for (int i = 0; i < x.size(); ++i) H.insert(i, i) = 1;
    return H;
  }
  Real gradient_scale() const { return 1; }
};

TEST(ProjectedNewton, StopsAtTheRoundoffFloorJustAboveTheTolerance) {
  for (const bool direct : {true, false}) {
    SCOPED_TRACE(direct ? "direct" : "CG");
    ProjectedNewtonOptions options;
    options.direct = direct;
    options.absolute_tolerance = 0;
    options.relative_tolerance = 2.4e-9;     // |g_0| = 1: direct stop 2.4e-9, |g| stuck at 3e-9
    options.cg_relative_tolerance = 1e-11;   // the floor is 300 times the CG stop
    Vector x = Vector::Constant(1, 1 - 1.5e-9);
    const NewtonResult near = minimize_projected_newton(FlooredPotential{}, x, options);
    EXPECT_TRUE(near.converged) << near.summary();
    EXPECT_TRUE(near.roundoff_floor);
    EXPECT_LT(near.iterations, 5);
    options.relative_tolerance = 1e-12;  // the floor is 3000 times the direct stop (below the CG stop here): not converged
    x = Vector::Constant(1, 1 - 1.5e-9);
    const NewtonResult far = minimize_projected_newton(FlooredPotential{}, x, options);
    EXPECT_FALSE(far.converged) << far.summary();
  }
}

}  // namespace
}  // namespace iqmpm
