#include "linear_solver/subtree_factorisation.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <thread>
#include <utility>
#include <vector>

#include "core/buckets.h"

namespace iqmpm {

// A split is taken where its predicted time is at most this share of one thread's; else
// the factorisation runs on one thread.
constexpr double kLeastGain = 0.8;

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
  for (int j = 0; j < n; ++j) work[j] = double(colcount[j]) * colcount[j];
  for (int j = 0; j < n; ++j) {
    if (parent[j] < 0) continue;
    if (parent[j] <= j) return one_thread;  // not postordered: no contiguous subtrees
    work[parent[j]] += work[j], size[parent[j]] += size[j];
  }
  const Buckets children = bucket_by_key(parent, n);  // node j's children, in order
  auto children_begin = [&](int j) { return children.items.begin() + children.start[j]; };
  auto children_end = [&](int j) { return children.items.begin() + children.start[j + 1]; };
  auto has_children = [&](int j) { return children.start[j + 1] > children.start[j]; };
  std::vector<int> frontier;  // the roots of the forest, or the children below the top chain
  for (int j = 0; j < n; ++j)
    if (parent[j] < 0) frontier.push_back(j);
  while (frontier.size() == 1 && has_children(frontier[0]))
    frontier.assign(children_begin(frontier[0]), children_end(frontier[0]));
  // Each split: the frontier's subtrees largest first into the lighter bin, the rest of the
  // rows after the bins. The one with the least predicted time is kept: the heavier bin
  // plus the rows after (one thread's), in column count^2.
  double total = 0;  // the one-thread time
  for (int j = 0; j < n; ++j)
    if (parent[j] < 0) total += work[j];
  std::vector<int> bins[2];
  double best_time = total;
  for (int round = 0; round < 256 && !frontier.empty(); ++round) {
    std::sort(frontier.begin(), frontier.end(), [&](int a, int b) { return work[a] > work[b]; });
    double load[2] = {0, 0};
    std::vector<int> filled[2];
    for (int root : frontier) {
      const int b = load[0] <= load[1] ? 0 : 1;
      filled[b].push_back(root), load[b] += work[root];
    }
    const double after = total - load[0] - load[1];
    if (std::max(load[0], load[1]) + after < best_time) {
      best_time = std::max(load[0], load[1]) + after;
      bins[0] = std::move(filled[0]), bins[1] = std::move(filled[1]);
      schedule.bin_work[0] = load[0], schedule.bin_work[1] = load[1];
    }
    // Rows only join the rows after, so no later split takes less than half the bins' rows
    // plus all of these: (total - after) / 2 + after.
    if (best_time <= (total + after) / 2) break;
    // The heaviest subtree gives way to its children, below its chain of single children
    // (a separator's rows, one after another), so that a round is a branching.
    int heaviest = frontier[0];
    while (children_end(heaviest) - children_begin(heaviest) == 1) heaviest = *children_begin(heaviest);
    if (!has_children(heaviest)) break;
    frontier.erase(frontier.begin());
    frontier.insert(frontier.end(), children_begin(heaviest), children_end(heaviest));
  }
  if (bins[0].empty() || bins[1].empty() || best_time > kLeastGain * total) return one_thread;
  schedule.group.assign(n, SubtreeSchedule::kAfterBins);
  for (int b = 0; b < 2; ++b) {
    std::sort(bins[b].begin(), bins[b].end());
    for (int root : bins[b]) {
      schedule.bins[b].emplace_back(root - size[root] + 1, root + 1);
      std::fill(schedule.group.begin() + (root - size[root] + 1), schedule.group.begin() + root + 1, std::int8_t(b));
    }
  }
  schedule.parent = std::move(parent);
  for (int k = 0; k < n; ++k) {
    if (schedule.group[k] != SubtreeSchedule::kAfterBins) continue;
    schedule.after_work += double(colcount[k]) * colcount[k];
    if (!schedule.after.empty() && schedule.after.back().second == k) ++schedule.after.back().second;
    else schedule.after.emplace_back(k, k + 1);
  }
  return schedule;
}

namespace {

// One thread's dense workspace for row-by-row solves (as CHOLMOD's Xwork, Flag and Iwork).
struct RowWorkspace {
  std::vector<double> w;  // the row being solved for, zero outside it
  std::vector<int> mark;  // of the nodes already on the stack (or touched) for a row
  std::vector<int> stack, touched;
  explicit RowWorkspace(int n) : w(n, 0.0), mark(n, -1), stack(n) {}
};

// What one bin's columns contribute to the rows after the bins, row by row in schedule
// order: the sums they subtract from the row's entries in the columns after the bins, and
// from its pivot.
struct BinContribution {
  std::vector<int> start{0};  // row r's sums: [start[r], start[r + 1])
  std::vector<int> column;
  std::vector<double> sum;
  std::vector<double> pivot_sum;
};

// The columns of the simplicial factor L, as rowfac fills them: column j holds D(j) first,
// then L(k, j) for the rows k computed so far, in order.
struct Columns {
  const int* start;
  const int* next;
  int* count;
  int* row;
  double* value;
  explicit Columns(cholmod_factor* L)
      : start(static_cast<const int*>(L->p)), next(static_cast<const int*>(L->next)),
        count(static_cast<int*>(L->nz)), row(static_cast<int*>(L->i)), value(static_cast<double*>(L->x)) {}
  // L(k, j) = l; false if column j has no room (not the pattern L was analysed for).
  bool append(int j, int k, double l) {
    const int p = start[j] + count[j];
    if (p >= start[next[j]]) return false;
    row[p] = k, value[p] = l, ++count[j];
    return true;
  }
};

// Pushes the path from node i up the elimination tree, while `on_path` holds and its nodes
// are new to this row, onto the stack [top, n), which stays in topological order (rowfac's
// reach of a row's pattern).
template <class OnPath>
void push_path(int i, int row_mark, const std::vector<int>& parent, RowWorkspace& ws, int& top, OnPath on_path) {
  int length = 0;
  for (; i >= 0 && on_path(i) && ws.mark[i] != row_mark; i = parent[i]) ws.stack[top - 1 - length++] = i, ws.mark[i] = row_mark;
  std::reverse(ws.stack.begin() + (top - length), ws.stack.begin() + top);
  top -= length;
}

// One step of a row's up-looking solve: y_j = w_j, w -= L(:, j) y_j, pivot_sum += L(k, j)
// y_j; returns L(k, j) = y_j / D(j). As in rowfac, a zero D(j) leaves column j out (L(k, j)
// = 0).
double eliminate(const Columns& L, int j, double* w, double& pivot_sum) {
  const double y = w[j];
  w[j] = 0;
  const int first = L.start[j], end = first + L.count[j];
  const double d = L.value[first];
  if (d == 0) return 0;
  const int* row = L.row;
  const double* value = L.value;
  for (int p = first + 1; p < end; ++p) w[row[p]] -= value[p] * y;
  const double l = y / d;
  pivot_sum += l * y;
  return l;
}

// Bin b's part of the rows after the bins (the bin's rows computed): for each such row k,
// its entries in the bin's columns and what they subtract from the row's other entries.
bool bin_part_of_rows_after(cholmod_sparse* S, Columns L, const SubtreeSchedule& schedule, int b, RowWorkspace& ws,
                            BinContribution& out) {
  const int n = int(schedule.parent.size());
  const int* Sp = static_cast<const int*>(S->p);
  const int* Si = static_cast<const int*>(S->i);
  const double* Sx = static_cast<const double*>(S->x);
  auto in_bin = [&](int i) { return schedule.group[i] == b; };
  for (const auto& [first, end] : schedule.after)
    for (int k = first; k < end; ++k) {
      int top = n;
      for (int p = Sp[k]; p < Sp[k + 1]; ++p) {
        const int i = Si[p];
        if (!in_bin(i)) continue;
        ws.w[i] = Sx[p];
        push_path(i, k, schedule.parent, ws, top, in_bin);
      }
      // The rows after the bins that this row's solve in the bin's columns reaches: the
      // paths up from the subtrees' roots it reaches (each path's first node is in the
      // root's column, computed as an earlier row, and the rest in the row's pattern).
      ws.touched.clear();
      for (int s = top; s < n; ++s)
        for (int i = schedule.parent[ws.stack[s]]; i >= 0 && i < k && schedule.group[i] == SubtreeSchedule::kAfterBins &&
                                                   ws.mark[i] != k;
             i = schedule.parent[i])
          ws.mark[i] = k, ws.touched.push_back(i);
      double pivot_sum = 0;
      for (int s = top; s < n; ++s) {
        const int j = ws.stack[s];
        if (!L.append(j, k, eliminate(L, j, ws.w.data(), pivot_sum))) return false;
      }
      for (int r : ws.touched) out.column.push_back(r), out.sum.push_back(ws.w[r]), ws.w[r] = 0;
      out.start.push_back(int(out.column.size()));
      out.pivot_sum.push_back(pivot_sum);
    }
  return true;
}

// The rows after the bins, from both bins' contributions: each row's up-looking solve in
// the columns after the bins, then its pivot D(k). Sets L->minor at a zero pivot.
bool rows_after_bins(cholmod_sparse* S, cholmod_factor* factor, const SubtreeSchedule& schedule,
                     const BinContribution (&from)[2], RowWorkspace& ws) {
  const int n = int(schedule.parent.size());
  Columns L(factor);
  const int* Sp = static_cast<const int*>(S->p);
  const int* Si = static_cast<const int*>(S->i);
  const double* Sx = static_cast<const double*>(S->x);
  int r = 0;  // row k's place among the rows after the bins
  for (const auto& [first, end] : schedule.after)
    for (int k = first; k < end; ++k, ++r) {
      const int row_mark = n + k;  // apart from the bins' part's marks (k)
      auto below_k = [k](int i) { return i < k; };
      int top = n;
      for (int p = Sp[k]; p < Sp[k + 1]; ++p) {
        const int i = Si[p];
        if (schedule.group[i] != SubtreeSchedule::kAfterBins) continue;
        ws.w[i] = Sx[p];
        push_path(i, row_mark, schedule.parent, ws, top, below_k);
      }
      double d = ws.w[k];
      ws.w[k] = 0;
      for (const BinContribution& bin : from) {
        d -= bin.pivot_sum[r];
        for (int e = bin.start[r]; e < bin.start[r + 1]; ++e) {
          ws.w[bin.column[e]] += bin.sum[e];
          push_path(bin.column[e], row_mark, schedule.parent, ws, top, below_k);
        }
      }
      double pivot_sum = 0;
      for (int s = top; s < n; ++s) {
        const int j = ws.stack[s];
        if (!L.append(j, k, eliminate(L, j, ws.w.data(), pivot_sum))) return false;
      }
      d -= pivot_sum;
      L.row[L.start[k]] = k;
      L.value[L.start[k]] = d;
      if (d == 0) {
        factor->minor = k;
        return false;
      }
    }
  return true;
}

// The columns of L as the solves read them. Two columns j, j + 1 whose patterns below j + 1
// are the same (a supernode of two; L's columns are sorted) are swept together, as
// cholmod_solve does, so that each row of y is read and written once for both.
struct SolveColumns {
  const int* start;
  const int* count;
  const int* row;
  const double* value;
  explicit SolveColumns(const cholmod_factor* L)
      : start(static_cast<const int*>(L->p)), count(static_cast<const int*>(L->nz)), row(static_cast<const int*>(L->i)),
        value(static_cast<const double*>(L->x)) {}
  bool pair_below(int j) const { return count[j] >= 4 && count[j] == count[j + 1] + 1 && row[start[j] + 1] == j + 1; }
};

// The forward solve in the columns of `ranges` (each a subtree's rows, or rows after the
// bins): y_j /= D(j) and target(i) -= L(i, j) y_j with the undivided y_j (CHOLMOD's LD
// solve). `target(i, end)` is the entry that row i of a column in the range [.., end) updates.
template <class Target>
void forward(const SolveColumns& L, const std::vector<std::pair<int, int>>& ranges, double* y, Target target) {
  for (const auto& [first, end] : ranges)
    for (int j = first; j < end;) {
      const int p = L.start[j], last = p + L.count[j];
      if (j + 1 < end && L.pair_below(j)) {
        const int q = L.start[j + 1];
        const double y_0 = y[j], y_1 = y[j + 1] - L.value[p + 1] * y_0;
        y[j] = y_0 / L.value[p];
        y[j + 1] = y_1 / L.value[q];
        for (int e = p + 2, f = q + 1; e < last; ++e, ++f) target(L.row[e], end) -= L.value[e] * y_0 + L.value[f] * y_1;
        j += 2;
      } else {
        const double y_j = y[j];
        y[j] = y_j / L.value[p];
        for (int e = p + 1; e < last; ++e) target(L.row[e], end) -= L.value[e] * y_j;
        ++j;
      }
    }
}

// The backward solve, L^T x = y in place, in the columns of `ranges`, last row first. Each
// column's sum in two parts (one chain of dependent additions would bound it by the
// adder's latency).
void backward(const SolveColumns& L, const std::vector<std::pair<int, int>>& ranges, double* y) {
  for (auto range = ranges.rbegin(); range != ranges.rend(); ++range)
    for (int j = range->second - 1; j >= range->first;) {
      const int p = L.start[j], last = p + L.count[j];
      if (j - 1 >= range->first && L.pair_below(j - 1)) {
        const int q = L.start[j - 1];
        double sum_0[2] = {0, 0}, sum_1[2] = {0, 0};
        int e = p + 1, f = q + 2;
        for (; e + 2 <= last; e += 2, f += 2)
          for (int k = 0; k < 2; ++k) {
            const double x_i = y[L.row[e + k]];
            sum_0[k] += L.value[e + k] * x_i, sum_1[k] += L.value[f + k] * x_i;
          }
        if (e < last) sum_0[0] += L.value[e] * y[L.row[e]], sum_1[0] += L.value[f] * y[L.row[e]];
        const double x_j = y[j] - (sum_0[0] + sum_0[1]);
        y[j] = x_j;
        y[j - 1] = y[j - 1] - (sum_1[0] + sum_1[1]) - L.value[q + 1] * x_j;
        j -= 2;
      } else {
        double sum[4] = {0, 0, 0, 0};
        int e = p + 1;
        for (; e + 4 <= last; e += 4)
          for (int k = 0; k < 4; ++k) sum[k] += L.value[e + k] * y[L.row[e + k]];
        for (int k = 0; e < last; ++e, ++k) sum[k] += L.value[e] * y[L.row[e]];
        y[j] -= (sum[0] + sum[1]) + (sum[2] + sum[3]);
        --j;
      }
    }
}

}  // namespace

bool solve_by_subtrees(const cholmod_factor* L, const SubtreeSchedule& schedule, int threads, const double* b, double* x,
                       SubtreeSolveWorkspace& workspace) {
  const int n = int(L->n);
  const int* perm = static_cast<const int*>(L->Perm);
  const SolveColumns columns(L);
  std::vector<double>& y = workspace.y;
  auto& carry = workspace.carry;
  y.resize(n);
  for (auto& c : carry)
    if (int(c.size()) != n) c.assign(n, 0.0);  // kept zero between solves
  for (int k = 0; k < n; ++k) y[k] = b[perm[k]];
  // A bin's column updates rows of its own subtree (below the range's end) and rows after
  // the bins, whose share goes to the bin's carry; a row of the other bin links the bins.
  bool linked[2] = {false, false};
#pragma omp parallel for num_threads(threads) schedule(static, 1)
  for (int bin = 0; bin < 2; ++bin)
    forward(columns, schedule.bins[bin], y.data(), [&, bin](int i, int end) -> double& {
      if (i < end) return y[i];
      linked[bin] |= schedule.group[i] != SubtreeSchedule::kAfterBins;
      return carry[bin][i];
    });
  if (linked[0] || linked[1]) {
    for (auto& c : carry) std::fill(c.begin(), c.end(), 0.0);
    return false;
  }
  for (const auto& [first, end] : schedule.after)
    for (int k = first; k < end; ++k) {
      y[k] = y[k] + carry[0][k] + carry[1][k];
      carry[0][k] = carry[1][k] = 0;
    }
  forward(columns, schedule.after, y.data(), [&](int i, int) -> double& { return y[i]; });
  backward(columns, schedule.after, y.data());
#pragma omp parallel for num_threads(threads) schedule(static, 1)
  for (int bin = 0; bin < 2; ++bin) backward(columns, schedule.bins[bin], y.data());
  for (int k = 0; k < n; ++k) x[perm[k]] = y[k];
  return true;
}

cholmod_sparse* permuted_upper_triangle(int n, const int* column_start, const int* row, const double* value,
                                        const int* perm, const int* inverse, cholmod_common* common) {
  // Where A's entry e = (i, j) of column j has i > j, the stored (j, i) of column i holds the
  // pair's upper-triangle value (A's values need not be symmetric to the bit); -1 if there
  // is none (then CHOLMOD, reading the upper triangle only, does not see the pair).
  auto mirror = [&](int e, int j) {
    const int i = row[e];
    const int* at = std::lower_bound(row + column_start[i], row + column_start[i + 1], j);
    return at != row + column_start[i + 1] && *at == j ? int(at - row) : -1;
  };
  // Per column of S its entries; per column of A its upper-triangle entries. An upper entry
  // whose mirror is not stored would be missed by the gather: the totals then differ.
  std::vector<int> start(n + 1, 0);
  long upper_entries = 0;
#pragma omp parallel for schedule(dynamic, 4096) reduction(+ : upper_entries)
  for (int k = 0; k < n; ++k) {
    const int j = perm[k];
    int count = 0;
    for (int e = column_start[j]; e < column_start[j + 1]; ++e) {
      upper_entries += row[e] <= j;
      count += inverse[row[e]] <= k && (row[e] <= j || mirror(e, j) >= 0);
    }
    start[k + 1] = count;
  }
  for (int k = 0; k < n; ++k) start[k + 1] += start[k];
  if (start[n] != upper_entries) return nullptr;
  cholmod_sparse* S = cholmod_allocate_sparse(n, n, start[n], 1, 1, 1, CHOLMOD_REAL, common);
  if (!S) return nullptr;
  int* S_start = static_cast<int*>(S->p);
  int* S_row = static_cast<int*>(S->i);
  double* S_value = static_cast<double*>(S->x);
  std::copy(start.begin(), start.end(), S_start);
#pragma omp parallel for schedule(dynamic, 4096)
  for (int k = 0; k < n; ++k) {
    const int j = perm[k];
    int q = start[k];
    for (int e = column_start[j]; e < column_start[j + 1]; ++e) {
      const int new_row = inverse[row[e]];
      if (new_row > k) continue;
      const int source = row[e] <= j ? e : mirror(e, j);
      if (source < 0) continue;
      int at = q++;  // insertion by row: a column holds a handful of entries
      for (; at > start[k] && S_row[at - 1] > new_row; --at) S_row[at] = S_row[at - 1], S_value[at] = S_value[at - 1];
      S_row[at] = new_row;
      S_value[at] = value[source];
    }
  }
  return S;
}

bool factorise_by_subtrees(cholmod_sparse* S, cholmod_factor* L, const SubtreeSchedule& schedule, int threads,
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
  if (!schedule.split()) return rows(schedule.after, first) && L->minor == std::size_t(n);
  RowWorkspace workspace[2] = {RowWorkspace(n), RowWorkspace(n)};
  BinContribution contribution[2];
  bool ok[2] = {true, true};
  auto bin = [&](int b, cholmod_common* common) {
    ok[b] = rows(schedule.bins[b], common) && bin_part_of_rows_after(S, Columns(L), schedule, b, workspace[b], contribution[b]);
  };
  if (threads >= 2) {
    std::thread helper(bin, 1, second);
    bin(0, first);
    helper.join();
  } else {
    bin(0, first), bin(1, first);
  }
  return ok[0] && ok[1] && L->minor == std::size_t(n) && rows_after_bins(S, L, schedule, contribution, workspace[0]);
}

}  // namespace iqmpm
