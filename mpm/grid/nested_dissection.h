// A fill-reducing elimination order of a grid's dual cells, fixed for the run: geometric
// nested dissection. The pressure system couples cells that share a corner (the 3^dim
// block around each cell), so a slab one cell thick across the longest axis separates
// the two halves; each half is ordered the same way, recursively, and the slab comes
// after both. A direct solve orders each step's unknowns by their cell's rank instead of
// running a fill-reducing ordering (AMD) on every step's new pattern (issue 21; AMD was 9 %
// of a 2-D run at a/128, method.md#linear-solver). On a regular grid this is the order with the least
// fill up to a constant (George 1973).
#pragma once

#include <algorithm>
#include <utility>
#include <vector>

#include "grid/grid.h"

namespace iqmpm {

// rank[cell] (layout index of grid.dual_cells()): the cell's place in the order.
template <int dim>
std::vector<int> nested_dissection_rank(const GridLayout<dim>& cells, const IVec<dim>& extent) {
  std::vector<int> rank(cells.size(), -1);
  int next = 0;
  // Cells of the box [lo, hi) in lexicographic order.
  auto order_box = [&](const IVec<dim>& lo, const IVec<dim>& hi) {
    IVec<dim> i = lo;
    while (true) {
      rank[cells.index(i)] = next++;
      int a = 0;
      while (a < dim && ++i[a] == hi[a]) i[a] = lo[a], ++a;
      if (a == dim) return;
    }
  };
  auto dissect = [&](auto&& self, const IVec<dim>& lo, const IVec<dim>& hi) -> void {
    int axis = 0;
    for (int a = 1; a < dim; ++a)
      if (hi[a] - lo[a] > hi[axis] - lo[axis]) axis = a;
    const int width = hi[axis] - lo[axis];
    for (int a = 0; a < dim; ++a)
      if (hi[a] <= lo[a]) return;
    if (width < 4) {  // too small to gain from a separator
      order_box(lo, hi);
      return;
    }
    const int middle = lo[axis] + width / 2;
    IVec<dim> left_hi = hi, right_lo = lo, slab_lo = lo, slab_hi = hi;
    left_hi[axis] = middle;
    right_lo[axis] = middle + 1;
    slab_lo[axis] = middle;
    slab_hi[axis] = middle + 1;
    self(self, lo, left_hi);
    self(self, right_lo, hi);
    self(self, slab_lo, slab_hi);  // the separator, itself dissected along its own longest axis
  };
  dissect(dissect, IVec<dim>::Zero(), extent);
  return rank;
}

// The elimination order of a system's unknowns: by the rank of their dual cell
// (`cell_of_unknown[u]`), unknowns of one cell in index order (a system's blocks follow one
// another, so that is block order).
inline std::vector<int> order_by_cell_rank(const std::vector<int>& cell_of_unknown, const std::vector<int>& rank) {
  std::vector<std::pair<int, int>> keyed(cell_of_unknown.size());
  for (std::size_t u = 0; u < keyed.size(); ++u) keyed[u] = {rank[cell_of_unknown[u]], int(u)};
  std::sort(keyed.begin(), keyed.end());
  std::vector<int> order(keyed.size());
  for (std::size_t k = 0; k < keyed.size(); ++k) order[k] = keyed[k].second;
  return order;
}

}  // namespace iqmpm
