// The direct solve's orders of the cells (grid/nested_dissection.h). A dissection of the
// cells a system has orders each of them once, and on a region that fills only part of the
// grid (the dam break's water column) its factor has less fill than the whole grid's
// dissection gives, which is what solver.ordering = cells is for.
#include <cholmod.h>

#include <algorithm>
#include <vector>

#include "grid/kernels.h"
#include "grid/nested_dissection.h"
#include "support/test_helpers.h"

namespace iqmpm {
namespace {

template <class D>
class CellOrderingTest : public ::testing::Test {};
TYPED_TEST_SUITE(CellOrderingTest, testing::Dimensions);

// nnz(L) of the cells' 3^dim-block coupling (the pressure system's pattern) in `order`.
template <int dim>
double factor_entries(const GridLayout<dim>& cells, const std::vector<int>& set, const std::vector<int>& order) {
  std::vector<int> unknown_of(cells.size(), -1);
  for (std::size_t u = 0; u < set.size(); ++u) unknown_of[set[u]] = int(u);
  const int n = int(set.size());
  std::vector<int> start(n + 1, 0), rows;
  for (int u = 0; u < n; ++u) {  // the upper triangle, column by column
    const IVec<dim> c = cells.multi_index(set[u]);
    std::vector<int> column;
    for_each_offset<dim, 3>([&](const IVec<dim>& offset) {
      const IVec<dim> neighbour = c + offset - IVec<dim>::Ones();
      if (!cells.contains(neighbour)) return;
      const int v = unknown_of[cells.index(neighbour)];
      if (v >= 0 && v <= u) column.push_back(v);
    });
    std::sort(column.begin(), column.end());
    rows.insert(rows.end(), column.begin(), column.end());
    start[u + 1] = int(rows.size());
  }
  cholmod_common common;
  cholmod_start(&common);
  cholmod_sparse pattern{};
  pattern.nrow = pattern.ncol = n;
  pattern.nzmax = rows.size();
  pattern.p = start.data();
  pattern.i = rows.data();
  pattern.stype = 1;
  pattern.itype = CHOLMOD_INT;
  pattern.xtype = CHOLMOD_PATTERN;
  pattern.dtype = CHOLMOD_DOUBLE;
  pattern.sorted = pattern.packed = 1;
  common.nmethods = 1;
  common.method[0].ordering = CHOLMOD_GIVEN;
  common.supernodal = CHOLMOD_SIMPLICIAL;
  std::vector<int> permutation(order);
  cholmod_factor* L = cholmod_analyze_p(&pattern, permutation.data(), nullptr, 0, &common);
  const double entries = L ? common.lnz : -1;
  cholmod_free_factor(&L, &common);
  cholmod_finish(&common);
  return entries;
}

// Water columns that fill part of the grid: one in a corner with a thin layer along the
// floor (its width not a power of two, as the dam break's is not), one across the grid's
// middle, where the grid's first separator runs down the column's length. Every cell is
// ordered once, and the cells' dissection has less fill (nnz(L)) than the grid's (measured
// ratios beside the regions, asserted with a margin).
TYPED_TEST(CellOrderingTest, EveryCellOnceAndLessFillThanTheWholeGridsOrder) {
  constexpr int dim = TypeParam::value;
  const int side = dim == 2 ? 128 : 32;
  const IVec<dim> extent = IVec<dim>::Constant(side);
  const GridLayout<dim> cells(IVec<dim>::Zero(), extent);
  struct Region {
    int x0, x1, height;  // the column [x0, x1) wide (in x and, in 3-D, z), height tall
    bool layer;          // and a layer two cells thick along the floor
    double largest_ratio;
  };
  const std::vector<Region> regions =
      dim == 2 ? std::vector<Region>{{0, 38, 83, true, 0.95}, {45, 83, 83, false, 0.9}}     // measured 0.901, 0.839
               : std::vector<Region>{{0, 10, 21, true, 0.85}, {11, 21, 21, false, 0.85}};  // measured 0.770, 0.765
  for (const Region& region : regions) {
    std::vector<int> set;
    for (int k = 0; k < cells.size(); ++k) {
      const IVec<dim> c = cells.multi_index(k);
      const bool across = c[0] >= region.x0 && c[0] < region.x1 && (dim == 2 || (c[dim - 1] >= region.x0 && c[dim - 1] < region.x1));
      if ((across && c[1] < region.height) || (region.layer && c[1] < 2 && (dim == 2 || c[dim - 1] < region.x1))) set.push_back(k);
    }
    const std::vector<int> by_cells = CellOrdering<dim>::occupied_cells(cells).order(set);
    const std::vector<int> by_grid = CellOrdering<dim>::whole_grid(cells, extent).order(set);
    std::vector<int> sorted = by_cells;
    std::sort(sorted.begin(), sorted.end());
    std::vector<int> identity(set.size());
    for (std::size_t u = 0; u < identity.size(); ++u) identity[u] = int(u);
    EXPECT_EQ(sorted, identity);  // a permutation of the unknowns

    const double cells_fill = factor_entries<dim>(cells, set, by_cells);
    const double grid_fill = factor_entries<dim>(cells, set, by_grid);
    ASSERT_GT(grid_fill, 0);
    EXPECT_LT(cells_fill, region.largest_ratio * grid_fill)
        << "column from " << region.x0 << ": " << cells_fill << " against " << grid_fill << ", ratio " << cells_fill / grid_fill;
  }
}

}  // namespace
}  // namespace iqmpm
