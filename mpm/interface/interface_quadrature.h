// Interface quadrature (method.md §3 step 3, §4): the points where the free-slip coupling
// condition (v_f - v_s) . n = 0 is imposed, one multiplier h per dual cell holding them.
//
//  * IQ points: solid particles within coupling.interface_reach (0.6 dx; the reference
//    code's 0.5) of some fluid particle (found through the particle bins: a neighbour
//    lies in the 3^dim block of dual cells around the particle).
//  * Borrowed volume: every fluid particle shares its volume equally among itself and its
//    solid neighbours, so each IQ point is also a fluid quadrature point of G^f: the
//    divergence constraint reaches into the interface cells. The fluid keeps its mass;
//    the reference code lends the mass too, which weighs the lent water twice next to
//    full cells (docs/method.md#borrowed-volume).
//  * Normal: the normalised gradient of the solid grid mass at the point (into the solid),
//    the mass reflected across the slip walls first (mass_reflected_across_walls).
//  * Area: a disk of the particle's current volume: 2 sqrt(V / pi) (a length) in 2-D,
//    pi r^2 with r = (3 V / 4 pi)^(1/3) in 3-D (the reference code's formula is 2-D only).
//  * The point is clamped 0.1 dx inside its dual cell so that N0 is unambiguous there.
#pragma once

#include <Eigen/LU>
#include <Eigen/SparseCore>
#include <array>
#include <cmath>
#include <vector>

#include "core/types.h"
#include "grid/grid.h"
#include "grid/kernels.h"
#include "particles/particles.h"

namespace iqmpm {

template <int dim>
struct InterfacePoints {
  std::vector<int> solid_particle;       // IQ point q -> its solid particle
  std::vector<std::vector<int>> lenders; // fluid particles within the reach of q
  std::vector<int> share_count;          // per fluid particle: 1 + number of solid neighbours
  bool empty() const { return solid_particle.empty(); }
  int size() const { return int(solid_particle.size()); }
};

template <int dim>
InterfacePoints<dim> find_interface_points(const Grid<dim>& grid, const Particles<dim>& fluid,
                                           const ParticleBins<dim>& fluid_bins, const Particles<dim>& solid,
                                           Real reach_in_dx = 0.5) {
  InterfacePoints<dim> iq;
  iq.share_count.assign(fluid.size(), 1);
  if (fluid.empty() || solid.empty()) return iq;
  const GridLayout<dim> cells = grid.dual_cells();
  // Seeded lattices of two particles a cell meet exactly dx/2 apart: such ties count. At a
  // reach of exactly dx/2 (the reference code's) a sub-micron motion breaks them, and rows
  // of IQ points drop out and come back step by step; 0.6 dx keeps the first layer and
  // stays below the diagonal neighbours at dx/sqrt(2) (docs/method.md#interface-reach).
  const Real reach2 = std::pow(reach_in_dx * grid.dx * (1 + 1e-9), 2);
  for (std::size_t s = 0; s < solid.size(); ++s) {
    const Vec<dim>& xs = solid.position[s];
    const IVec<dim> home = dual_cell_of<dim>(grid.to_cells(xs));
    std::vector<int> near;
    for_each_offset<dim, 3>([&](const IVec<dim>& offset) {
      const IVec<dim> cell = home + offset - IVec<dim>::Ones();
      if (!cells.contains(cell)) return;
      const int k = cells.index(cell);
      for (int p = fluid_bins.begin(k); p < fluid_bins.end(k); ++p)
        if ((fluid.position[p] - xs).squaredNorm() <= reach2) near.push_back(p);
    });
    if (near.empty()) continue;
    for (int p : near) ++iq.share_count[p];
    iq.solid_particle.push_back(int(s));
    iq.lenders.push_back(std::move(near));
  }
  return iq;
}

// An IQ point moved at least 0.1 dx inside its dual cell (method.md §3 step 3).
template <int dim>
Vec<dim> clamped_inside_cell(const Grid<dim>& grid, const Vec<dim>& x) {
  const Vec<dim> xi = grid.to_cells(x);
  Vec<dim> out = x;
  for (int a = 0; a < dim; ++a) {
    const Real lo = std::floor(xi[a]);
    const Real f = std::min(std::max(xi[a] - lo, Real(0.1)), Real(0.9));
    out[a] = grid.origin[a] + (lo + f) * grid.dx;
  }
  return out;
}

// One fluid quadrature point per IQ point, carrying the volume its lenders share with it
// and the lenders' velocity and affine field there; massless: a pure G^f point that adds
// no weight.
template <int dim>
Particles<dim> borrowed_fluid_points(const Grid<dim>& grid, const Particles<dim>& fluid, const Particles<dim>& solid,
                                     const InterfacePoints<dim>& iq) {
  Particles<dim> out;
  for (int q = 0; q < iq.size(); ++q) {
    Real mass = 0, volume = 0;
    Vec<dim> momentum = Vec<dim>::Zero();
    Mat<dim> affine = Mat<dim>::Zero();
    const Vec<dim> x = clamped_inside_cell(grid, solid.position[iq.solid_particle[q]]);
    for (int p : iq.lenders[q]) {
      const Real share = fluid.mass[p] / iq.share_count[p];
      mass += share;
      volume += fluid.initial_volume[p] / iq.share_count[p];
      // The lender's affine velocity field evaluated at the IQ point.
      momentum += share * (fluid.velocity[p] + fluid.affine[p] * (x - fluid.position[p]));
      affine += share * fluid.affine[p];
    }
    out.add(x, momentum / mass, Real(0), volume);
    out.affine.back() = affine / mass;
  }
  return out;
}

// Calls f(solid dof, N2 weight) for the solid velocity nodes around fluid corner `corner`.
template <int dim, class F>
void for_each_solid_weight(const Grid<dim>& grid, const IVec<dim>& corner, const std::vector<int>& solid_dof_of_node, F&& f) {
  const GridLayout<dim> nodes = grid.nodes();
  const auto stencil = quadratic_stencil<dim>(grid.to_cells(grid.corner_position(corner)), grid.dx);
  for_each_offset<dim, 3>([&](const IVec<dim>& offset) {
    const IVec<dim> node = stencil.base + offset;
    if (!nodes.contains(node)) return;
    const int dof = solid_dof_of_node[nodes.index(node)];
    if (dof >= 0) f(dof, stencil.weight(offset));
  });
}

// The solid grid mass extended by reflection across each slip wall (sides[a][0]: the low
// side of axis a), for the IQ normals only. The padding node beyond a wall and its mirror
// inside both get the sum of their masses: the mass of the body together with its mirror
// image. A body flush against a wall then has no mass gradient across the wall, so the
// normals of its particles next to the wall lie along the wall. Without it they tilt
// towards the wall (the body's mass falls off into the padding layer), and the one
// constraint per cell lets water slide along the wall into the body (measured: a gate
// clamped to the floor, holding still water, leaked under itself from 0.5 s on; docs/method.md#walls-mirror-a-body). A body more than 1.5 dx from a wall has no mass in the padding layer and is
// unaffected.
template <int dim>
std::vector<Real> mass_reflected_across_walls(const Grid<dim>& grid, std::vector<Real> node_mass,
                                              const std::array<std::array<bool, 2>, dim>& sides) {
  const GridLayout<dim> nodes = grid.nodes();
  for (int a = 0; a < dim; ++a)
    for (int side = 0; side < 2; ++side) {
      if (!sides[a][side]) continue;
      const int outside = side == 0 ? -1 : grid.cells[a];
      const int mirror = side == 0 ? 0 : grid.cells[a] - 1;
      for (int k = 0; k < nodes.size(); ++k) {
        IVec<dim> i = nodes.multi_index(k);
        if (i[a] != outside) continue;
        i[a] = mirror;
        const int m = nodes.index(i);
        const Real sum = node_mass[k] + node_mass[m];
        node_mass[k] = node_mass[m] = sum;
      }
    }
  return node_mass;
}

// H^s and H^f rows (method.md §4), one row per dual cell with IQ points:
//   row j:  sum_q A_q N0_j(x_q) n_q . ( sum_c N1_c(x_q) v_c  -  sum_i N2_i(x_q) v_i ),
// i.e. H^f v_f - H^s v_s, the normal velocity jump. Columns are in the stacked velocity
// numbering (solid dofs from 0, fluid dofs from fluid_column_offset).
template <int dim>
struct InterfaceOperators {
  std::vector<int> multiplier_of_cell;  // -1 where no IQ point
  std::vector<int> cell_of_multiplier;
  std::vector<int> row_of_point;        // per IQ point: its multiplier
  std::vector<Vec<dim>> normal;         // per IQ point, into the solid
  std::vector<Real> area;               // per IQ point
  std::vector<Eigen::Triplet<Real>> rows;

  int multipliers() const { return int(cell_of_multiplier.size()); }
};

template <int dim>
InterfaceOperators<dim> build_interface_operators(const Grid<dim>& grid, const InterfacePoints<dim>& iq,
                                                  const Particles<dim>& solid, const std::vector<Real>& node_mass,
                                                  const std::vector<int>& solid_dof_of_node,
                                                  const std::vector<int>& fluid_dof_of_corner, int fluid_column_offset) {
  InterfaceOperators<dim> ops;
  const GridLayout<dim> cells = grid.dual_cells(), nodes = grid.nodes(), corners = grid.corners();
  ops.multiplier_of_cell.assign(cells.size(), -1);
  const Real pi = 3.14159265358979323846;
  for (int q = 0; q < iq.size(); ++q) {
    const int s = iq.solid_particle[q];
    const Vec<dim> x = clamped_inside_cell(grid, solid.position[s]);
    const auto quadratic = quadratic_stencil<dim>(grid.to_cells(x), grid.dx);
    Vec<dim> mass_gradient = Vec<dim>::Zero();
    for_each_offset<dim, 3>([&](const IVec<dim>& offset) {
      mass_gradient += node_mass[nodes.index(quadratic.base + offset)] * quadratic.gradient(offset);
    });
    const Real norm = mass_gradient.norm();
    const Vec<dim> n = norm > 0 ? Vec<dim>(mass_gradient / norm) : Vec<dim>::Zero();
    const Real volume = solid.initial_volume[s] * solid.deformation_gradient[s].determinant();
    const Real area = dim == 2 ? 2 * std::sqrt(volume / pi) : pi * std::pow(3 * volume / (4 * pi), Real(2) / 3);
    // The fluid velocity at the point from the fluid unknowns among its corners, weights
    // renormalised: corners inside the solid are not fluid unknowns. A point without any
    // fluid unknown around it imposes nothing (it would give an empty or solid-only row).
    const auto linear = linear_stencil<dim>(grid.to_cells(x), grid.dx);
    Real active_weight = 0;
    for_each_offset<dim, 2>([&](const IVec<dim>& offset) {
      if (fluid_dof_of_corner[corners.index(linear.base + offset)] >= 0) active_weight += linear.weight(offset);
    });
    ops.normal.push_back(n);
    ops.area.push_back(area);
    if (!(active_weight > 1e-6) || norm == 0) {
      ops.row_of_point.push_back(-1);
      continue;
    }
    const int cell = cells.index(dual_cell_of<dim>(grid.to_cells(x)));
    int& row = ops.multiplier_of_cell[cell];
    if (row < 0) {
      row = ops.multipliers();
      ops.cell_of_multiplier.push_back(cell);
    }
    ops.row_of_point.push_back(row);
    for_each_offset<dim, 3>([&](const IVec<dim>& offset) {
      const int dof = solid_dof_of_node[nodes.index(quadratic.base + offset)];
      if (dof < 0) return;
      const Real w = area * quadratic.weight(offset);
      for (int a = 0; a < dim; ++a) ops.rows.emplace_back(row, dof * dim + a, -w * n[a]);
    });
    for_each_offset<dim, 2>([&](const IVec<dim>& offset) {
      const IVec<dim> corner = linear.base + offset;
      const int dof = fluid_dof_of_corner[corners.index(corner)];
      const Real w = area * linear.weight(offset);
      if (dof >= 0) {
        for (int a = 0; a < dim; ++a) ops.rows.emplace_back(row, fluid_column_offset + dof * dim + a, w * n[a]);
        return;
      }
      // A corner inside the solid moves with it: v_f,c = sum_i N2_i(x_c) v_s,i.
      for_each_solid_weight(grid, corner, solid_dof_of_node, [&](int solid_dof, Real weight) {
        for (int a = 0; a < dim; ++a) ops.rows.emplace_back(row, solid_dof * dim + a, w * weight * n[a]);
      });
    });
  }
  return ops;
}

}  // namespace iqmpm
