// CHOLMOD's two kinds of factor on dumped pressure systems (`iqmpm run ... --dump-system N`):
// simplicial LDL^T against supernodal LL^T, both in the order the solver uses (the grid's
// nested dissection, grid/nested_dissection.h, unknowns of one cell in index order), one
// core, BLAS on one thread. The ratio of flops to nnz(L) at which supernodal starts to win
// is the LDL^T solver's supernodal switch (linear_solver/direct_solvers.cpp).
//
// Built with the solver (CMakeLists.txt); run from the repository root:
//   OMP_NUM_THREADS=1 build/factor_kinds DUMP_DIR:STEP [DUMP_DIR:STEP ...]
// Prints a Markdown table: unknowns, nnz(L), flops / nnz(L), the fastest of 5
// factorisations of each kind (ms) and their ratio.
#include <Eigen/CholmodSupport>
#include <Eigen/SparseCore>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <string>
#include <vector>

#include "dump_reader.h"

namespace {

using dumped::Dump;
using dumped::fail;

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
  for (int k = 1; k < argc; ++k) dumps.push_back(dumped::read_dump(argv[k]));
  std::printf("| matrix | dim | unknowns | nnz(L) | flops / nnz(L) | simplicial LDL^T (ms) | supernodal LL^T (ms) | simplicial / supernodal |\n");
  std::printf("|---|---|---|---|---|---|---|---|\n");
  for (Dump& dump : dumps) {
    const Timing simplicial = factorise(dump, false), supernodal = factorise(dump, true);
    std::printf("| %s | %d | %d | %.3g | %.0f | %.1f | %.1f | %.2f |\n", dump.name.c_str(), dump.dim, dump.n, simplicial.lnz,
                simplicial.flops / simplicial.lnz, simplicial.milliseconds, supernodal.milliseconds,
                simplicial.milliseconds / supernodal.milliseconds);
  }
}
