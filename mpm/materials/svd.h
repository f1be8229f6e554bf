// Rotation-variant SVD F = U diag(sigma) V^T with U, V proper rotations (det = +1).
// Isotropic energies are functions of sigma; keeping U, V in SO(dim) and putting the
// sign of det F on the last (smallest-magnitude) singular value makes the energy and
// its derivatives continuous through inversion (Irving et al. 2004, Stomakhin et al.
// 2012). Used by the materials of method.md §1 and the per-particle PSD projection of
// §3 step 2.
#pragma once

#include "core/types.h"

#include <Eigen/SVD>
#include <cassert>

namespace iqmpm {

template <int dim>
struct RotationVariantSvd {
  Mat<dim> U;     // proper rotation
  Vec<dim> sigma; // sigma(0) >= ... >= |sigma(dim-1)|; only sigma(dim-1) may be negative
  Mat<dim> V;     // proper rotation
};

template <int dim>
RotationVariantSvd<dim> rotation_variant_svd(const Mat<dim>& F) {
  static_assert(dim == 2 || dim == 3, "dim must be 2 or 3");
  assert(F.allFinite() && "rotation_variant_svd: F has a NaN or infinite entry");
  // Two-sided Jacobi: accurate to machine precision relative to |F| for these tiny
  // fixed-size matrices; singular values come sorted in decreasing order.
  const Eigen::JacobiSVD<Mat<dim>> svd(F, Eigen::ComputeFullU | Eigen::ComputeFullV);
  RotationVariantSvd<dim> result{svd.matrixU(), svd.singularValues(), svd.matrixV()};
  // Flipping column dim-1 of U (or V) together with sigma(dim-1) leaves U S V^T unchanged.
  if (result.U.determinant() < 0) {
    result.U.col(dim - 1) *= -1;
    result.sigma(dim - 1) *= -1;
  }
  if (result.V.determinant() < 0) {
    result.V.col(dim - 1) *= -1;
    result.sigma(dim - 1) *= -1;
  }
  return result;
}

}  // namespace iqmpm
