// The 2-D direct solve's two-thread kernels (linear_solver/subtree_factorisation.h) on
// dumped pressure systems (`iqmpm run ... --dump-system N`), in the solver's default order
// (the nested dissection of the system's cells): the simplicial LDL^T factorisation by
// subtrees on one and two threads against cholmod_factorize, and the triangular solves by
// the same subtrees against cholmod_solve on that factor.
//
// Built with the solver (CMakeLists.txt); run from the repository root:
//   build/subtree_solves DUMP_DIR:STEP [DUMP_DIR:STEP ...]
// Prints a Markdown table: unknowns, the plan's predicted share of one thread's work, the
// median of 15 constructions of S = triu(P A P') (CHOLMOD's transposes, the solver's own on
// one and two threads, checked equal), the fastest of 7 factorisations and the fastest and
// median of 60 solves of each kind (ms, the kinds alternating), and the largest difference
// of the solves' solutions.
#include <Eigen/CholmodSupport>
#include <Eigen/SparseCore>
#include <omp.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <functional>
#include <random>
#include <string>
#include <vector>

#include "dump_reader.h"
#include "linear_solver/subtree_factorisation.h"

namespace {

using dumped::Dump;
using dumped::fail;
using Clock = std::chrono::steady_clock;

double milliseconds_of(const std::function<void()>& work) {
  const auto start = Clock::now();
  work();
  return std::chrono::duration<double, std::milli>(Clock::now() - start).count();
}

double median(std::vector<double> values) {
  std::sort(values.begin(), values.end());
  return values[values.size() / 2];
}

double fastest(const std::vector<double>& values) { return *std::min_element(values.begin(), values.end()); }

void measure(const Dump& dump) {
  cholmod_common common[2];
  for (cholmod_common& c : common) {
    cholmod_start(&c);
    c.nmethods = 1;
    c.method[0].ordering = CHOLMOD_GIVEN;
    c.supernodal = CHOLMOD_SIMPLICIAL;
    c.final_ll = false;  // LDL^T, as the solver's
  }
  const Eigen::SparseMatrix<double> upper = dump.matrix.triangularView<Eigen::Upper>();
  cholmod_sparse A = Eigen::viewAsCholmod(upper);
  A.stype = 1;
  std::vector<int> order = dump.order;
  cholmod_factor* reference = cholmod_analyze_p(&A, order.data(), nullptr, 0, &common[0]);
  cholmod_factor* L = cholmod_analyze_p(&A, order.data(), nullptr, 0, &common[0]);
  if (!reference || !L) fail("analysis failed on " + dump.name);
  // S = triu(P A P'), as the solver builds it.
  cholmod_sparse* lower = cholmod_ptranspose(&A, 2, static_cast<int*>(L->Perm), nullptr, 0, &common[0]);
  cholmod_sparse* S = cholmod_ptranspose(lower, 2, nullptr, nullptr, 0, &common[0]);
  const iqmpm::SubtreeSchedule schedule = iqmpm::plan_subtree_schedule(S, L, &common[0]);
  if (!schedule.split()) fail("the plan does not split " + dump.name);
  const double one_thread = schedule.bin_work[0] + schedule.bin_work[1] + schedule.after_work;
  const double predicted = (std::max(schedule.bin_work[0], schedule.bin_work[1]) + schedule.after_work) / one_thread;

  // S itself: CHOLMOD's two permuting transposes against permuted_upper_triangle (the
  // solver's) on one and two threads, which must give the same arrays.
  const Eigen::SparseMatrix<double>& full = dump.matrix;
  const int* perm = static_cast<const int*>(L->Perm);
  std::vector<int> inverse(dump.n);
  for (int k = 0; k < dump.n; ++k) inverse[perm[k]] = k;
  std::vector<double> s_cholmod, s_one, s_two;
  for (int round = 0; round < 15; ++round) {
    s_cholmod.push_back(milliseconds_of([&] {
      cholmod_sparse* l = cholmod_ptranspose(&A, 2, static_cast<int*>(L->Perm), nullptr, 0, &common[0]);
      cholmod_sparse* u = cholmod_ptranspose(l, 2, nullptr, nullptr, 0, &common[0]);
      cholmod_free_sparse(&l, &common[0]);
      cholmod_free_sparse(&u, &common[0]);
    }));
    for (int threads : {1, 2}) {
      omp_set_num_threads(threads);
      cholmod_sparse* ours = nullptr;
      (threads == 1 ? s_one : s_two).push_back(milliseconds_of([&] {
        ours = iqmpm::permuted_upper_triangle(dump.n, full.outerIndexPtr(), full.innerIndexPtr(), full.valuePtr(), perm,
                                              inverse.data(), &common[0]);
      }));
      auto same = [](const void* mine, const void* theirs, std::size_t bytes) {
        return std::memcmp(mine, theirs, bytes) == 0;
      };
      const int nonzeros = static_cast<const int*>(S->p)[dump.n];
      if (!ours || static_cast<const int*>(ours->p)[dump.n] != nonzeros || !same(ours->i, S->i, nonzeros * sizeof(int)) ||
          !same(ours->x, S->x, nonzeros * sizeof(double)))
        fail("permuted_upper_triangle differs from CHOLMOD's transposes on " + dump.name);
      cholmod_free_sparse(&ours, &common[0]);
    }
    omp_set_num_threads(2);
  }

  std::vector<double> factor_cholmod, factor_one, factor_two;
  for (int round = 0; round < 7; ++round) {
    factor_cholmod.push_back(milliseconds_of([&] { cholmod_factorize(&A, reference, &common[0]); }));
    for (int threads : {1, 2}) {
      bool ok = false;
      const double ms = milliseconds_of([&] { ok = iqmpm::factorise_by_subtrees(S, L, schedule, threads, &common[0], &common[1]); });
      if (!ok) fail("factorisation by subtrees failed on " + dump.name);
      (threads == 1 ? factor_one : factor_two).push_back(ms);
    }
  }

  std::mt19937 rng(1);
  std::uniform_real_distribution<double> uniform(-1, 1);
  Eigen::VectorXd b(dump.n), x_one(dump.n), x_two(dump.n);
  for (double& v : b) v = uniform(rng);
  cholmod_dense rhs = Eigen::viewAsCholmod(b);
  iqmpm::SubtreeSolveWorkspace workspace;
  std::vector<double> solve_cholmod, solve_one, solve_two;
  double difference = 0, size = 0;
  for (int round = 0; round < 60; ++round) {
    cholmod_dense* x = nullptr;
    solve_cholmod.push_back(milliseconds_of([&] { x = cholmod_solve(CHOLMOD_A, L, &rhs, &common[0]); }));
    if (!x) fail("cholmod_solve failed on " + dump.name);
    solve_one.push_back(milliseconds_of([&] { iqmpm::solve_by_subtrees(L, schedule, 1, b.data(), x_one.data(), workspace); }));
    solve_two.push_back(milliseconds_of([&] { iqmpm::solve_by_subtrees(L, schedule, 2, b.data(), x_two.data(), workspace); }));
    const Eigen::Map<const Eigen::VectorXd> x_cholmod(static_cast<const double*>(x->x), dump.n);
    difference = std::max(difference, (x_two - x_cholmod).lpNorm<Eigen::Infinity>());
    size = x_cholmod.lpNorm<Eigen::Infinity>();
    if (x_one != x_two) fail("one and two threads differ on " + dump.name);
    cholmod_free_dense(&x, &common[0]);
  }
  std::printf("| %s | %d | %.2f | %.2f / %.2f / %.2f | %.1f | %.1f | %.1f | %.2f / %.2f | %.2f / %.2f | %.2f / %.2f | %.1e |\n",
              dump.name.c_str(), dump.n, predicted, median(s_cholmod), median(s_one), median(s_two), fastest(factor_cholmod),
              fastest(factor_one), fastest(factor_two), fastest(solve_cholmod), median(solve_cholmod), fastest(solve_one),
              median(solve_one), fastest(solve_two), median(solve_two), difference / size);
  cholmod_free_sparse(&lower, &common[0]);
  cholmod_free_sparse(&S, &common[0]);
  cholmod_free_factor(&L, &common[0]);
  cholmod_free_factor(&reference, &common[0]);
  for (cholmod_common& c : common) cholmod_finish(&c);
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) fail("usage: subtree_solves DUMP_DIR:STEP [DUMP_DIR:STEP ...]");
  std::vector<Dump> dumps;  // all read first: a missing file stops before any output
  for (int k = 1; k < argc; ++k) dumps.push_back(dumped::read_dump(argv[k], dumped::Ordering::cells));
  std::printf("| matrix | unknowns | predicted (of one thread) | S = triu(P A P'): CHOLMOD's transposes / ours on 1 / 2 "
              "threads (median, ms) | factorise: cholmod (ms) | subtrees, 1 thread | 2 threads | "
              "solve: cholmod_solve (fastest / median, ms) | subtrees, 1 thread | 2 threads | largest difference / |x| |\n");
  std::printf("|---|---|---|---|---|---|---|---|---|---|---|\n");
  for (const Dump& dump : dumps) measure(dump);
}
