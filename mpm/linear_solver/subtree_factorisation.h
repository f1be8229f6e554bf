// CHOLMOD's simplicial LDL^T by subtrees of the elimination tree, on two threads
// (method.md#linear-solver). cholmod_rowfac computes L a row at a time and can compute any
// range of rows once the rows of their descendants in the elimination tree exist. Subtrees
// that do not contain one another are independent, and in CHOLMOD's postordered symbolic
// factor each is a contiguous range of rows whose rows write only their own columns of L.
// So two groups of such subtrees (bins) are computed at once, each on its own thread with
// its own cholmod_common (workspace).
//
// The rows above the bins (the top separators: every bin's ancestors) cannot be left to
// rowfac: it computes a row's entries in every column below it, the bins' columns included,
// so those rows would take one thread most of the time. Their entries in a bin's columns
// depend only on that bin's factor (the up-looking solve of row k in a bin's columns
// touches only that bin's rows and the rows above), so each thread computes them for its
// own bin right after the bin, with what they subtract from the entries above; the rows
// above are then finished on one thread from those sums. This changes the order of the
// additions against rowfac's, not the arithmetic, so L differs from cholmod_factorize's at
// round-off; it is the same on one thread (the bins one after the other) as on two, so
// results do not depend on the thread count.
#pragma once

#include <cholmod.h>

#include <array>
#include <cstdint>
#include <utility>
#include <vector>

namespace iqmpm {

// Which rows of L each thread computes, and which after.
struct SubtreeSchedule {
  std::array<std::vector<std::pair<int, int>>, 2> bins;  // per thread: row ranges [first, end), in order
  std::vector<std::pair<int, int>> after;                // the other rows, in order, after both bins
  double bin_work[2] = {0, 0}, after_work = 0;           // sum of column count^2 of their rows
  // Where split(): per row of L, its parent in the elimination tree (-1 at a root) and its
  // group (0 or 1: a bin; kAfterBins).
  static constexpr std::int8_t kAfterBins = 2;
  std::vector<int> parent;
  std::vector<std::int8_t> group;
  bool split() const { return !bins[0].empty() && !bins[1].empty(); }
};

// The schedule for the symbolic simplicial factor L (postordered) of S = triu(P A P'):
// starting from the children of the root (below the chain of single-child nodes at the
// top), the heaviest subtree is replaced, round by round, by the children below its own
// chain of single children (a separator's rows, which join the rows after); each round's
// subtrees fill two bins, largest first into the lighter. Of these splits the one with the
// least predicted time (the heavier bin plus the rows after, in column count^2) is taken
// if it is at most 0.8 of one thread's; else every row comes after (one thread, as
// cholmod_factorize).
SubtreeSchedule plan_subtree_schedule(cholmod_sparse* S, const cholmod_factor* L, cholmod_common* common);

// S = triu(P A P') exactly as cholmod_factorize builds it for a simplicial factor (two
// cholmod_ptranspose calls reading A's upper triangle: the same arrays, to the bit), from A
// with both triangles stored (n x n, compressed columns, rows sorted), `perm` the factor's
// Perm (new -> old) and `inverse` its inverse. Column k of S gathers, for the rows i of A's
// column perm[k] with inverse[i] <= k, the pair's upper-triangle entry where A stores one,
// sorted by new row; columns are independent, so they run on the OpenMP threads (CHOLMOD's
// transposes run on one). Null where an upper entry's mirror is not stored (a pattern that
// is not symmetric; the assembled A's is, pressure/weighted_gram.h), which the gather
// cannot see: the caller then transposes as CHOLMOD does. Allocated in `common`; null also
// if out of memory.
cholmod_sparse* permuted_upper_triangle(int n, const int* column_start, const int* row, const double* value,
                                        const int* perm, const int* inverse, cholmod_common* common);

// L = the LDL^T factor of S by `schedule` (S = triu(P A P'), as cholmod_factorize builds
// it; L simplicial, symbolic or numeric with room for its column counts), the bins on two
// threads where `threads` >= 2, else one after the other. Returns false if CHOLMOD failed
// or met a zero pivot (L->minor < n).
bool factorise_by_subtrees(cholmod_sparse* S, cholmod_factor* L, const SubtreeSchedule& schedule, int threads,
                           cholmod_common* first, cholmod_common* second);

// The vectors solve_by_subtrees works in, kept between solves (sized on first use).
struct SubtreeSolveWorkspace {
  std::vector<double> y;             // the permuted right-hand side, then the solution
  std::array<std::vector<double>, 2> carry;  // per bin: what its columns subtract from the rows after
};

// x = A^-1 b from the simplicial LDL^T factor L = P A P' of a split `schedule` (as
// factorise_by_subtrees computes it, or modified since by CHOLMOD's row updates, whose
// patterns stay within the analysed one). A bin's columns of L have entries only in its own
// rows and the rows after the bins, so the forward solve of the two bins runs on two
// threads (each bin's subtractions from the rows after kept apart and added, bin 0's first,
// before the rows after are solved) and the backward solve of the bins too, after the rows
// after; the same bits on one thread. Differs from cholmod_solve at round-off (the order of
// the sums). Returns false, with x untouched, where an entry of L links the two bins (a
// pattern the schedule was not planned for).
bool solve_by_subtrees(const cholmod_factor* L, const SubtreeSchedule& schedule, int threads, const double* b, double* x,
                       SubtreeSolveWorkspace& workspace);

}  // namespace iqmpm
