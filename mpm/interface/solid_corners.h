// Fluid velocity corners that move with a solid (coupling.solid_corner_fraction;
// docs/method.md#solid-corners): those whose N1 support is at least that fraction solid,
// by the solid particles' current volume. On a flat surface a corner's fraction is 0.5,
// and 1 - (1 - d)^2 / 2 at a depth of d cells inside it (0.75 at d = 0.29). A corner on a
// slip wall has half its support beyond the wall, where the body's mirror image lies (as
// for the IQ normals, mass_reflected_across_walls): its fraction counts twice, per wall it
// lies on.
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include "core/types.h"
#include "grid/grid.h"
#include "grid/kernels.h"
#include "particles/particles.h"

namespace iqmpm {

// Dense over the corners: 1 where the corner moves with a solid. Empty when threshold is 0.
template <int dim>
std::vector<std::uint8_t> solid_corners(const Grid<dim>& grid, const Particles<dim>& solid,
                                        const std::array<std::array<bool, 2>, dim>& slip, Real threshold) {
  std::vector<std::uint8_t> marked;
  if (!(threshold > 0)) return marked;
  const GridLayout<dim> corners = grid.corners();
  std::vector<Real> fraction(corners.size(), 0);
  const Real cell_volume = grid.cell_volume();
  for (std::size_t p = 0; p < solid.size(); ++p) {
    const auto stencil = linear_stencil<dim>(grid.to_cells(solid.position[p]), grid.dx);
    const Real share = solid.initial_volume[p] * solid.deformation_gradient[p].determinant() / cell_volume;
    for_each_offset<dim, 2>([&](const IVec<dim>& offset) { fraction[corners.index(stencil.base + offset)] += stencil.weight(offset) * share; });
  }
  marked.assign(corners.size(), 0);
  for (int k = 0; k < corners.size(); ++k) {
    const IVec<dim> corner = corners.multi_index(k);
    for (int a = 0; a < dim; ++a)
      if ((corner[a] == 0 && slip[a][0]) || (corner[a] == grid.cells[a] && slip[a][1])) fraction[k] *= 2;
    marked[k] = fraction[k] >= threshold;
  }
  return marked;
}

}  // namespace iqmpm
