// Fill-reducing elimination orders of the dual cells for the direct solve: geometric
// nested dissection. The pressure system couples cells that share a corner (the 3^dim
// block around each cell), so a slab one cell thick across the longest axis separates the
// two sides; each side is ordered the same way, recursively, and the slab comes after
// both. A direct solve orders each step's unknowns by their cell's rank instead of running
// a fill-reducing ordering (AMD) on every step's new pattern (issue 21; AMD was 9 % of a
// 2-D run at a/128, method.md#linear-solver): by a dissection of the whole grid, fixed for
// the run (on a regular grid the order with the least fill up to a constant, George 1973),
// or of the cells the step's system has (solver.ordering = cells, the default), which
// follows the water instead of the grid.
#pragma once

#include <omp.h>

#include <algorithm>
#include <cstddef>
#include <utility>
#include <vector>

#include "core/buckets.h"
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

// The same dissection of a set of cells (layout indices of `cells`, each once) rather than
// of the whole grid: each part is cut by a slab across the longest axis of its own bounding
// box, at its middle, so the separators cut the cells that are there (the water), not the
// grid's empty regions. Returns the cells in elimination order. On the dam break at a/128
// its factor takes 0.69-0.89 of the flops of the grid's order (1.03e8 against 1.5e8 with
// the water still a column, 7.8e7 against 8.8e7 later), as few as METIS's nested
// dissection of the matrix, in 1.5 ms (method.md#linear-solver).
template <int dim>
std::vector<int> nested_dissection_of_cells(const GridLayout<dim>& cells, const std::vector<int>& set) {
  struct Cell {
    IVec<dim> at;
    int index;
  };
  std::vector<Cell> part(set.size());
  for (std::size_t k = 0; k < set.size(); ++k) part[k] = {cells.multi_index(set[k]), set[k]};
  // The two sides of the first large part are dissected at once on two threads (each into
  // its own order, joined in the same sequence: the order does not depend on the threads).
  constexpr std::ptrdiff_t kCellsForTwoThreads = 8192;
  auto dissect = [&](auto&& self, Cell* begin, Cell* end, std::vector<int>& order) -> void {
    if (end == begin) return;
    IVec<dim> lo = begin->at, hi = lo;
    for (const Cell* c = begin + 1; c != end; ++c) lo = lo.cwiseMin(c->at), hi = hi.cwiseMax(c->at);
    int axis = 0;
    for (int a = 1; a < dim; ++a)
      if (hi[a] - lo[a] > hi[axis] - lo[axis]) axis = a;
    if (hi[axis] - lo[axis] < 3) {  // too small to gain from a separator: in index order
      std::sort(begin, end, [](const Cell& x, const Cell& y) { return x.index < y.index; });
      for (const Cell* c = begin; c != end; ++c) order.push_back(c->index);
      return;
    }
    // lo < middle < hi, so both sides hold a cell and every part shrinks.
    const int middle = (lo[axis] + hi[axis]) / 2;
    Cell* left_end = std::partition(begin, end, [&](const Cell& c) { return c.at[axis] < middle; });
    Cell* right_end = std::partition(left_end, end, [&](const Cell& c) { return c.at[axis] > middle; });
    if (end - begin >= kCellsForTwoThreads && omp_get_max_threads() >= 2 && !omp_in_parallel()) {
      std::vector<int> right;
#pragma omp parallel sections num_threads(2)
      {
#pragma omp section
        self(self, begin, left_end, order);
#pragma omp section
        self(self, left_end, right_end, right);
      }
      order.insert(order.end(), right.begin(), right.end());
    } else {
      self(self, begin, left_end, order);
      self(self, left_end, right_end, order);
    }
    self(self, right_end, end, order);  // the separator, itself dissected along its own longest axis
  };
  std::vector<int> order;
  order.reserve(set.size());
  dissect(dissect, part.data(), part.data() + part.size(), order);
  return order;
}

// The elimination order of a system's unknowns: by the rank of their dual cell
// (`cell_of_unknown[u]`), unknowns of one cell in index order (a system's blocks follow one
// another, so that is block order). A counting sort by rank (sorting (rank, index) pairs
// cost 1.1 ms a step at a/128).
inline std::vector<int> order_by_cell_rank(const std::vector<int>& cell_of_unknown, const std::vector<int>& rank) {
  std::vector<int> rank_of_unknown(cell_of_unknown.size());
  int ranks = 0;
  for (std::size_t u = 0; u < cell_of_unknown.size(); ++u)
    rank_of_unknown[u] = rank[cell_of_unknown[u]], ranks = std::max(ranks, rank_of_unknown[u] + 1);
  return bucket_by_key(rank_of_unknown, ranks).items;
}

// The direct solve's elimination order of a system's unknowns by their dual cells
// (solver.ordering): the grid's nested dissection, ranked once for the run, or a nested
// dissection of the cells the system has, each step. Empty: no order (the solver's AMD).
template <int dim>
class CellOrdering {
 public:
  CellOrdering() = default;
  static CellOrdering whole_grid(const GridLayout<dim>& cells, const IVec<dim>& extent) {
    CellOrdering o;
    o.cells_ = cells, o.kind_ = Kind::grid;
    o.rank_ = nested_dissection_rank<dim>(cells, extent);
    return o;
  }
  static CellOrdering occupied_cells(const GridLayout<dim>& cells) {
    CellOrdering o;
    o.cells_ = cells, o.kind_ = Kind::cells;
    return o;
  }
  bool empty() const { return kind_ == Kind::none; }

  // cell_of_unknown[u]: the layout index of unknown u's dual cell (every unknown has one).
  std::vector<int> order(const std::vector<int>& cell_of_unknown) const {
    if (kind_ == Kind::grid) return order_by_cell_rank(cell_of_unknown, rank_);
    if (rank_.size() != std::size_t(cells_.size())) rank_.assign(cells_.size(), -1);
    std::vector<int> set;
    for (int c : cell_of_unknown)
      if (rank_[c] < 0) rank_[c] = 0, set.push_back(c);
    const std::vector<int> cell_order = nested_dissection_of_cells<dim>(cells_, set);
    for (std::size_t k = 0; k < cell_order.size(); ++k) rank_[cell_order[k]] = int(k);
    std::vector<int> order = order_by_cell_rank(cell_of_unknown, rank_);
    for (int c : set) rank_[c] = -1;  // unmarked again, not the whole grid refilled every step
    return order;
  }

 private:
  enum class Kind { none, grid, cells };
  Kind kind_ = Kind::none;
  GridLayout<dim> cells_;
  mutable std::vector<int> rank_;  // grid: fixed; cells: -1 between calls, this call's ranks during one
};

}  // namespace iqmpm
