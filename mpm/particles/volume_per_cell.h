#pragma once

#include <algorithm>
#include <vector>

#include "core/types.h"
#include "grid/grid.h"
#include "grid/kernels.h"
#include "particles/particles.h"

namespace iqmpm {

// Particles' volume in each dual cell (layout index): V0, or with current_volume the
// current volume V0 det F (solids); particles outside the domain are not counted.
template <int dim>
std::vector<Real> particle_volume_per_cell(const Grid<dim>& grid, const Particles<dim>& particles, bool current_volume) {
  const auto cells = grid.dual_cells();
  std::vector<Real> volume(cells.size(), 0);
  for (std::size_t p = 0; p < particles.size(); ++p) {
    const IVec<dim> c = dual_cell_of<dim>(grid.to_cells(particles.position[p]));
    if (cells.contains(c))
      volume[cells.index(c)] += particles.initial_volume[p] * (current_volume ? particles.deformation_gradient[p].determinant() : Real(1));
  }
  return volume;
}

// The fluid's and the solids' volume in each dual cell (layout index), the solids' at
// their current volume.
template <int dim>
std::vector<Real> material_volume_per_cell(const Grid<dim>& grid, const Particles<dim>& fluid, const Particles<dim>& solid) {
  std::vector<Real> volume = particle_volume_per_cell(grid, fluid, false);
  if (!solid.empty()) {
    const std::vector<Real> solid_volume = particle_volume_per_cell(grid, solid, true);
    for (std::size_t k = 0; k < volume.size(); ++k) volume[k] += solid_volume[k];
  }
  return volume;
}

// The same volume spread with multilinear weights over the dual cells around each
// particle (centres at i + 1/2), so that it moves continuously with the particles;
// weight falling on a cell beyond a side of the domain is reflected back into the cell
// inside, as if the wall mirrored the particles. A regular lattice of particles, whole
// cells of them up to a wall, gives each cell exactly its particles' volume. Used where a
// density drives a correction (fluid/position_correction.h): the count per cell jumps by
// a particle's volume when a particle crosses a face, and a correction that answers such
// jumps stirs the particles instead of evening them out (method.md#position-correction).
template <int dim>
std::vector<Real> smoothed_particle_volume_per_cell(const Grid<dim>& grid, const Particles<dim>& particles,
                                                    bool current_volume) {
  const auto cells = grid.dual_cells();
  std::vector<Real> volume(cells.size(), 0);
  for (std::size_t p = 0; p < particles.size(); ++p) {
    const Real v = particles.initial_volume[p] * (current_volume ? particles.deformation_gradient[p].determinant() : Real(1));
    const Vec<dim> xi = grid.to_cells(particles.position[p]);
    if (!cells.contains(dual_cell_of<dim>(xi))) continue;
    const LinearStencil<dim> stencil = linear_stencil<dim>(xi - Vec<dim>::Constant(Real(0.5)), grid.dx);
    for_each_offset<dim, 2>([&](const IVec<dim>& o) {
      IVec<dim> cell = stencil.base + o;
      for (int a = 0; a < dim; ++a) cell[a] = std::clamp(cell[a], 0, grid.cells[a] - 1);
      volume[cells.index(cell)] += stencil.weight(o) * v;
    });
  }
  return volume;
}

}  // namespace iqmpm
