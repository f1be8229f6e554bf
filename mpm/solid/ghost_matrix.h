// The solid's operators in the pressure-only system (method.md §1, §4): the lumped mass
// M^s on the active quadratic nodes, and for the ghost matrix its pressure unknowns p_g
// (one per dual cell holding solid particles), the Q2-P0 gradient G^s, the scaling S^s and
// the volume-weighted P2G of the matrix pressure p_g^n.
//
// With these the A11 block and its right-hand side come out of PressureSystem (D = G^sT,
// compliance S/dt, offset S p_g^n/dt): the matrix pressure obeys
//   S (p_g^{n+1} - p_g^n) / dt = G^sT v_s^{n+1},   (G^sT v)_j = -integral of N0_j div v,
// the discrete form of dp_g/dt = -lambda_g div v for Psi_g = lambda_g/2 (J_g - 1)^2.
#pragma once

#include <Eigen/LU>
#include <Eigen/SparseCore>
#include <cassert>
#include <vector>

#include "core/types.h"
#include "grid/grid.h"
#include "grid/kernels.h"
#include "particles/particles.h"

namespace iqmpm {

template <int dim>
struct SolidOperators {
  // Velocity unknowns: active nodes (mass > 0), dim components each, dof-major.
  std::vector<int> dof_of_node;  // dense over Grid::nodes(); -1 where inactive
  std::vector<int> node_of_dof;
  // Ghost-matrix pressure unknowns: dual cells holding solid particles.
  std::vector<int> pressure_of_cell;  // -1 where no solid
  std::vector<int> cell_of_pressure;
  std::vector<Real> compliance;        // S_jj = sum_p V0_p / lambda_g N0_j(x_p)
  std::vector<Real> previous_pressure; // p_g^n_j, volume-weighted average of -lambda_g (J_g - 1)
  std::vector<Eigen::Triplet<Real>> gradient_transpose;  // G^sT: rows p_g unknowns, columns dof*dim + a

  int velocity_dofs() const { return int(node_of_dof.size()); }
  int pressure_unknowns() const { return int(cell_of_pressure.size()); }
};

// node_mass: dense over Grid::nodes() (solid P2G). ghost_stiffness[body] is lambda_g.
// Particles must be sorted into `bins` (their stencil base is their dual cell minus one).
template <int dim>
SolidOperators<dim> build_solid_operators(const Grid<dim>& grid, const Particles<dim>& particles,
                                          const ParticleBins<dim>& bins, const std::vector<Real>& node_mass,
                                          const std::vector<Real>& ghost_stiffness) {
  constexpr int kStencil = dim == 2 ? 9 : 27;
  SolidOperators<dim> ops;
  const GridLayout<dim> nodes = grid.nodes();
  const GridLayout<dim> cells = grid.dual_cells();

  ops.dof_of_node.assign(nodes.size(), -1);
  for (int k = 0; k < nodes.size(); ++k)
    if (node_mass[k] > 0) {
      ops.dof_of_node[k] = int(ops.node_of_dof.size());
      ops.node_of_dof.push_back(k);
    }

  number_occupied_cells(bins, ops.pressure_of_cell, ops.cell_of_pressure);
  const int np = ops.pressure_unknowns();
  ops.compliance.assign(np, 0);
  ops.previous_pressure.assign(np, 0);
  ops.gradient_transpose.reserve(std::size_t(np) * kStencil * dim);

  for (int row = 0; row < np; ++row) {
    const int cell_index = ops.cell_of_pressure[row];
    const IVec<dim> base = cells.multi_index(cell_index) - IVec<dim>::Ones();
    // integral of N0_j grad N2_i over the cell, by particle quadrature with V_p^n = V0 J_p.
    Eigen::Matrix<Real, dim, kStencil> integral = Eigen::Matrix<Real, dim, kStencil>::Zero();
    Real weighted_pressure = 0, weight = 0;
    for (int p = bins.begin(cell_index); p < bins.end(cell_index); ++p) {
      const auto stencil = quadratic_stencil<dim>(grid.to_cells(particles.position[p]), grid.dx);
      const Real J = particles.deformation_gradient[p].determinant();
      const Real volume = particles.initial_volume[p] * J;
      const Real lambda_g = ghost_stiffness[particles.body[p]];
      assert(stencil.base == base && "particle bins out of date");
      int e = 0;
      for_each_offset<dim, 3>([&](const IVec<dim>& offset) { integral.col(e++) += volume * stencil.gradient(offset); });
      ops.compliance[row] += particles.initial_volume[p] / lambda_g;
      weighted_pressure += volume * (-lambda_g * (particles.ghost_J[p] - 1));
      weight += volume;
    }
    ops.previous_pressure[row] = weight > 0 ? weighted_pressure / weight : 0;
    int e = 0;
    for_each_offset<dim, 3>([&](const IVec<dim>& offset) {
      const int dof = ops.dof_of_node[nodes.index(base + offset)];
      if (dof >= 0)
        for (int a = 0; a < dim; ++a) ops.gradient_transpose.emplace_back(row, dof * dim + a, -integral(a, e));
      ++e;
    });
  }
  return ops;
}

}  // namespace iqmpm
