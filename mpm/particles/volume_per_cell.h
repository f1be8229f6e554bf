#pragma once

#include <vector>

#include "core/types.h"
#include "grid/grid.h"
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

}  // namespace iqmpm
