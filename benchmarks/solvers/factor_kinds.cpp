// CHOLMOD's two kinds of factor on dumped pressure systems (`iqmpm run ... --dump-system N`):
// simplicial LDL^T against supernodal LL^T, both in the order the solver uses (the grid's
// nested dissection, grid/nested_dissection.h, unknowns of one cell in index order), one
// core, BLAS on one thread. The ratio of flops to nnz(L) at which supernodal starts to win
// is the LDL^T solver's supernodal switch (linear_solver/direct_solvers.cpp).
//
// Build and run from the repository root (see README.md beside it):
//   g++ -O2 -std=c++17 -Impm -I/usr/include/eigen3 -I/usr/include/suitesparse
//     benchmarks/solvers/factor_kinds.cpp -o out/factor_kinds -lcholmod   (one line)
//   OMP_NUM_THREADS=1 out/factor_kinds DUMP_DIR:STEP [DUMP_DIR:STEP ...]
// Prints a Markdown table: unknowns, nnz(L), flops / nnz(L), the fastest of 5
// factorisations of each kind (ms) and their ratio.
#include <Eigen/CholmodSupport>
#include <Eigen/SparseCore>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "grid/nested_dissection.h"

namespace {

struct Dump {
  std::string name;
  int n = 0, dim = 0;
  Eigen::SparseMatrix<double> matrix;  // both triangles, as dumped
  std::vector<int> order;  // the solver's elimination order
};

[[noreturn]] void fail(const std::string& message) {
  std::cerr << "factor_kinds: " << message << "\n";
  std::exit(2);
}

template <int dim>
std::vector<int> cell_ranks(const std::vector<int>& cells) {
  iqmpm::IVec<dim> extent;
  for (int a = 0; a < dim; ++a) extent[a] = cells[a];
  const iqmpm::GridLayout<dim> layout(iqmpm::IVec<dim>::Zero(), extent);
  return iqmpm::nested_dissection_rank<dim>(layout, extent);
}

Dump read_dump(const std::string& argument) {
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
  const std::vector<int> rank = dump.dim == 2 ? cell_ranks<2>(cells) : cell_ranks<3>(cells);
  std::vector<std::pair<int, int>> keyed(dump.n);
  for (int u = 0; u < dump.n; ++u) keyed[u] = {u < int(dual_cell.size()) && dual_cell[u] >= 0 ? rank[dual_cell[u]] : 0, u};
  std::sort(keyed.begin(), keyed.end());
  for (const auto& [r, u] : keyed) dump.order.push_back(u);
  return dump;
}

struct Timing {
  double milliseconds = 0, lnz = 0, flops = 0;
  bool supernodal = false;
};

// The fastest of 5 numeric factorisations after one analysis.
Timing factorise(Dump& dump, bool supernodal) {
  cholmod_common common;
  cholmod_start(&common);
  common.nmethods = 1;
  common.method[0].ordering = CHOLMOD_GIVEN;
  common.postorder = true;
  common.supernodal = supernodal ? CHOLMOD_SUPERNODAL : CHOLMOD_SIMPLICIAL;
  common.final_ll = supernodal;  // the solver's simplicial factor is LDL^T
  const Eigen::SparseMatrix<double>& full = dump.matrix;
  cholmod_sparse A = Eigen::viewAsCholmod(full.selfadjointView<Eigen::Upper>());  // stype 1: the upper triangle
  cholmod_factor* L = cholmod_analyze_p(&A, dump.order.data(), nullptr, 0, &common);
  if (!L) fail("analysis failed on " + dump.name);
  Timing timing;
  timing.lnz = common.lnz;
  timing.flops = common.fl;
  timing.milliseconds = 1e30;
  for (int round = 0; round < 5; ++round) {
    const auto start = std::chrono::steady_clock::now();
    cholmod_factorize(&A, L, &common);
    const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
    if (common.status != CHOLMOD_OK) fail("factorisation failed on " + dump.name);
    timing.milliseconds = std::min(timing.milliseconds, ms);
  }
  timing.supernodal = L->is_super;
  cholmod_free_factor(&L, &common);
  cholmod_finish(&common);
  return timing;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) fail("usage: factor_kinds DUMP_DIR:STEP [DUMP_DIR:STEP ...]");
  std::vector<Dump> dumps;  // all read first: a missing file stops before any output
  for (int k = 1; k < argc; ++k) dumps.push_back(read_dump(argv[k]));
  std::printf("| matrix | dim | unknowns | nnz(L) | flops / nnz(L) | simplicial LDL^T (ms) | supernodal LL^T (ms) | simplicial / supernodal |\n");
  std::printf("|---|---|---|---|---|---|---|---|\n");
  for (Dump& dump : dumps) {
    const Timing simplicial = factorise(dump, false), supernodal = factorise(dump, true);
    std::printf("| %s | %d | %d | %.3g | %.0f | %.1f | %.1f | %.2f |\n", dump.name.c_str(), dump.dim, dump.n, simplicial.lnz,
                simplicial.flops / simplicial.lnz, simplicial.milliseconds, supernodal.milliseconds,
                simplicial.milliseconds / supernodal.milliseconds);
  }
}
