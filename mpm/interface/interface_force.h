// Force of the fluid on the solid (method.md §7): -D^T lambda on the solid nodes over the
// rows that couple them to the fluid (h, and p_f where fluid corners inside a solid move
// with it); the ghost-matrix rows are internal to the solid. Each node's force is shared
// among the particles around it by their mass there (N2 weight x mass / node mass), so
// that a node shared by bodies, or by a region and the rest of a body, is split
// consistently. Evaluate before the particles move, so that the split uses the positions
// of the node masses.
#pragma once

#include <Eigen/Core>
#include <vector>

#include "core/types.h"
#include "grid/grid.h"
#include "grid/kernels.h"
#include "particles/particles.h"
#include "solid/ghost_matrix.h"

namespace iqmpm {

// nodal_force: stacked per solid velocity dof (dim components each), as -D^T lambda.
template <int dim>
std::vector<Vec<dim>> interface_force_on_particles(const Grid<dim>& grid, const Particles<dim>& solid,
                                                   const std::vector<Real>& node_mass, const SolidOperators<dim>& solid_ops,
                                                   const Eigen::VectorXd& nodal_force) {
  const GridLayout<dim> nodes = grid.nodes();
  std::vector<Vec<dim>> node_force(nodes.size(), Vec<dim>::Zero());
  for (int d = 0; d < solid_ops.velocity_dofs(); ++d) node_force[solid_ops.node_of_dof[d]] = nodal_force.template segment<dim>(d * dim);
  std::vector<Vec<dim>> force(solid.size(), Vec<dim>::Zero());
  for (std::size_t p = 0; p < solid.size(); ++p) {
    const auto stencil = quadratic_stencil<dim>(grid.to_cells(solid.position[p]), grid.dx);
    Vec<dim> share = Vec<dim>::Zero();
    for_each_offset<dim, 3>([&](const IVec<dim>& offset) {
      const int node = nodes.index(stencil.base + offset);
      if (node_mass[node] > 0) share += stencil.weight(offset) * solid.mass[p] / node_mass[node] * node_force[node];
    });
    force[p] = share;
  }
  return force;
}

}  // namespace iqmpm
