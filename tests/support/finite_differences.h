// Central differences of a potential's energy and gradient, for the derivative checks of
// the solid step's potentials (solid/incremental_potential.h, solid/weak_node_extension.h).
#pragma once

#include <Eigen/Dense>

#include "core/types.h"

namespace iqmpm::testing {

struct CentralDifferences {
  Eigen::Matrix<Real, Eigen::Dynamic, 1> gradient;                // of energy(x)
  Eigen::Matrix<Real, Eigen::Dynamic, Eigen::Dynamic> hessian;    // of gradient(x), by columns
};

// `potential` has energy(x) and gradient(x); h is the step of every coordinate.
template <class Potential>
CentralDifferences central_differences(const Potential& potential, const Eigen::Matrix<Real, Eigen::Dynamic, 1>& x, Real h) {
  const Eigen::Index n = x.size();
  CentralDifferences d{Eigen::Matrix<Real, Eigen::Dynamic, 1>(n), Eigen::Matrix<Real, Eigen::Dynamic, Eigen::Dynamic>(n, n)};
  for (Eigen::Index k = 0; k < n; ++k) {
    auto plus = x, minus = x;
    plus[k] += h;
    minus[k] -= h;
    d.gradient[k] = (potential.energy(plus) - potential.energy(minus)) / (2 * h);
    d.hessian.col(k) = (potential.gradient(plus) - potential.gradient(minus)) / (2 * h);
  }
  return d;
}

}  // namespace iqmpm::testing
