// CHOLMOD's simplicial LDL^T on two threads (method.md#linear-solver). cholmod_rowfac
// computes L a row at a time and can compute any range of rows once the rows of their
// descendants in the elimination tree exist. Subtrees of that tree that do not contain one
// another are independent, and in CHOLMOD's postordered symbolic factor each is a
// contiguous range of rows; their rows also write only their own columns of L. So the rows
// of two groups of such subtrees can be computed at once, each on its own thread with its
// own cholmod_common (workspace), and the rows above them after both: every row is computed
// by the same arithmetic as in cholmod_factorize, so L is bit for bit the same.
#pragma once

#include <cholmod.h>

#include <array>
#include <utility>
#include <vector>

namespace iqmpm {

// Which rows of L each thread computes, and which after.
struct SubtreeSchedule {
  std::array<std::vector<std::pair<int, int>>, 2> bins;  // per thread: row ranges [first, end), in order
  std::vector<std::pair<int, int>> after;                // the other rows, in order, after both bins
  double bin_work[2] = {0, 0}, after_work = 0;           // sum of column count^2 of their rows
  bool split() const { return !bins[0].empty() && !bins[1].empty(); }
};

// The schedule for the symbolic simplicial factor L (postordered) of S = triu(P A P'):
// starting from the children of the root (below the chain of single-child nodes at the
// top), the heaviest subtree is replaced by its children until two bins, filled largest
// first, differ by at most 10 % of their total. Where no such split exists, every row
// comes after (one thread, as cholmod_factorize).
SubtreeSchedule plan_subtree_schedule(cholmod_sparse* S, const cholmod_factor* L, cholmod_common* common);

// L = the LDL^T factor of S by `schedule` (S = triu(P A P'), as cholmod_factorize builds
// it; L simplicial, symbolic or numeric with room for its column counts). Returns false if
// CHOLMOD failed or met a zero pivot (L->minor < n).
bool factorise_by_subtrees(cholmod_sparse* S, cholmod_factor* L, const SubtreeSchedule& schedule,
                           cholmod_common* first, cholmod_common* second);

}  // namespace iqmpm
