// The three interpolation kernels of the B2B0-B0-B1B0 scheme (method.md §2).
//
// Positions are measured in cells from the grid origin, xi = (x - origin) / dx.
// The grid is laid out so that the domain walls fall on faces of the dual cells:
//   * dual cell ("pressure cell") i covers [i, i + 1) in xi; every pressure-like unknown
//     (p_f, p_g, wall multiplier y, interface multiplier h) is constant on one of them (N0);
//   * the quadratic B-spline node i of the solid velocity (N2) sits at the centre xi = i + 1/2
//     of dual cell i, so dual cells are exactly the knot spans of N2;
//   * the fluid velocity (N1) lives on the corners xi = c of the dual cells, so each dual
//     cell is one multilinear (Q1) element and the fluid is a Q1-P0 pair.
// This is method.md's grid shifted by half a cell, which puts walls on dual-cell faces.
#pragma once

#include <cmath>

#include "core/types.h"

namespace iqmpm {

// Calls f(offset) for every offset in {0, ..., width-1}^dim, first axis outermost.
template <int dim, int width, class F>
inline void for_each_offset(F&& f) {
  IVec<dim> offset;
  if constexpr (dim == 2) {
    for (offset[0] = 0; offset[0] < width; ++offset[0])
      for (offset[1] = 0; offset[1] < width; ++offset[1]) f(offset);
  } else {
    for (offset[0] = 0; offset[0] < width; ++offset[0])
      for (offset[1] = 0; offset[1] < width; ++offset[1])
        for (offset[2] = 0; offset[2] < width; ++offset[2]) f(offset);
  }
}

// Tensor-product stencil of a B-spline kernel: per-axis weights and derivatives.
template <int dim, int width>
struct Stencil {
  IVec<dim> base;            // index of the first grid point touched on each axis
  Real w[dim][width];        // 1-D weights
  Real dw[dim][width];       // 1-D derivatives, in 1/length

  Real weight(const IVec<dim>& offset) const {
    Real value = 1;
    for (int a = 0; a < dim; ++a) value *= w[a][offset[a]];
    return value;
  }
  Vec<dim> gradient(const IVec<dim>& offset) const {
    Vec<dim> g;
    for (int a = 0; a < dim; ++a) {
      g[a] = dw[a][offset[a]];
      for (int b = 0; b < dim; ++b)
        if (b != a) g[a] *= w[b][offset[b]];
    }
    return g;
  }
};

template <int dim>
using QuadraticStencil = Stencil<dim, 3>;
template <int dim>
using LinearStencil = Stencil<dim, 2>;

// N2: quadratic B-spline on the nodes xi = i + 1/2. The middle node (base + 1) is the
// node of the dual cell that holds the point.
template <int dim>
inline QuadraticStencil<dim> quadratic_stencil(const Vec<dim>& xi, Real dx) {
  QuadraticStencil<dim> s;
  for (int a = 0; a < dim; ++a) {
    const Real eta = xi[a] - Real(0.5);  // node coordinate
    const int base = int(std::floor(eta - Real(0.5)));
    const Real f = eta - base;  // in [0.5, 1.5)
    s.base[a] = base;
    s.w[a][0] = Real(0.5) * (Real(1.5) - f) * (Real(1.5) - f);
    s.w[a][1] = Real(0.75) - (f - 1) * (f - 1);
    s.w[a][2] = Real(0.5) * (f - Real(0.5)) * (f - Real(0.5));
    s.dw[a][0] = (f - Real(1.5)) / dx;
    s.dw[a][1] = -2 * (f - 1) / dx;
    s.dw[a][2] = (f - Real(0.5)) / dx;
  }
  return s;
}

// N1: multilinear hat on the corners xi = c; base is the dual cell holding the point.
template <int dim>
inline LinearStencil<dim> linear_stencil(const Vec<dim>& xi, Real dx) {
  LinearStencil<dim> s;
  for (int a = 0; a < dim; ++a) {
    const int base = int(std::floor(xi[a]));
    const Real f = xi[a] - base;  // in [0, 1)
    s.base[a] = base;
    s.w[a][0] = 1 - f;
    s.w[a][1] = f;
    s.dw[a][0] = -1 / dx;
    s.dw[a][1] = 1 / dx;
  }
  return s;
}

// N0: index of the dual cell that holds the point.
template <int dim>
inline IVec<dim> dual_cell_of(const Vec<dim>& xi) {
  IVec<dim> cell;
  for (int a = 0; a < dim; ++a) cell[a] = int(std::floor(xi[a]));
  return cell;
}

}  // namespace iqmpm
