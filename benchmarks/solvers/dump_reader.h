// Reading a pressure system dumped by `iqmpm run ... --dump-system N` (system_stepN.mtx,
// both triangles, and layout_stepN.json, each unknown's dual cell) with a direct solver's
// elimination order (grid/nested_dissection.h, unknowns of one cell in index order): the
// grid's nested dissection (solver.ordering = grid) or that of the cells the system has
// (cells, the default), for the benchmarks beside this file.
#pragma once

#include <Eigen/SparseCore>

#include <algorithm>
#include <cstdlib>
#include <fstream>
#include <iostream>
#include <nlohmann/json.hpp>
#include <string>
#include <utility>
#include <vector>

#include "grid/nested_dissection.h"

namespace dumped {

struct Dump {
  std::string name;
  int n = 0, dim = 0;
  Eigen::SparseMatrix<double> matrix;  // both triangles, as dumped
  std::vector<int> order;  // the solver's elimination order
};

[[noreturn]] inline void fail(const std::string& message) {
  std::cerr << "benchmark: " << message << "\n";
  std::exit(2);
}

enum class Ordering { grid, cells };

// rank[cell] for the grid's cells (`extent` per axis); by `ordering`, of the whole grid or
// of the cells in `present` (others keep rank 0).
template <int dim>
std::vector<int> cell_ranks(const std::vector<int>& extent_per_axis, Ordering ordering, const std::vector<int>& present) {
  iqmpm::IVec<dim> extent;
  for (int a = 0; a < dim; ++a) extent[a] = extent_per_axis[a];
  const iqmpm::GridLayout<dim> layout(iqmpm::IVec<dim>::Zero(), extent);
  if (ordering == Ordering::grid) return iqmpm::nested_dissection_rank<dim>(layout, extent);
  std::vector<int> rank(layout.size(), 0);
  const std::vector<int> order = iqmpm::nested_dissection_of_cells<dim>(layout, present);
  for (std::size_t k = 0; k < order.size(); ++k) rank[order[k]] = int(k);
  return rank;
}

inline Dump read_dump(const std::string& argument, Ordering ordering = Ordering::grid) {
  const auto colon = argument.rfind(':');
  if (colon == std::string::npos) fail("expected DUMP_DIR:STEP, got '" + argument + "'");
  const std::string dir = argument.substr(0, colon), step = argument.substr(colon + 1);
  Dump dump;
  dump.name = dir + " step " + step;
  std::ifstream matrix(dir + "/system_step" + step + ".mtx");
  if (!matrix) fail("cannot read " + dir + "/system_step" + step + ".mtx");
  std::string line;
  std::getline(matrix, line);
  long rows, columns, entries;
  matrix >> rows >> columns >> entries;
  std::vector<Eigen::Triplet<double>> triplets;
  for (long e = 0; e < entries; ++e) {
    long i, j;
    double v;
    matrix >> i >> j >> v;
    triplets.emplace_back(int(i - 1), int(j - 1), v);
  }
  dump.n = int(rows);
  dump.matrix.resize(rows, columns);
  dump.matrix.setFromTriplets(triplets.begin(), triplets.end());
  std::ifstream layout_file(dir + "/layout_step" + step + ".json");
  if (!layout_file) fail("cannot read " + dir + "/layout_step" + step + ".json");
  const nlohmann::json layout = nlohmann::json::parse(layout_file);
  const auto cells = layout.at("cells").get<std::vector<int>>();
  const auto dual_cell = layout.at("dual_cell").get<std::vector<int>>();
  dump.dim = int(cells.size());
  std::vector<int> present;
  for (int c : dual_cell)
    if (c >= 0) present.push_back(c);
  std::sort(present.begin(), present.end());
  present.erase(std::unique(present.begin(), present.end()), present.end());
  const std::vector<int> rank =
      dump.dim == 2 ? cell_ranks<2>(cells, ordering, present) : cell_ranks<3>(cells, ordering, present);
  std::vector<std::pair<int, int>> keyed(dump.n);
  for (int u = 0; u < dump.n; ++u) keyed[u] = {u < int(dual_cell.size()) && dual_cell[u] >= 0 ? rank[dual_cell[u]] : 0, u};
  std::sort(keyed.begin(), keyed.end());
  for (const auto& [r, u] : keyed) dump.order.push_back(u);
  return dump;
}

}  // namespace dumped
