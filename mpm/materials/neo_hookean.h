// Compressible neo-Hookean elasticity, one of the solid models of method.md §1:
//   Psi(F) = mu/2 (tr(F^T F) - dim) - mu log J + lambda/2 (log J)^2,   J = det F.
//
// Inversion: Psi is only defined for J > 0 and grows without bound as J -> 0+.
// energy_density returns +infinity for J <= 0 (and for non-finite F), so the backtracking
// line search of method.md §3 step 2 rejects any trial state that inverts a particle
// and keeps halving the step. first_piola and first_piola_derivative require J > 0
// (debug assert); they are only evaluated at accepted states, and without the assert
// they would return NaN / inf entries, never a plausible-looking wrong force.
#pragma once

#include "core/types.h"
#include "materials/lame.h"
#include "materials/psd_projection.h"
#include "materials/svd.h"

#include <Eigen/LU>
#include <cassert>
#include <cmath>
#include <limits>

namespace iqmpm {

template <int dim>
struct NeoHookean {
  static_assert(dim == 2 || dim == 3, "dim must be 2 or 3");
  Real mu = 0;
  Real lambda = 0;

  static NeoHookean from_young_poisson(Real E, Real nu) {
    const LameParameters lame = lame_from_young_poisson(E, nu);
    return {lame.mu, lame.lambda};
  }

  Real energy_density(const Mat<dim>& F) const {
    const Real J = F.determinant();
    if (!(J > 0) || !F.allFinite()) return std::numeric_limits<Real>::infinity();
    const Real log_J = std::log(J);
    return mu / 2 * (F.squaredNorm() - dim) - mu * log_J + lambda / 2 * log_J * log_J;
  }

  // P = mu F + (lambda log J - mu) F^{-T}.
  Mat<dim> first_piola(const Mat<dim>& F) const {
    const Real J = F.determinant();
    assert(J > 0 && "NeoHookean::first_piola needs det F > 0");
    const Mat<dim> F_inv_T = F.inverse().transpose();
    return mu * F + (lambda * std::log(J) - mu) * F_inv_T;
  }

  TensorMat<dim> first_piola_derivative(const Mat<dim>& F, bool project_to_psd) const {
    assert(F.determinant() > 0 && "NeoHookean::first_piola_derivative needs det F > 0");
    return first_piola_derivative(rotation_variant_svd<dim>(F), project_to_psd);
  }
  TensorMat<dim> first_piola_derivative(const RotationVariantSvd<dim>& svd, bool project_to_psd) const {
    return isotropic_first_piola_derivative<dim>(svd, principal_stiffness(svd.sigma), project_to_psd);
  }

  // psi_i = mu sigma_i + (lambda log J - mu) / sigma_i.
  Vec<dim> principal_gradient(const Vec<dim>& sigma) const {
    const Real log_J = std::log(sigma.prod());
    return mu * sigma.array() + (lambda * log_J - mu) / sigma.array();
  }

  // H_ii = mu + (mu + lambda (1 - log J)) / sigma_i^2;  H_ij = lambda / (sigma_i sigma_j);
  // flip_ij  = mu + (mu - lambda log J) / (sigma_i sigma_j)   (divided difference, exact);
  // twist_ij = mu - (mu - lambda log J) / (sigma_i sigma_j).
  PrincipalStiffness<dim> principal_stiffness(const Vec<dim>& sigma) const {
    const Real log_J = std::log(sigma.prod());
    const Vec<dim> inv_sigma = sigma.cwiseInverse();
    PrincipalStiffness<dim> stiffness;
    stiffness.hessian = lambda * inv_sigma * inv_sigma.transpose();
    stiffness.hessian.diagonal() +=
        (mu + (mu - lambda * log_J) * inv_sigma.array().square()).matrix();
    const auto pairs = singular_value_pairs<dim>();
    for (int p = 0; p < PrincipalStiffness<dim>::pair_count; ++p) {
      const auto [i, j] = pairs[p];
      const Real restoring = (mu - lambda * log_J) * inv_sigma(i) * inv_sigma(j);
      stiffness.flip[p] = mu + restoring;
      stiffness.twist[p] = mu - restoring;
    }
    return stiffness;
  }
};

}  // namespace iqmpm
