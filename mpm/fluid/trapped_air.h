// Air trapped by the water (experimental.trapped_air = incompressible; docs/method.md#trapped-air).
// Without it an empty dual cell is air at p = 0 wherever it is, so water closing over a
// cavity falls into it freely. With it, every face-connected set of empty cells that does not
// reach the top layer of cells (the open air) and spans at least 2^dim cells is a pocket with
// one pressure unknown, uniform over the pocket, and one row: the sum of its cells' divergence
// rows by the centre rule on full cells, -(d/dt of the pocket's volume). Summed over a
// connected set the corners inside it cancel, so the row holds the flux through the pocket's
// boundary only: the corners it shares with water or a solid (and on a wall, along the wall).
// Water floating inside the pocket (drops, spray) counts with the pocket's cells, so that its
// corners are inside too: a drop's corners are light (a particle's far tail), and as the
// pocket's boundary they would let its volume out at almost no pressure.
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
  auto is_water = [&](int k) { return ops.pressure_of_cell[k] >= 0; };
  auto for_each_face_neighbour = [&](int k, auto&& f) {
    const IVec<dim> cell = cells.multi_index(k);
    for (int a = 0; a < dim; ++a)
      for (int step : {-1, 1}) {
        IVec<dim> next = cell;
        next[a] += step;
        if (cells.contains(next)) f(cells.index(next));
      }
  };
  // Face-connected sets of cells that pass `member`, labelled in `label`.
  auto label_sets = [&](auto member, std::vector<int>& label) {
    std::vector<std::vector<int>> sets;
    label.assign(cells.size(), -1);
    for (int start = 0; start < cells.size(); ++start) {
      if (label[start] >= 0 || !member(start)) continue;
      std::vector<int> set{start};
      label[start] = int(sets.size());
      for (std::size_t q = 0; q < set.size(); ++q)
        for_each_face_neighbour(set[q], [&](int k) {
          if (label[k] < 0 && member(k)) label[k] = label[start], set.push_back(k);
        });
      sets.push_back(std::move(set));
    }
    return sets;
  };
  std::vector<int> air_set, water_set;
  std::vector<std::vector<int>> air_sets = label_sets(is_air, air_set);
  std::vector<char> is_pocket(air_sets.size());
  for (std::size_t id = 0; id < air_sets.size(); ++id) {
    bool open = false;
    for (int k : air_sets[id]) open = open || cells.multi_index(k)[up.axis] == top;
    is_pocket[id] = !open && int(air_sets[id].size()) >= smallest_air_pocket<dim>;
  }
  if (std::find(is_pocket.begin(), is_pocket.end(), 1) == is_pocket.end()) return air;  // most steps: no water to label
  // Water that floats inside one pocket (a drop, spray: a set of water cells whose every
  // other neighbour is that pocket's air or a wall) is inside it: the pocket's boundary is
  // the surface of the water around it, and the drop's own rows keep the drop's volume.
  std::vector<std::vector<int>> floating(air_sets.size());
  for (const auto& set : label_sets(is_water, water_set)) {
    int pocket = -1;
    bool enclosed = true;
    for (int k : set)
      for_each_face_neighbour(k, [&](int j) {
        if (is_water(j)) return;
        if (!is_air(j) || (pocket >= 0 && air_set[j] != pocket)) enclosed = false;
        else pocket = air_set[j];
      });
    if (enclosed && pocket >= 0 && is_pocket[pocket]) floating[pocket].insert(floating[pocket].end(), set.begin(), set.end());
  }

  std::vector<Vec<dim>> coefficient(corners.size(), Vec<dim>::Zero());
  std::vector<int> touched;
  for (std::size_t id = 0; id < air_sets.size(); ++id) {
    if (!is_pocket[id]) continue;
    std::vector<int>& pocket = air_sets[id];
    // The row: -(sum over the pocket's cells, and the water floating in it, of cell volume x
    // grad N1_c at the cell's centre).
    auto add_cell = [&](int k) {
      const IVec<dim> cell = cells.multi_index(k);
      const auto stencil = linear_stencil<dim>(grid.to_cells(grid.dual_cell_centre(cell)), grid.dx);
      for_each_offset<dim, 2>([&](const IVec<dim>& offset) {
        const int c = corners.index(cell + offset);
        if (coefficient[c].isZero()) touched.push_back(c);
        coefficient[c] += grid.cell_volume() * stencil.gradient(offset);
      });
    };
    for (int k : pocket) add_cell(k);
    for (int k : floating[id]) add_cell(k);
    const int row = air.size();
    const Real negligible = 1e-9 * grid.cell_volume() / grid.dx;  // inner corners cancel to round-off
    std::sort(touched.begin(), touched.end());
    touched.erase(std::unique(touched.begin(), touched.end()), touched.end());
    std::vector<Triplet> rows;
    std::vector<typename FluidOperators<dim>::CornerEntry> on_solid;
    for (int c : touched) {
      const Vec<dim> g = coefficient[c];
      coefficient[c].setZero();
      if (g.cwiseAbs().maxCoeff() <= negligible) continue;
      const int dof = ops.dof_of_corner[c];
      if (dof >= 0) {
        // No flux through a slip wall: a corner on one is the pocket's boundary there only
        // along the wall (with wall faces its normal velocity is held on average only).
        for (int a = 0; a < dim; ++a)
          if (!ops.wall_sides(dof, a)) rows.emplace_back(row, dof * dim + a, -g[a]);
      } else if (moves_with_solid(c)) {
        on_solid.push_back({row, c, -g});
      }
    }
    touched.clear();
    if (rows.empty()) continue;  // walled in by solids and walls alone: no water to hold back
    air.rows.insert(air.rows.end(), rows.begin(), rows.end());
    air.solid_corner_rows.insert(air.solid_corner_rows.end(), on_solid.begin(), on_solid.end());
    air.pockets.push_back(std::move(pocket));
  }
  return air;
}

}  // namespace iqmpm
