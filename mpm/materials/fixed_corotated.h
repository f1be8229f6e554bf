// Fixed-corotated elasticity (Stomakhin et al. 2012), one of the solid models of
// method.md §1:  Psi(F) = mu |F - R|^2 + lambda/2 (J - 1)^2
//                       = mu sum_i (sigma_i - 1)^2 + lambda/2 (J - 1)^2,
// R the polar rotation of F, sigma the rotation-variant singular values (svd.h), J = det F.
// Defined, smooth and finite for inverted F (J <= 0): the volume term pushes back.
#pragma once

#include "core/types.h"
#include "materials/lame.h"
#include "materials/psd_projection.h"
#include "materials/svd.h"

namespace iqmpm {

template <int dim>
struct FixedCorotated {
  static_assert(dim == 2 || dim == 3, "dim must be 2 or 3");
  Real mu = 0;
  Real lambda = 0;

  static FixedCorotated from_young_poisson(Real E, Real nu) {
    const LameParameters lame = lame_from_young_poisson(E, nu);
    return {lame.mu, lame.lambda};
  }

  Real energy_density(const Mat<dim>& F) const { return energy_density(rotation_variant_svd<dim>(F)); }
  Real energy_density(const RotationVariantSvd<dim>& svd) const {
    const Vec<dim>& sigma = svd.sigma;
    const Real J = sigma.prod();
    return mu * (sigma.array() - 1).square().sum() + lambda / 2 * (J - 1) * (J - 1);
  }

  // P = 2 mu (F - R) + lambda (J - 1) J F^{-T}, written as U diag(dpsi/dsigma) V^T.
  Mat<dim> first_piola(const Mat<dim>& F) const { return first_piola(rotation_variant_svd<dim>(F)); }
  Mat<dim> first_piola(const RotationVariantSvd<dim>& svd) const {
    return svd.U * principal_gradient(svd.sigma).asDiagonal() * svd.V.transpose();
  }

  TensorMat<dim> first_piola_derivative(const Mat<dim>& F, bool project_to_psd) const {
    return first_piola_derivative(rotation_variant_svd<dim>(F), project_to_psd);
  }
  TensorMat<dim> first_piola_derivative(const RotationVariantSvd<dim>& svd, bool project_to_psd) const {
    return isotropic_first_piola_derivative<dim>(svd, principal_stiffness(svd.sigma), project_to_psd);
  }

  // psi_i = 2 mu (sigma_i - 1) + lambda (J - 1) J_i, with J_i = dJ/dsigma_i = prod_{k != i} sigma_k.
  Vec<dim> principal_gradient(const Vec<dim>& sigma) const {
    const Real J = sigma.prod();
    Vec<dim> gradient;
    for (int i = 0; i < dim; ++i)
      gradient(i) = 2 * mu * (sigma(i) - 1) + lambda * (J - 1) * cofactor_product(sigma, i);
    return gradient;
  }

  // H_ii = 2 mu + lambda J_i^2;  H_ij = lambda J_i J_j + lambda (J - 1) c_ij, with
  // c_ij = d^2 J / dsigma_i dsigma_j (1 in 2-D, the remaining sigma_k in 3-D).
  // flip_ij  = 2 mu - lambda (J - 1) c_ij                       (divided difference, exact)
  // twist_ij = 2 mu - 4 mu / (sigma_i + sigma_j) + lambda (J - 1) c_ij
  PrincipalStiffness<dim> principal_stiffness(const Vec<dim>& sigma) const {
    const Real J = sigma.prod();
    Vec<dim> J_i;
    for (int i = 0; i < dim; ++i) J_i(i) = cofactor_product(sigma, i);
    PrincipalStiffness<dim> stiffness;
    stiffness.hessian = lambda * J_i * J_i.transpose();
    stiffness.hessian.diagonal().array() += 2 * mu;
    const auto pairs = singular_value_pairs<dim>();
    for (int p = 0; p < PrincipalStiffness<dim>::pair_count; ++p) {
      const auto [i, j] = pairs[p];
      const Real c_ij = dim == 2 ? Real(1) : sigma(3 - i - j);
      stiffness.hessian(i, j) += lambda * (J - 1) * c_ij;
      stiffness.hessian(j, i) += lambda * (J - 1) * c_ij;
      stiffness.flip[p] = 2 * mu - lambda * (J - 1) * c_ij;
      stiffness.twist[p] =
          2 * mu - 4 * mu / guarded_sigma_sum(sigma(i) + sigma(j)) + lambda * (J - 1) * c_ij;
    }
    return stiffness;
  }

 private:
  // prod_{k != i} sigma_k, computed without dividing by sigma_i (which may be 0).
  static Real cofactor_product(const Vec<dim>& sigma, int i) {
    Real product = 1;
    for (int k = 0; k < dim; ++k)
      if (k != i) product *= sigma(k);
    return product;
  }
};

}  // namespace iqmpm
