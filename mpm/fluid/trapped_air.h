// Air trapped by the water (experimental.trapped_air = incompressible; docs/method.md#trapped-air).
// Without it an empty dual cell is air at p = 0 wherever it is, so water closing over a
// cavity falls into it freely. With it, every face-connected set of empty cells that does not
// reach the top layer of cells (the open air) and spans at least 2^dim cells is a pocket with
// one pressure unknown, uniform over the pocket, and one row: the sum of its cells' divergence
// rows by the centre rule on full cells, -(d/dt of the pocket's volume). Summed over a
// connected set the corners inside it cancel, so the row holds the flux through the pocket's
// boundary only: the corners it shares with water or a solid (and on a wall, along the wall).
#pragma once

#include <algorithm>
#include <vector>

#include "core/types.h"
#include "fluid/fluid_operators.h"
#include "grid/grid.h"
#include "grid/kernels.h"

namespace iqmpm {

template <int dim>
struct TrappedAir {
  std::vector<std::vector<int>> pockets;  // dual cells (layout index) of each pocket
  std::vector<Triplet> rows;              // rows: pockets; columns: fluid velocity components
  // Boundary corners that are not fluid unknowns but move with a solid: (row, corner,
  // coefficients), for the caller to spread over the solid's nodes.
  std::vector<typename FluidOperators<dim>::CornerEntry> solid_corner_rows;

  int size() const { return int(pockets.size()); }
  int largest() const {
    std::size_t n = 0;
    for (const auto& cells : pockets) n = std::max(n, cells.size());
    return int(n);
  }
  // Where each pocket's unknown lives (its first cell), for orderings and dumps.
  std::vector<int> cell_of_pocket() const {
    std::vector<int> cells;
    for (const auto& pocket : pockets) cells.push_back(pocket.front());
    return cells;
  }
};

// Smaller sets of empty cells are sampling holes of the particles (at 2 per axis a dual cell
// inside the water can be empty for a step), not air: docs/method.md#trapped-air.
template <int dim>
constexpr int smallest_air_pocket = 1 << dim;

// `is_air(cell)`: an empty dual cell (no fluid quadrature, no solid); `up`: the open side
// (the top layer of cells along it is open air); `moves_with_solid(corner)`: a corner that is
// no fluid unknown belongs to a solid (else it lies on a wall, whose normal velocity is held).
template <int dim, class IsAir, class MovesWithSolid>
TrappedAir<dim> find_trapped_air(const Grid<dim>& grid, const FluidOperators<dim>& ops, DomainSide up, IsAir is_air,
                                 MovesWithSolid moves_with_solid) {
  TrappedAir<dim> air;
  const GridLayout<dim> cells = grid.dual_cells(), corners = grid.corners();
  const int top = up.side == 1 ? grid.cells[up.axis] - 1 : 0;
  std::vector<char> seen(cells.size(), 0);
  std::vector<Vec<dim>> coefficient(corners.size(), Vec<dim>::Zero());
  std::vector<int> touched;
  for (int start = 0; start < cells.size(); ++start) {
    if (seen[start] || !is_air(start)) continue;
    std::vector<int> pocket{start};
    seen[start] = 1;
    bool open = false;
    for (std::size_t q = 0; q < pocket.size(); ++q) {
      const IVec<dim> cell = cells.multi_index(pocket[q]);
      open = open || cell[up.axis] == top;
      for (int a = 0; a < dim; ++a)
        for (int step : {-1, 1}) {
          IVec<dim> next = cell;
          next[a] += step;
          if (!cells.contains(next)) continue;
          const int k = cells.index(next);
          if (!seen[k] && is_air(k)) seen[k] = 1, pocket.push_back(k);
        }
    }
    if (open || int(pocket.size()) < smallest_air_pocket<dim>) continue;

    // The row: -(sum over the pocket's cells of cell volume x grad N1_c at the cell's centre).
    for (int k : pocket) {
      const IVec<dim> cell = cells.multi_index(k);
      const auto stencil = linear_stencil<dim>(grid.to_cells(grid.dual_cell_centre(cell)), grid.dx);
      for_each_offset<dim, 2>([&](const IVec<dim>& offset) {
        const int c = corners.index(cell + offset);
        if (coefficient[c].isZero()) touched.push_back(c);
        coefficient[c] += grid.cell_volume() * stencil.gradient(offset);
      });
    }
    const int row = air.size();
    const Real negligible = 1e-9 * grid.cell_volume() / grid.dx;  // inner corners cancel to round-off
    bool on_fluid = false;
    std::sort(touched.begin(), touched.end());
    touched.erase(std::unique(touched.begin(), touched.end()), touched.end());
    const std::size_t rows_before = air.rows.size(), solid_before = air.solid_corner_rows.size();
    for (int c : touched) {
      const Vec<dim> g = coefficient[c];
      coefficient[c].setZero();
      if (g.cwiseAbs().maxCoeff() <= negligible) continue;
      const int dof = ops.dof_of_corner[c];
      if (dof >= 0) {
        // No flux through a slip wall: a corner on one is the pocket's boundary there only
        // along the wall (with wall faces its normal velocity is held on average only).
        for (int a = 0; a < dim; ++a)
          if (!ops.wall_sides(dof, a)) air.rows.emplace_back(row, dof * dim + a, -g[a]);
        on_fluid = true;
      } else if (moves_with_solid(c)) {
        air.solid_corner_rows.push_back({row, c, -g});
      }
    }
    touched.clear();
    if (!on_fluid) {  // walled in by solids and walls alone: no water to hold back
      air.rows.resize(rows_before);
      air.solid_corner_rows.resize(solid_before);
      continue;
    }
    air.pockets.push_back(std::move(pocket));
  }
  return air;
}

}  // namespace iqmpm
