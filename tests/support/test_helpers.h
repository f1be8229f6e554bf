// Shared helpers of the typed tests: the dimension as a type, random points, small scenes.
#pragma once

#include <gtest/gtest.h>

#include <random>
#include <string>
#include <vector>

#include "core/types.h"
#include "scene/scene.h"

namespace iqmpm::testing {

template <int d>
struct Dim {
  static constexpr int value = d;
};
using Dimensions = ::testing::Types<Dim<2>, Dim<3>>;

template <int dim>
Vec<dim> random_vector(std::mt19937& rng, Real lo, Real hi) {
  std::uniform_real_distribution<Real> u(lo, hi);
  Vec<dim> v;
  for (int a = 0; a < dim; ++a) v[a] = u(rng);
  return v;
}

template <int dim>
Mat<dim> random_matrix(std::mt19937& rng, Real lo, Real hi) {
  std::uniform_real_distribution<Real> u(lo, hi);
  Mat<dim> m;
  for (int i = 0; i < dim; ++i)
    for (int j = 0; j < dim; ++j) m(i, j) = u(rng);
  return m;
}

// A point or vector of a scene document: (x, y) in 2-D, (x, y, z) in 3-D. The 3-D
// instance of a typed test extends its 2-D scene along z this way.
template <int dim>
std::vector<Real> xyz(Real x, Real y, Real z) {
  if constexpr (dim == 2) return {x, y};
  else return {x, y, z};
}

// A box shape of a scene document.
inline Json box(const std::vector<Real>& min, const std::vector<Real>& max) {
  return {{"type", "box"}, {"min", min}, {"max", max}};
}

// A box of fluid in a closed box domain, as a scene document.
inline Json fluid_box_scene(int dim, Real dx, const std::vector<Real>& fluid_max, const std::vector<Real>& domain_max) {
  Json scene = {{"dim", dim},
                {"domain", {{"min", std::vector<Real>(dim, 0.0)}, {"max", domain_max}}},
                {"dx", dx},
                {"end_time", 1.0},
                {"fluid", {{"shapes", Json::array({{{"type", "box"}, {"min", std::vector<Real>(dim, 0.0)}, {"max", fluid_max}}})}}}};
  if (dim == 3) scene["gravity"] = {0.0, -9.81, 0.0};
  return scene;
}

}  // namespace iqmpm::testing
