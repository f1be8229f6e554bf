// Preconditioned conjugate gradients on any SPD operator: the pressure solve's `pcg`
// (an assembled matrix, incomplete Cholesky or Jacobi) and Newton's direction in 3-D
// (matrix-free Hessian products, Jacobi). Stops when |r| <= tolerance |b|.
#pragma once

#include <Eigen/Core>

#include "core/types.h"

namespace iqmpm {

struct PcgResult {
  int iterations = 0;
  Real initial_relative_residual = 0;  // of the first guess: |b - A x0| / |b|
  Real relative_residual = 0;
  bool converged = false;
};

// x holds the initial guess on entry and the solution on exit. product(p) returns A p;
// precondition(r, z) writes z = M^-1 r.
template <class Product, class Precondition>
PcgResult preconditioned_cg(const Product& product, const Precondition& precondition,
                            const Eigen::Matrix<Real, Eigen::Dynamic, 1>& b, Eigen::Matrix<Real, Eigen::Dynamic, 1>& x,
                            Real tolerance, int max_iterations) {
  using Vector = Eigen::Matrix<Real, Eigen::Dynamic, 1>;
  PcgResult result;
  const Real b_norm = b.norm();
  if (b_norm == 0) {
    x.setZero(b.size());
    result.converged = true;
    return result;
  }
  // From x = 0 (Newton's direction) r = b exactly: no product needed.
  Vector r = x.isZero(0) ? Vector(b) : Vector(b - product(x));
  Vector z(b.size()), p(b.size()), q(b.size());
  precondition(r, z);
  p = z;
  Real rz = r.dot(z);
  Real residual = r.norm() / b_norm;
  result.initial_relative_residual = residual;
  int k = 0;
  while (residual > tolerance && k < max_iterations) {
    q.noalias() = product(p);
    const Real alpha = rz / p.dot(q);
    x += alpha * p;
    r -= alpha * q;
    residual = r.norm() / b_norm;
    ++k;
    if (residual <= tolerance) break;
    precondition(r, z);
    const Real rz_next = r.dot(z);
    p = z + (rz_next / rz) * p;
    rz = rz_next;
  }
  result.iterations = k;
  result.relative_residual = residual;
  result.converged = residual <= tolerance;
  return result;
}

}  // namespace iqmpm
