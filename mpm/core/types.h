// Fixed-size Eigen aliases shared by the whole solver. Every physics routine is
// templated on the spatial dimension `dim` (2 or 3) and uses these names.
#pragma once

#include <Eigen/Core>
#include <array>
#include <cstdint>

namespace iqmpm {

using Real = double;

template <int dim>
using Vec = Eigen::Matrix<Real, dim, 1>;

template <int dim>
using Mat = Eigen::Matrix<Real, dim, dim>;

template <int dim>
using IVec = Eigen::Matrix<int, dim, 1>;

// Derivative of a dim x dim matrix function with respect to a dim x dim matrix,
// both flattened column-major (Eigen's default): entry (i, j) = d vec(P)_i / d vec(F)_j.
template <int dim>
using TensorMat = Eigen::Matrix<Real, dim * dim, dim * dim>;

}  // namespace iqmpm
