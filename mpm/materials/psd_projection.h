// dP/dF of an isotropic hyperelastic energy, assembled from its eigensystem in the SVD
// frame, with the optional per-particle PSD projection of method.md §3 step 2.
//
// For Psi(F) = psi(sigma) with F = U diag(sigma) V^T (rotation-variant SVD, svd.h),
// P = U diag(dpsi/dsigma) V^T and dP/dF (a dim^2 x dim^2 symmetric matrix, vec ordering
// of types.h) has the orthonormal eigen-basis vec(U B V^T) with (Teran et al. 2005;
// Smith et al. 2019, "Analytic eigensystems for isotropic distortion energies"):
//   * the dim "stretch" modes B = diag(q), q an eigenvector of the principal Hessian
//     H_kl = d^2 psi / dsigma_k dsigma_l, with H's eigenvalue;
//   * for every pair i < j the "flip" mode B = (e_i e_j^T + e_j e_i^T) / sqrt(2) with
//     eigenvalue flip_ij = (psi_i - psi_j) / (sigma_i - sigma_j), and the "twist" mode
//     B = (e_i e_j^T - e_j e_i^T) / sqrt(2) with eigenvalue
//     twist_ij = (psi_i + psi_j) / (sigma_i + sigma_j), where psi_i = dpsi/dsigma_i.
// These dim + dim (dim - 1) = dim^2 modes are orthonormal in the Frobenius product and
// U, V are orthogonal, so clamping H's eigenvalues and the flip/twist scalars at 0 is
// exactly the nearest-PSD (Frobenius) projection of the full dP/dF -- the same matrix as a
// dim^2 x dim^2 symmetric eigen-decomposition with clamped eigenvalues, at the cost of a
// dim x dim eigensolve. The test suite checks this against that brute-force oracle.
//
// Each material supplies H, flip and twist in closed form: flip_ij is a divided
// difference that must be simplified analytically so it stays finite as
// sigma_i -> sigma_j (repeated singular values are common, e.g. F = I).
#pragma once

#include "core/types.h"
#include "materials/svd.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <array>
#include <cmath>
#include <utility>

namespace iqmpm {

template <int dim>
struct PrincipalStiffness {
  static constexpr int pair_count = dim * (dim - 1) / 2;
  Mat<dim> hessian;                    // d^2 psi / dsigma_k dsigma_l
  std::array<Real, pair_count> flip;   // (psi_i - psi_j) / (sigma_i - sigma_j), pairs below
  std::array<Real, pair_count> twist;  // (psi_i + psi_j) / (sigma_i + sigma_j), pairs below
};

// The singular-value index pairs (i, j), i < j, in the order used by PrincipalStiffness.
template <int dim>
constexpr std::array<std::pair<int, int>, PrincipalStiffness<dim>::pair_count>
singular_value_pairs() {
  static_assert(dim == 2 || dim == 3, "dim must be 2 or 3");
  if constexpr (dim == 2) {
    return {{{0, 1}}};
  } else {
    return {{{0, 1}, {0, 2}, {1, 2}}};
  }
}

// Keeps a twist denominator sigma_i + sigma_j away from 0 (it vanishes only for an
// inverted F with |sigma_last| = sigma_i, where the polar rotation is not unique and the
// exact Hessian is unbounded); keeps the sign so the formula stays continuous otherwise.
inline Real guarded_sigma_sum(Real sum) {
  constexpr Real floor = 1e-6;
  return std::abs(sum) >= floor ? sum : std::copysign(floor, sum);
}

template <int dim>
TensorMat<dim> isotropic_first_piola_derivative(const RotationVariantSvd<dim>& svd,
                                                PrincipalStiffness<dim> stiffness,
                                                bool project_to_psd) {
  using VecF = Eigen::Matrix<Real, dim * dim, 1>;
  const Mat<dim>& U = svd.U;
  const Mat<dim>& V = svd.V;
  // vec(u_i v_j^T), column-major like vec(F).
  const auto outer_vec = [&](int i, int j) -> VecF {
    const Mat<dim> m = U.col(i) * V.col(j).transpose();
    return Eigen::Map<const VecF>(m.data());
  };

  if (project_to_psd) {
    const Eigen::SelfAdjointEigenSolver<Mat<dim>> eigen(stiffness.hessian);
    const Vec<dim> clamped = eigen.eigenvalues().cwiseMax(Real(0));
    stiffness.hessian = eigen.eigenvectors() * clamped.asDiagonal() *
                        eigen.eigenvectors().transpose();
    for (int p = 0; p < PrincipalStiffness<dim>::pair_count; ++p) {
      stiffness.flip[p] = std::max(stiffness.flip[p], Real(0));
      stiffness.twist[p] = std::max(stiffness.twist[p], Real(0));
    }
  }

  TensorMat<dim> dPdF = TensorMat<dim>::Zero();
  std::array<VecF, dim> stretch_modes;
  for (int k = 0; k < dim; ++k) stretch_modes[k] = outer_vec(k, k);
  for (int k = 0; k < dim; ++k)
    for (int l = 0; l < dim; ++l)
      dPdF.noalias() += stiffness.hessian(k, l) * stretch_modes[k] * stretch_modes[l].transpose();

  const Real inv_sqrt2 = 1 / std::sqrt(Real(2));
  const auto pairs = singular_value_pairs<dim>();
  for (int p = 0; p < PrincipalStiffness<dim>::pair_count; ++p) {
    const auto [i, j] = pairs[p];
    const VecF ij = outer_vec(i, j);
    const VecF ji = outer_vec(j, i);
    const VecF flip_mode = inv_sqrt2 * (ij + ji);
    const VecF twist_mode = inv_sqrt2 * (ij - ji);
    dPdF.noalias() += stiffness.flip[p] * flip_mode * flip_mode.transpose();
    dPdF.noalias() += stiffness.twist[p] * twist_mode * twist_mode.transpose();
  }
  return dPdF;
}

}  // namespace iqmpm
