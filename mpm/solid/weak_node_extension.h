// Extended B-splines for the solid's weak nodes (method.md#weak-solid-nodes).
//
// A quadratic node whose support (its 3^dim dual cells) holds no cell that the solid
// fills is seen by a few particles at the body's face, by the tails of its B-spline. In
// the implicit step such a node's velocity is nearly free: it can cancel the strain rate
// of the few face particles it touches at almost no cost, so those particles carry little
// stress and the body bends as if thinner (a beam across the grid at 2 particles per axis,
// 10-13 % too soft; first order in dx over the thickness). Extended B-splines (Hollig,
// Reif & Wipper, SIAM J. Numer. Anal. 39, 2001) remove that freedom: a weak node's velocity
// is the quadratic extrapolation of the nearest 3^dim block of inner nodes,
//
//   v_weak = sum_j e_j v_j,   e_j = prod_a l_(j_a)(i_a - b_a),
//
// l_0..l_2 the Lagrange polynomials on the block's three nodes b_a, b_a + 1, b_a + 2 of
// axis a. The extrapolation reproduces quadratic fields, so the space keeps its order, and
// sums to one, so momentum is kept. It must hold through the whole step, else the weak
// nodes relieve the face particles in whichever stage leaves them free: the solid step
// minimises its potential over the kept unknowns x, v = E x (ExtendedPotential below); the
// pressure solve moves the weak nodes' constraint columns to their blocks
// (Simulation::weak_solid_node_columns); the final velocities are extended (WeakSolidNodes::extend).
//
// A cell counts as filled when its particles' current volume is at least 3/4 of the cell:
// at 2 particles per axis, one particle of a cell's four may have drifted out. Nodes with a
// wall-held component stay kept (their Dirichlet projection stays in place), and only
// free nodes without a held component are block nodes. A node belongs to a body when only
// that body's particles reach it; a weak node and its block belong to the same body (a
// body's face never moves with another body), and a weak node that two bodies reach, or
// with no block whose centre lies within two nodes of it along every axis, stays kept.
#pragma once

#include <Eigen/SparseCore>

#include <array>
#include <cassert>
#include <cstdint>
#include <limits>
#include <vector>

#include "core/types.h"
#include "grid/grid.h"
#include "grid/kernels.h"
#include "particles/particles.h"
#include "particles/volume_per_cell.h"

namespace iqmpm {

// The weak nodes given by extrapolation, dense over Grid::nodes(): weak node i's velocity is
// sum over parent_start[i] <= j < parent_start[i + 1] of weight[j] times parent[j]'s.
struct WeakSolidNodes {
  std::vector<int> node;
  std::vector<int> parent_start{0};
  std::vector<int> parent;
  std::vector<Real> weight;
  int unextended = 0;  // weak nodes without a block, left as unknowns of their own
  int size() const { return int(node.size()); }
  bool empty() const { return node.empty(); }

  // v_weak = sum_j e_j v_j on every weak node of a dense nodal field.
  template <class V>
  void extend(std::vector<V>& field) const {
    for (int i = 0; i < size(); ++i) {
      V v = field[parent[parent_start[i]]] * weight[parent_start[i]];
      for (int j = parent_start[i] + 1; j < parent_start[i + 1]; ++j) v += field[parent[j]] * weight[j];
      field[node[i]] = v;
    }
  }
};

namespace weak_nodes_detail {
// Lagrange polynomials on the nodes 0, 1, 2 at t.
inline std::array<Real, 3> lagrange(Real t) {
  return {Real(0.5) * (t - 1) * (t - 2), -t * (t - 2), Real(0.5) * t * (t - 1)};
}
}  // namespace weak_nodes_detail

// The weak nodes among the free ones (mass > 0, not clamped) and their blocks. fixed_axes:
// dense, bit a = component a wall-held (empty: none).
template <int dim>
WeakSolidNodes find_weak_solid_nodes(const Grid<dim>& grid, const Particles<dim>& particles,
                                     const std::vector<Real>& mass, const std::vector<std::uint8_t>& clamped,
                                     const std::vector<std::uint8_t>& fixed_axes) {
  const GridLayout<dim> nodes = grid.nodes();
  const GridLayout<dim> cells = grid.dual_cells();
  const std::vector<Real> volume = particle_volume_per_cell(grid, particles, /*current_volume=*/true);
  const Real filled = (Real(0.75) - Real(1e-9)) * grid.cell_volume();  // 6 of 8 particles count

  // The body that reaches each node: -1 none, -2 several (Particles::body; empty: one body).
  std::vector<int> node_body(nodes.size(), -1);
  for (std::size_t p = 0; p < particles.size(); ++p) {
    const int body = particles.body.empty() ? 0 : particles.body[p];
    const auto stencil = quadratic_stencil<dim>(grid.to_cells(particles.position[p]), grid.dx);
    for_each_offset<dim, 3>([&](const IVec<dim>& offset) {
      const IVec<dim> j = stencil.base + offset;
      if (!nodes.contains(j)) return;
      int& owner = node_body[nodes.index(j)];
      owner = owner == -1 || owner == body ? body : -2;
    });
  }

  std::vector<char> weak(nodes.size(), 0), block_node(nodes.size(), 0);
  for (int k = 0; k < nodes.size(); ++k) {
    const bool free = mass[k] > 0 && (clamped.empty() || !clamped[k]);
    if (!free) continue;
    const IVec<dim> i = nodes.multi_index(k);
    bool strong = false;
    for_each_offset<dim, 3>([&](const IVec<dim>& offset) {
      const IVec<dim> cell = i + offset - IVec<dim>::Ones();
      strong = strong || (cells.contains(cell) && volume[cells.index(cell)] >= filled);
    });
    const bool held = !fixed_axes.empty() && fixed_axes[k] != 0;
    weak[k] = !strong && !held;
    block_node[k] = strong && !held;
  }

  // Each weak node's block: the lowest corner of the nearest 3^dim block of block nodes
  // whose centre is within two nodes along every axis (the first in offset order on a tie).
  WeakSolidNodes out;
  for (int k = 0; k < nodes.size(); ++k) {
    if (!weak[k]) continue;
    const IVec<dim> i = nodes.multi_index(k);
    const int body = node_body[k];
    int best = std::numeric_limits<int>::max();
    IVec<dim> best_corner = IVec<dim>::Zero();
    for_each_offset<dim, 5>([&](const IVec<dim>& shift) {
      const IVec<dim> corner = i + shift - IVec<dim>::Constant(3);
      const int distance = (shift - IVec<dim>::Constant(2)).squaredNorm();
      if (distance >= best) return;
      bool all = true;
      for_each_offset<dim, 3>([&](const IVec<dim>& offset) {
        const IVec<dim> j = corner + offset;
        all = all && nodes.contains(j) && block_node[nodes.index(j)] && node_body[nodes.index(j)] == body;
      });
      if (all) best = distance, best_corner = corner;
    });
    if (body < 0) best = std::numeric_limits<int>::max();
    if (best == std::numeric_limits<int>::max()) {
      ++out.unextended;
      continue;
    }
    std::array<std::array<Real, 3>, dim> l;
    for (int a = 0; a < dim; ++a) l[a] = weak_nodes_detail::lagrange(Real(i[a] - best_corner[a]));
    out.node.push_back(k);
    for_each_offset<dim, 3>([&](const IVec<dim>& offset) {
      Real e = 1;
      for (int a = 0; a < dim; ++a) e *= l[a][offset[a]];
      out.parent.push_back(nodes.index(best_corner + offset));
      out.weight.push_back(e);
    });
    out.parent_start.push_back(int(out.parent.size()));
  }
  return out;
}

// E, the map from the kept unknowns to a solid potential's unknowns (dim per free node, the
// free numbering `free_number`: dense node -> number or -1).
struct WeakNodeExtension {
  using SparseMatrix = Eigen::SparseMatrix<Real, Eigen::RowMajor, int>;
  SparseMatrix matrix;             // rows: the potential's unknowns; columns: the kept unknowns
  std::vector<int> kept_unknowns;  // the potential's unknown of each kept unknown
};

template <int dim>
WeakNodeExtension weak_node_extension(const WeakSolidNodes& weak, const std::vector<int>& free_number) {
  int free_count = 0;
  for (int r : free_number) free_count = std::max(free_count, r + 1);
  std::vector<int> weak_of_free(free_count, -1);
  for (int i = 0; i < weak.size(); ++i) {
    assert(free_number[weak.node[i]] >= 0);
    weak_of_free[free_number[weak.node[i]]] = i;
  }
  std::vector<int> kept_number(free_count, -1);
  WeakNodeExtension out;
  int kept = 0;
  for (int r = 0; r < free_count; ++r)
    if (weak_of_free[r] < 0) {
      kept_number[r] = kept++;
      for (int a = 0; a < dim; ++a) out.kept_unknowns.push_back(dim * r + a);
    }
  std::vector<Eigen::Triplet<Real, int>> entries;
  for (int r = 0; r < free_count; ++r)
    for (int a = 0; a < dim; ++a) {
      const int i = weak_of_free[r];
      if (i < 0) {
        entries.emplace_back(dim * r + a, dim * kept_number[r] + a, Real(1));
        continue;
      }
      for (int j = weak.parent_start[i]; j < weak.parent_start[i + 1]; ++j) {
        assert(free_number[weak.parent[j]] >= 0 && kept_number[free_number[weak.parent[j]]] >= 0 &&
               "weak nodes found with another mass or clamp array than the potential's");
        entries.emplace_back(dim * r + a, dim * kept_number[free_number[weak.parent[j]]] + a, weak.weight[j]);
      }
    }
  out.matrix.resize(dim * free_count, dim * kept);
  out.matrix.setFromTriplets(entries.begin(), entries.end());
  return out;
}

// The potential over the kept unknowns x, v = E x: energy E(Ex), gradient E^T g(Ex), Hessian
// E^T H(Ex) E; the Jacobi diagonal of products is sum_k E_kq^2 H_kk (the weak nodes' cross
// terms left out), enough for a preconditioner.
template <class Potential>
class ExtendedPotential {
 public:
  using Vector = typename Potential::Vector;
  using SparseMatrix = typename Potential::SparseMatrix;

  ExtendedPotential(const Potential& potential, const WeakNodeExtension& extension)
      : potential_(potential), E_(extension.matrix), Et_(extension.matrix.transpose()), kept_(extension.kept_unknowns) {
    squared_ = Et_.cwiseAbs2();
  }

  int unknowns() const { return int(E_.cols()); }
  Vector expand(const Vector& x) const { return E_ * x; }

  Vector initial_velocity() const {
    const Vector full = potential_.initial_velocity();
    Vector x(kept_.size());
    for (std::size_t q = 0; q < kept_.size(); ++q) x[q] = full[kept_[q]];
    return x;
  }
  Real gradient_scale() const { return potential_.gradient_scale(); }
  Real energy(const Vector& x) const { return potential_.energy(expand(x)); }
  Vector gradient(const Vector& x) const { return Et_ * potential_.gradient(expand(x)); }
  SparseMatrix hessian(const Vector& x, bool project_to_psd) const {
    const SparseMatrix H = potential_.hessian(expand(x), project_to_psd);
    return SparseMatrix(Et_ * H * E_);
  }

  struct Linearization {
    typename Potential::Linearization full;
    Vector diagonal;
  };
  Linearization linearize(const Vector& x, bool project_to_psd) const {
    Linearization out{potential_.linearize(expand(x), project_to_psd), Vector()};
    out.diagonal = squared_ * out.full.diagonal;
    return out;
  }
  Vector hessian_product(const Linearization& linear, const Vector& y) const {
    return Et_ * potential_.hessian_product(linear.full, expand(y));
  }

 private:
  const Potential& potential_;
  const typename WeakNodeExtension::SparseMatrix& E_;
  typename WeakNodeExtension::SparseMatrix Et_;       // E^T, row-major: the products by rows
  std::vector<int> kept_;
  typename WeakNodeExtension::SparseMatrix squared_;  // (E^T)^2 entrywise, for the diagonal
};

}  // namespace iqmpm
