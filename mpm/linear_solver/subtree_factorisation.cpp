#include "linear_solver/subtree_factorisation.h"

#include <algorithm>
#include <cmath>
#include <thread>

namespace iqmpm {

SubtreeSchedule plan_subtree_schedule(cholmod_sparse* S, const cholmod_factor* L, cholmod_common* common) {
  const int n = int(L->n);
  SubtreeSchedule one_thread;
  one_thread.after.emplace_back(0, n);
  SubtreeSchedule schedule;
  if (n < 2) return one_thread;
  std::vector<int> parent(n);
  if (!cholmod_etree(S, parent.data(), common)) return one_thread;
  const int* colcount = static_cast<const int*>(L->ColCount);
  std::vector<double> work(n);  // of the subtree rooted at each node
  std::vector<int> size(n, 1);
  std::vector<std::vector<int>> children(n);
  for (int j = 0; j < n; ++j) work[j] = double(colcount[j]) * colcount[j];
  for (int j = 0; j < n; ++j) {
    if (parent[j] < 0) continue;
    if (parent[j] <= j) return one_thread;  // not postordered: no contiguous subtrees
    work[parent[j]] += work[j], size[parent[j]] += size[j];
    children[parent[j]].push_back(j);
  }
  std::vector<int> frontier;  // the roots of the forest, or the children below the top chain
  for (int j = 0; j < n; ++j)
    if (parent[j] < 0) frontier.push_back(j);
  while (frontier.size() == 1 && !children[frontier[0]].empty()) frontier = children[frontier[0]];
  std::vector<int> bins[2];
  for (int round = 0; round < 256 && !frontier.empty(); ++round) {
    std::sort(frontier.begin(), frontier.end(), [&](int a, int b) { return work[a] > work[b]; });
    double load[2] = {0, 0};
    bins[0].clear(), bins[1].clear();
    for (int root : frontier) {
      const int b = load[0] <= load[1] ? 0 : 1;
      bins[b].push_back(root), load[b] += work[root];
    }
    schedule.bin_work[0] = load[0], schedule.bin_work[1] = load[1];
    if (std::abs(load[0] - load[1]) <= 0.1 * (load[0] + load[1])) break;
    const int heaviest = frontier[0];
    if (children[heaviest].empty()) break;
    frontier.erase(frontier.begin());
    frontier.insert(frontier.end(), children[heaviest].begin(), children[heaviest].end());
  }
  if (std::abs(schedule.bin_work[0] - schedule.bin_work[1]) > 0.1 * (schedule.bin_work[0] + schedule.bin_work[1]))
    return one_thread;
  std::vector<char> in_bin(n, 0);
  for (int b = 0; b < 2; ++b) {
    std::sort(bins[b].begin(), bins[b].end());
    for (int root : bins[b]) {
      schedule.bins[b].emplace_back(root - size[root] + 1, root + 1);
      std::fill(in_bin.begin() + (root - size[root] + 1), in_bin.begin() + root + 1, 1);
    }
  }
  for (int k = 0; k < n; ++k) {
    if (in_bin[k]) continue;
    schedule.after_work += double(colcount[k]) * colcount[k];
    if (!schedule.after.empty() && schedule.after.back().second == k) ++schedule.after.back().second;
    else schedule.after.emplace_back(k, k + 1);
  }
  return schedule;
}

bool factorise_by_subtrees(cholmod_sparse* S, cholmod_factor* L, const SubtreeSchedule& schedule,
                           cholmod_common* first, cholmod_common* second) {
  double beta[2] = {0, 0};
  const int n = int(L->n);
  L->is_ll = first->final_ll ? 1 : 0;
  if (L->xtype == CHOLMOD_PATTERN) {
    // No rows: allocates the numeric factor with exactly its column counts, as
    // cholmod_factorize does for a packed final factor.
    const double grow2 = first->grow2;
    first->grow2 = 0;
    const int allocated = cholmod_rowfac(S, nullptr, beta, 0, 0, L, first);
    first->grow2 = grow2;
    if (!allocated) return false;
  }
  // A refactorisation starts from empty columns (what rowfac does itself for all rows).
  int* column_count = static_cast<int*>(L->nz);
  std::fill(column_count, column_count + n, 1);
  L->minor = n;
  auto rows = [&](const std::vector<std::pair<int, int>>& ranges, cholmod_common* common) {
    bool ok = true;
    for (const auto& [begin, end] : ranges) ok = cholmod_rowfac(S, nullptr, beta, begin, end, L, common) && ok;
    return ok;
  };
  bool first_ok = true, second_ok = true;
  if (schedule.split()) {
    std::thread helper([&] { second_ok = rows(schedule.bins[1], second); });
    first_ok = rows(schedule.bins[0], first);
    helper.join();
  }
  const bool after_ok = rows(schedule.after, first);
  return first_ok && second_ok && after_ok && L->minor == std::size_t(n);
}

}  // namespace iqmpm
