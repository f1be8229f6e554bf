// Contract tests for the hyperelastic materials (method.md §1, §3 step 2): one typed
// suite runs every check on every model in 2-D and 3-D. A second, small typed suite
// checks the rotation-variant SVD they are built on.
#include "core/types.h"
#include "materials/fixed_corotated.h"
#include "materials/lame.h"
#include "materials/neo_hookean.h"
#include "materials/svd.h"

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <random>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <vector>

namespace iqmpm {
namespace {

constexpr Real pi = 3.14159265358979323846;

// ---------------------------------------------------------------------------------------
// Deterministic sampling (own uniform from mt19937_64 bits: same numbers on every
// standard library).
class Sampler {
 public:
  explicit Sampler(std::uint64_t seed) : engine_(seed) {}
  Real uniform(Real lo, Real hi) {
    const Real unit = static_cast<Real>(engine_() >> 11) * 0x1.0p-53;
    return lo + (hi - lo) * unit;
  }
  template <int dim>
  Mat<dim> matrix(Real lo, Real hi) {
    Mat<dim> m;
    for (int k = 0; k < dim * dim; ++k) m.data()[k] = uniform(lo, hi);
    return m;
  }
  template <int dim>
  Mat<dim> rotation() {
    if constexpr (dim == 2) {
      return Eigen::Rotation2D<Real>(uniform(-pi, pi)).toRotationMatrix();
    } else {
      Eigen::Quaternion<Real> q(uniform(-1, 1), uniform(-1, 1), uniform(-1, 1), uniform(-1, 1));
      return q.normalized().toRotationMatrix();
    }
  }

 private:
  std::mt19937_64 engine_;
};

template <int dim>
Vec<dim> principal(Real a, Real b, Real c) {
  Vec<dim> v;
  if constexpr (dim == 2) {
    v << a, b;
  } else {
    v << a, b, c;
  }
  return v;
}

template <class Material>
struct MaterialInfo;
template <int d>
struct MaterialInfo<FixedCorotated<d>> {
  static constexpr int dim = d;
  static constexpr bool defined_when_inverted = true;
  static std::string name() { return "FixedCorotated" + std::to_string(d); }
};
template <int d>
struct MaterialInfo<NeoHookean<d>> {
  static constexpr int dim = d;
  static constexpr bool defined_when_inverted = false;
  static std::string name() { return "NeoHookean" + std::to_string(d); }
};

struct NamedDeformation {
  std::string name;
  std::vector<Real> entries;  // column-major, dim * dim
};

template <int dim>
Mat<dim> to_matrix(const NamedDeformation& sample) {
  return Eigen::Map<const Mat<dim>>(sample.entries.data());
}

// The deformations every derivative check runs on: near identity, a strong
// stretch + shear, repeated singular values (degenerate SVD), strong compression, and
// for models defined there, an inverted F.
template <class Material>
std::vector<NamedDeformation> sample_deformations(std::uint64_t seed) {
  constexpr int dim = MaterialInfo<Material>::dim;
  Sampler sampler(seed);
  std::vector<NamedDeformation> samples;
  const auto add = [&](const std::string& name, const Mat<dim>& F) {
    samples.push_back({name, std::vector<Real>(F.data(), F.data() + dim * dim)});
  };
  add("near identity", Mat<dim>::Identity() + sampler.matrix<dim>(-0.15, 0.15));
  add("stretched and sheared", sampler.rotation<dim>() *
                                   principal<dim>(1.6, 0.7, 1.25).asDiagonal() *
                                   sampler.rotation<dim>());
  Mat<dim> shear = Mat<dim>::Identity();
  shear(0, dim - 1) = 0.6;
  add("simple shear", shear * principal<dim>(1.3, 0.85, 1.1).asDiagonal());
  add("repeated singular values", sampler.rotation<dim>() *
                                      principal<dim>(1.2, 1.2, 0.9).asDiagonal() *
                                      sampler.rotation<dim>());
  add("compressed", sampler.rotation<dim>() * principal<dim>(0.6, 0.45, 0.5).asDiagonal() *
                        sampler.rotation<dim>());
  if constexpr (MaterialInfo<Material>::defined_when_inverted) {
    add("inverted", sampler.rotation<dim>() * principal<dim>(1.1, 0.9, -0.3).asDiagonal() *
                        sampler.rotation<dim>());
  }
  return samples;
}

template <class Material>
Material test_material() {
  return Material::from_young_poisson(/*E=*/2.0e3, /*nu=*/0.35);
}

template <class Material>
Real stiffness_scale(const Material& material) {
  return 2 * material.mu + material.lambda;
}

template <int dim>
Real min_eigenvalue(const TensorMat<dim>& A) {
  return Eigen::SelfAdjointEigenSolver<TensorMat<dim>>(A, Eigen::EigenvaluesOnly)
      .eigenvalues()
      .minCoeff();
}

// Brute-force oracle: full dim^2 x dim^2 eigen-decomposition, negative eigenvalues -> 0.
template <int dim>
TensorMat<dim> clamp_eigenvalues(const TensorMat<dim>& A) {
  const Eigen::SelfAdjointEigenSolver<TensorMat<dim>> eigen(A);
  return eigen.eigenvectors() * eigen.eigenvalues().cwiseMax(Real(0)).asDiagonal() *
         eigen.eigenvectors().transpose();
}

template <class A, class B>
Real relative_error(const A& approx, const B& exact) {
  return (approx - exact).norm() / exact.norm();
}

// ---------------------------------------------------------------------------------------
template <class Material>
class MaterialContract : public ::testing::Test {};

using AllMaterials =
    ::testing::Types<FixedCorotated<2>, FixedCorotated<3>, NeoHookean<2>, NeoHookean<3>>;

struct MaterialNames {
  template <class Material>
  static std::string GetName(int) {
    return MaterialInfo<Material>::name();
  }
};
TYPED_TEST_SUITE(MaterialContract, AllMaterials, MaterialNames);

// (a) P = dPsi/dF, by central differences of the energy.
TYPED_TEST(MaterialContract, FirstPiolaMatchesEnergyFiniteDifference) {
  constexpr int dim = MaterialInfo<TypeParam>::dim;
  const TypeParam material = test_material<TypeParam>();
  const Real h = 1e-6;
  for (const NamedDeformation& sample : sample_deformations<TypeParam>(11)) {
    SCOPED_TRACE(sample.name);
    const Mat<dim> F = to_matrix<dim>(sample);
    Mat<dim> P_fd;
    for (int k = 0; k < dim * dim; ++k) {
      Mat<dim> F_plus = F, F_minus = F;
      F_plus.data()[k] += h;
      F_minus.data()[k] -= h;
      P_fd.data()[k] =
          (material.energy_density(F_plus) - material.energy_density(F_minus)) / (2 * h);
    }
    const Mat<dim> P = material.first_piola(F);
    EXPECT_LT(relative_error(P_fd, P), 1e-6)
        << "relative error |P_fd - P| / |P| must be < 1e-6\nP =\n" << P << "\nP_fd =\n" << P_fd;
  }
}

// (b) dP/dF (unprojected) = d(vec P)/d(vec F), by central differences of P.
TYPED_TEST(MaterialContract, FirstPiolaDerivativeMatchesStressFiniteDifference) {
  constexpr int dim = MaterialInfo<TypeParam>::dim;
  const TypeParam material = test_material<TypeParam>();
  const Real h = 1e-6;
  std::vector<NamedDeformation> samples = sample_deformations<TypeParam>(12);
  samples.push_back({"identity", {}});
  for (const NamedDeformation& sample : samples) {
    SCOPED_TRACE(sample.name);
    const Mat<dim> F = sample.entries.empty() ? Mat<dim>::Identity() : to_matrix<dim>(sample);
    TensorMat<dim> dPdF_fd;
    for (int k = 0; k < dim * dim; ++k) {
      Mat<dim> F_plus = F, F_minus = F;
      F_plus.data()[k] += h;
      F_minus.data()[k] -= h;
      const Mat<dim> dP = (material.first_piola(F_plus) - material.first_piola(F_minus)) / (2 * h);
      dPdF_fd.col(k) = Eigen::Map<const Eigen::Matrix<Real, dim * dim, 1>>(dP.data());
    }
    const TensorMat<dim> dPdF = material.first_piola_derivative(F, /*project_to_psd=*/false);
    EXPECT_LT(relative_error(dPdF_fd, dPdF), 1e-6)
        << "relative error |dPdF_fd - dPdF| / |dPdF| must be < 1e-6\ndPdF =\n"
        << dPdF << "\ndPdF_fd =\n" << dPdF_fd;
  }
}

// (c) The projected derivative is symmetric PSD, equals the brute-force clamp of the
// full eigen-decomposition, and the projection actually bites on some samples.
TYPED_TEST(MaterialContract, ProjectedDerivativeIsSymmetricPsdAndExact) {
  constexpr int dim = MaterialInfo<TypeParam>::dim;
  const TypeParam material = test_material<TypeParam>();
  Sampler sampler(13);
  // Fixed-corotated: principal stretches down to strongly compressed and inverted;
  // neo-Hookean: the same but J > 0.
  const Real lowest = MaterialInfo<TypeParam>::defined_when_inverted ? -0.6 : 0.15;
  int indefinite_samples = 0;
  for (int trial = 0; trial < 200; ++trial) {
    Vec<dim> stretches;
    for (int k = 0; k < dim; ++k) stretches(k) = sampler.uniform(lowest, 1.8);
    if constexpr (!MaterialInfo<TypeParam>::defined_when_inverted) {
      stretches = stretches.cwiseAbs();
    }
    const Mat<dim> F = sampler.rotation<dim>() * stretches.asDiagonal() * sampler.rotation<dim>();
    SCOPED_TRACE("trial " + std::to_string(trial));
    const TensorMat<dim> exact = material.first_piola_derivative(F, false);
    const TensorMat<dim> projected = material.first_piola_derivative(F, true);
    const Real scale = std::max(exact.norm(), stiffness_scale(material));

    EXPECT_LE((exact - exact.transpose()).norm(), 1e-12 * scale) << "dP/dF must be symmetric";
    EXPECT_LE((projected - projected.transpose()).norm(), 1e-12 * scale);
    EXPECT_GE(min_eigenvalue<dim>(projected), -1e-8 * scale)
        << "projected dP/dF must be PSD (min eigenvalue >= -1e-8 * scale)";
    EXPECT_LE((projected - clamp_eigenvalues<dim>(exact)).norm(), 1e-9 * scale)
        << "analytic projection must equal the clamped full eigen-decomposition";
    if (min_eigenvalue<dim>(exact) < -1e-6 * scale) ++indefinite_samples;
  }
  EXPECT_GT(indefinite_samples, 0) << "no sample exercised the projection";
}

TYPED_TEST(MaterialContract, ProjectionLeavesPsdDerivativeUnchanged) {
  constexpr int dim = MaterialInfo<TypeParam>::dim;
  const TypeParam material = test_material<TypeParam>();
  Sampler sampler(14);
  const Mat<dim> R = sampler.rotation<dim>();
  const Mat<dim> stretched =
      R * principal<dim>(1.15, 1.05, 1.1).asDiagonal() * sampler.rotation<dim>();
  for (const Mat<dim>& F : {Mat<dim>(Mat<dim>::Identity()), R, stretched}) {
    const TensorMat<dim> exact = material.first_piola_derivative(F, false);
    const Real scale = stiffness_scale(material);
    ASSERT_GE(min_eigenvalue<dim>(exact), -1e-10 * scale) << "precondition: already PSD at\n" << F;
    EXPECT_LE((material.first_piola_derivative(F, true) - exact).norm(), 1e-10 * scale)
        << "projection changed an already-PSD derivative at F =\n" << F;
  }
}

// (d) A rigid rotation stores no energy and carries no stress.
TYPED_TEST(MaterialContract, RigidRotationIsStressFree) {
  constexpr int dim = MaterialInfo<TypeParam>::dim;
  const TypeParam material = test_material<TypeParam>();
  const Real scale = stiffness_scale(material);
  Sampler sampler(15);
  for (int trial = 0; trial < 20; ++trial) {
    const Mat<dim> R = sampler.rotation<dim>();
    EXPECT_NEAR(material.energy_density(R), 0, 1e-12 * scale);
    EXPECT_LE(material.first_piola(R).norm(), 1e-12 * scale) << "R =\n" << R;
  }
}

// (e) Small-strain limit: P(I + eps) = 2 mu eps + lambda tr(eps) I + O(|eps|^2), and the
// remainder really is second order (ratio of errors under halving ~ 4).
TYPED_TEST(MaterialContract, SmallStrainLimitIsLinearElasticity) {
  constexpr int dim = MaterialInfo<TypeParam>::dim;
  const TypeParam material = test_material<TypeParam>();
  Sampler sampler(16);
  const Mat<dim> A = sampler.matrix<dim>(-1, 1);
  const Mat<dim> direction = (A + A.transpose()) / 2;
  std::vector<Real> errors;
  for (const Real eps : {1e-2, 5e-3, 2.5e-3, 1.25e-3}) {
    const Mat<dim> strain = eps * direction;
    const Mat<dim> linear = 2 * material.mu * strain +
                            material.lambda * strain.trace() * Mat<dim>::Identity();
    const Real error = (material.first_piola(Mat<dim>::Identity() + strain) - linear).norm();
    EXPECT_LE(error, 10 * stiffness_scale(material) * strain.squaredNorm())
        << "eps = " << eps << ": remainder must be O(eps^2)";
    errors.push_back(error);
  }
  for (std::size_t k = 1; k < errors.size(); ++k) {
    const Real order = std::log2(errors[k - 1] / errors[k]);
    EXPECT_NEAR(order, 2.0, 0.1) << "observed order of the small-strain remainder";
  }
}

// (f) Parameter validation, and the Lame parameters reproduce E and nu.
TYPED_TEST(MaterialContract, FromYoungPoissonValidatesAndConverts) {
  const auto expect_rejected = [](Real E, Real nu, const std::string& named) {
    try {
      TypeParam::from_young_poisson(E, nu);
      ADD_FAILURE() << "E = " << E << ", nu = " << nu << " was accepted";
    } catch (const std::invalid_argument& error) {
      EXPECT_NE(std::string(error.what()).find(named), std::string::npos)
          << "message \"" << error.what() << "\" should name " << named;
    }
  };
  const Real nan = std::numeric_limits<Real>::quiet_NaN();
  for (const Real nu : {0.5, 0.7, -1.0, -1.5, nan}) expect_rejected(1e3, nu, "Poisson ratio nu");
  for (const Real E : {0.0, -5.0, nan, std::numeric_limits<Real>::infinity()})
    expect_rejected(E, 0.3, "Young's modulus E");

  for (const Real nu : {-0.5, 0.0, 0.3, 0.49}) {
    const Real E = 3.0e4;
    const TypeParam material = TypeParam::from_young_poisson(E, nu);
    const Real mu = material.mu, lambda = material.lambda;
    EXPECT_NEAR(mu * (3 * lambda + 2 * mu) / (lambda + mu), E, 1e-10 * E);
    EXPECT_NEAR(lambda / (2 * (lambda + mu)), nu, 1e-12);
  }
}

// Behaviour under inversion: fixed-corotated is finite and resists; neo-Hookean's energy
// is +infinity so that a line search rejects the state.
TYPED_TEST(MaterialContract, InversionHandling) {
  constexpr int dim = MaterialInfo<TypeParam>::dim;
  const TypeParam material = test_material<TypeParam>();
  Mat<dim> flat = Mat<dim>::Identity();
  flat(dim - 1, dim - 1) = 0;
  Mat<dim> inverted = Mat<dim>::Identity();
  inverted(dim - 1, dim - 1) = -0.2;
  if constexpr (MaterialInfo<TypeParam>::defined_when_inverted) {
    EXPECT_TRUE(std::isfinite(material.energy_density(flat)));
    EXPECT_GT(material.energy_density(inverted), material.energy_density(flat));
    // The volume term pushes the inverted direction back: P_dd < 0 drives sigma_d up.
    EXPECT_LT(material.first_piola(inverted)(dim - 1, dim - 1), 0);
  } else {
    const Real infinity = std::numeric_limits<Real>::infinity();
    EXPECT_EQ(material.energy_density(flat), infinity);
    EXPECT_EQ(material.energy_density(inverted), infinity);
    Mat<dim> nearly_flat = flat;
    nearly_flat(dim - 1, dim - 1) = 1e-8;
    EXPECT_GT(material.energy_density(nearly_flat), 10 * stiffness_scale(material))
        << "energy must blow up as J -> 0+";
  }
}

// ---------------------------------------------------------------------------------------
template <class Dim>
class RotationVariantSvdTest : public ::testing::Test {};
using Dims = ::testing::Types<std::integral_constant<int, 2>, std::integral_constant<int, 3>>;
TYPED_TEST_SUITE(RotationVariantSvdTest, Dims);

TYPED_TEST(RotationVariantSvdTest, ReconstructsWithProperRotationsAndSignedLastValue) {
  constexpr int dim = TypeParam::value;
  Sampler sampler(17);
  for (int trial = 0; trial < 100; ++trial) {
    const Mat<dim> F = sampler.matrix<dim>(-2, 2);
    const RotationVariantSvd<dim> svd = rotation_variant_svd<dim>(F);
    const Real scale = F.norm();
    EXPECT_LE((svd.U * svd.sigma.asDiagonal() * svd.V.transpose() - F).norm(), 1e-13 * scale);
    EXPECT_NEAR(svd.U.determinant(), 1, 1e-13);
    EXPECT_NEAR(svd.V.determinant(), 1, 1e-13);
    EXPECT_LE((svd.U.transpose() * svd.U - Mat<dim>::Identity()).norm(), 1e-13);
    EXPECT_LE((svd.V.transpose() * svd.V - Mat<dim>::Identity()).norm(), 1e-13);
    for (int k = 0; k + 1 < dim; ++k) {
      EXPECT_GE(svd.sigma(k), std::abs(svd.sigma(k + 1)));
    }
    EXPECT_EQ(std::signbit(svd.sigma(dim - 1)), F.determinant() < 0);
  }
}

}  // namespace
}  // namespace iqmpm
