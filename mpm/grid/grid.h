// Geometry and index layouts of the background grid (see kernels.h for where each
// kind of unknown lives). Storage is dense over the domain box; the physics only talks to
// GridLayout::index(), so a sparse block layout can replace it without touching them.
// Unknowns are numbered over active cells only (pressure_system.h), never over this box.
#pragma once

#include <cmath>

#include "core/types.h"

namespace iqmpm {

// Row-major layout of a box of grid points [lo, lo + extent), first axis outermost, so
// that a slab of first-axis indices is a contiguous range (used by parallel P2G).
template <int dim>
class GridLayout {
 public:
  GridLayout() = default;
  GridLayout(const IVec<dim>& lo, const IVec<dim>& extent) : lo_(lo), extent_(extent) {}

  int size() const {
    int n = 1;
    for (int a = 0; a < dim; ++a) n *= extent_[a];
    return n;
  }
  bool contains(const IVec<dim>& i) const {
    for (int a = 0; a < dim; ++a)
      if (i[a] < lo_[a] || i[a] >= lo_[a] + extent_[a]) return false;
    return true;
  }
  int index(const IVec<dim>& i) const {
    int k = 0;
    for (int a = 0; a < dim; ++a) k = k * extent_[a] + (i[a] - lo_[a]);
    return k;
  }
  IVec<dim> multi_index(int k) const {
    IVec<dim> i;
    for (int a = dim - 1; a >= 0; --a) {
      i[a] = lo_[a] + k % extent_[a];
      k /= extent_[a];
    }
    return i;
  }
  // Number of points in one slab of the first axis (all other indices).
  int slab_size() const { return size() / extent_[0]; }
  const IVec<dim>& lo() const { return lo_; }
  const IVec<dim>& extent() const { return extent_; }

 private:
  IVec<dim> lo_ = IVec<dim>::Zero();
  IVec<dim> extent_ = IVec<dim>::Zero();
};

template <int dim>
struct Grid {
  Vec<dim> origin = Vec<dim>::Zero();  // lower corner of the domain
  Real dx = 1;
  IVec<dim> cells = IVec<dim>::Ones();  // dual cells per axis; the domain is cells * dx

  Grid() = default;
  Grid(const Vec<dim>& lower, const Vec<dim>& upper, Real spacing) : origin(lower), dx(spacing) {
    for (int a = 0; a < dim; ++a) cells[a] = int(std::lround((upper[a] - lower[a]) / spacing));
  }

  Vec<dim> upper() const { return origin + dx * cells.template cast<Real>(); }
  Vec<dim> to_cells(const Vec<dim>& x) const { return (x - origin) / dx; }
  Real cell_volume() const { return std::pow(dx, dim); }

  // Dual cells of the domain: the pressure-like unknowns.
  GridLayout<dim> dual_cells() const { return GridLayout<dim>(IVec<dim>::Zero(), cells); }
  // Corners of the dual cells: the fluid velocity (N1).
  GridLayout<dim> corners() const { return GridLayout<dim>(IVec<dim>::Zero(), cells + IVec<dim>::Ones()); }
  // Quadratic nodes: the solid velocity (N2); one layer of padding on each side.
  GridLayout<dim> nodes() const {
    return GridLayout<dim>(-IVec<dim>::Ones(), cells + 2 * IVec<dim>::Ones());
  }
  Vec<dim> dual_cell_centre(const IVec<dim>& i) const {
    return origin + dx * (i.template cast<Real>() + Vec<dim>::Constant(0.5));
  }
  Vec<dim> corner_position(const IVec<dim>& c) const { return origin + dx * c.template cast<Real>(); }
};

}  // namespace iqmpm
