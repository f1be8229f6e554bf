// The direct solvers behind LinearSolver (linear_solver.h): CHOLMOD's LL^T
// (solver.method = cholmod) and its updatable LDL^T (ldlt, the 2-D default).
#include "linear_solver/direct_solvers.h"

#include <Eigen/CholmodSupport>
#include <cholmod.h>
#include <omp.h>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <string>
#include <utility>
#include <vector>

#include "core/errors.h"
#include "linear_solver/subtree_factorisation.h"

namespace iqmpm {
namespace {

using Sparse = Eigen::SparseMatrix<Real>;

// The sparsity pattern of the last matrix a direct solver analysed: its symbolic analysis
// (fill-reducing ordering, elimination tree) depends on the pattern only, so it is kept
// while the pattern repeats (the active-set rounds of one step).
struct SparsityPattern {
  std::vector<int> outer, inner;
  bool matches(const Sparse& A) const {
    return std::size_t(A.outerSize()) + 1 == outer.size() && std::equal(outer.begin(), outer.end(), A.outerIndexPtr()) &&
           A.nonZeros() == Eigen::Index(inner.size()) && std::equal(inner.begin(), inner.end(), A.innerIndexPtr());
  }
  void remember(const Sparse& A) {
    outer.assign(A.outerIndexPtr(), A.outerIndexPtr() + A.outerSize() + 1);
    inner.assign(A.innerIndexPtr(), A.innerIndexPtr() + A.nonZeros());
  }
};

// A semi-definite system (method.md §5: an enclosed pocket of fluid, or interface rows that
// coincide with divergence rows next to a clamped body) can meet an exact zero pivot, or
// in LDL^T one at round-off size. A direct solver then retries once with each diagonal
// entry raised by 1e-12 of itself (of the mean diagonal where it is zero), which selects
// one solution of a consistent system; LDL^T refines that solution against the unshifted
// system, whose residual it reports. Relative to each row, not one shift for all: the
// diagonal spans 1e-9 to 1 (a clamped body's rows beside unit rows), and a shift of 1e-12
// of the mean stalled the refinement at 1.3e-6 on a dumped system where this reaches 1e-12.
Sparse with_diagonal_shift(const Sparse& A) {
  Sparse shifted = A;
  const Real mean = A.diagonal().cwiseAbs().mean();
  for (int i = 0; i < shifted.rows(); ++i) {
    Real& diagonal = shifted.coeffRef(i, i);
    diagonal += 1e-12 * (diagonal != 0 ? std::abs(diagonal) : mean);
  }
  return shifted;
}

// CHOLMOD's switch from a simplicial to a supernodal factor, flops / nnz(L): the measured
// crossover (benchmarks/solvers/factor_kinds.cpp on dumped systems, one core, OpenBLAS, the
// grid's nested dissection): simplicial LDL^T takes 0.41 / 0.68 / 0.81 of supernodal LL^T's
// time on the 2-D dam break at a/64 / a/128 / a/180 (flops / nnz(L) 61 / 102 / 124), 1.31 /
// 1.99 / 4.43 of it on 3-D floating cubes (135 / 244 / 493). CHOLMOD's default, 40, sent
// the 2-D dam break supernodal (method.md#linear-solver).
constexpr double kSupernodalSwitch = 130;

// The smallest system whose simplicial factorisation runs on two threads (subtree_factorisation.h).
constexpr int kSubtreeRows = 4096;

// CHOLMOD's supernodal factorisation and solves call BLAS and LAPACK (OpenBLAS's OpenMP
// build, .ci/setup.sh), whose threaded dpotrf / dgemm round differently from their serial
// versions: a dam_break_obstacle run parted between 1 and 2 threads at step 285
// (method.md#linear-solver). Inside this scope BLAS runs on one thread, so results do not depend on the
// thread count; measured cost none (dam break a/128, first 0.1 s, 2 threads: solve stage
// 10.6 / 11.2 s with threaded BLAS, 8.7 / 10.1 s without, alternating).
class SerialBlasScope {
 public:
  SerialBlasScope() : threads_(omp_get_max_threads()) { omp_set_num_threads(1); }
  ~SerialBlasScope() { omp_set_num_threads(threads_); }
  SerialBlasScope(const SerialBlasScope&) = delete;
  SerialBlasScope& operator=(const SerialBlasScope&) = delete;

 private:
  int threads_;
};

// A direct factorisation (Factor: an Eigen sparse Cholesky-type solver; CHOLMOD's LL^T for
// solver.method = cholmod) with the residual of its solution reported like PCG's.
template <class Factor>
class DirectSolver final : public LinearSolver {
 public:
  explicit DirectSolver(std::string name) : name_(std::move(name)) {}
  bool solves_quasi_definite() const override { return false; }  // LL^T
  std::string name() const override { return name_; }
  LinearSolverKind kind() const override { return LinearSolverKind::cholmod; }

  LinearSolveStats solve(const Sparse& A, const Eigen::VectorXd& b, Eigen::VectorXd& x) override {
    LinearSolveStats stats;
    stats.method = name_;
    if (!analysed_ || !pattern_.matches(A)) {
      configure(factor);
      factor.analyzePattern(A);
      pattern_.remember(A);
      analysed_ = true;
    }
    const SerialBlasScope serial_blas;
    factor.factorize(A);
    if (factor.info() != Eigen::Success) {
      analysed_ = false;  // the shifted retry analyses afresh
      factor.compute(with_diagonal_shift(A));
      stats.shifted = true;
    }
    if (factor.info() != Eigen::Success) {
      stats.relative_residual = 1;
      return stats;
    }
    x = factor.solve(b);
    const Real b_norm = b.norm();
    stats.relative_residual = b_norm > 0 ? (b - A * x).norm() / b_norm : 0;
    stats.converged = std::isfinite(stats.relative_residual);
    return stats;
  }

 private:
  template <class F>
  static void configure(F&) {}
  // CHOLMOD: LL^T with AMD ordering, supernodal where the factor is dense enough, by the
  // LDL^T solver's measured crossover (kSupernodalSwitch): simplicial on the 2-D dam
  // break (at a/64 supernodal took 46 ms a solve against 21 ms), supernodal on 3-D systems.
  static void configure(Eigen::CholmodDecomposition<Sparse, Eigen::Lower>& factor) {
    factor.cholmod().nmethods = 1;
    factor.cholmod().method[0].ordering = CHOLMOD_AMD;
    factor.setMode(Eigen::CholmodAuto);
    factor.cholmod().supernodal_switch = kSupernodalSwitch;
  }

  std::string name_;
  Factor factor;
  bool analysed_ = false;
  SparsityPattern pattern_;
};

// LDL^T by CHOLMOD (simplicial LDL^T, or supernodal LL^T where the factor is dense enough;
// in the suggested order, else AMD; no pivoting: the system is symmetric positive
// definite, or quasi-definite with coupling.solid_response = stiffness). It keeps its
// symbolic analysis while the pattern repeats, and it can modify its factorisation a row at
// a time (CHOLMOD's Modify module, a rank-2 update each): after expect_row_changes(), a released row is deleted (its row and column
// of L become the identity's, which factorises the matrix with that row and column made a
// unit vector, as PressureSystem::release does) and a restored row is added back from the
// new matrix's column. The active set's later rounds change a few rows of thousands
// (measured on elastic_gate: 4 on average, of 2700), so they skip the factorisation. If a
// modified factor's relative residual is above 1e-10, the matrix is factorised afresh.
// Measured against Eigen's simplicial LDL^T, which it replaced: 2.4 / 13.7 ms a solve on
// the dam break at a/32 / a/64 against 2.3 / 14.1; the unilateral
// gate's solve stage 12.8 -> 7.4 s.
class UpdatableLdlSolver final : public LinearSolver {
 public:
  explicit UpdatableLdlSolver(bool simplicial) {
    for (cholmod_common* common : {&common_, &helper_common_}) {
      cholmod_start(common);
      common->nmethods = 1;
      common->method[0].ordering = CHOLMOD_AMD;
      // CHOLMOD_AUTO: supernodal LL^T (BLAS-3) where the factor is dense enough (flops /
      // nnz(L) at least kSupernodalSwitch), else simplicial LDL^T; always simplicial where
      // rows are modified or the system is quasi-definite.
      common->supernodal = simplicial ? CHOLMOD_SIMPLICIAL : CHOLMOD_AUTO;
      common->supernodal_switch = kSupernodalSwitch;
      common->final_ll = false;
      common->print = 0;
      common->error_handler = nullptr;
    }
  }
  ~UpdatableLdlSolver() override {
    if (factor_) cholmod_free_factor(&factor_, &common_);
    cholmod_finish(&common_);
    cholmod_finish(&helper_common_);
  }
  UpdatableLdlSolver(const UpdatableLdlSolver&) = delete;
  UpdatableLdlSolver& operator=(const UpdatableLdlSolver&) = delete;

  bool solves_quasi_definite() const override { return true; }
  std::string name() const override { return "ldlt"; }
  LinearSolverKind kind() const override { return LinearSolverKind::ldlt; }
  void suggest_order(std::vector<int> order) override { order_ = std::move(order); }
  void expect_row_changes(std::vector<int> released, std::vector<int> restored) override {
    released_ = std::move(released);
    restored_ = std::move(restored);
    changes_pending_ = true;
  }

  LinearSolveStats solve_again(const Sparse& A, const Eigen::VectorXd& b, Eigen::VectorXd& x) override {
    if (!factor_valid_ || changes_pending_ || !pattern_.matches(A)) return solve(A, b, x);
    return solve_with_current_factor(A, b, x);
  }

  LinearSolveStats solve(const Sparse& A, const Eigen::VectorXd& b, Eigen::VectorXd& x) override {
    LinearSolveStats stats;
    stats.method = name();
    const bool pending = changes_pending_;
    changes_pending_ = false;
    const bool same_pattern = factor_ && pattern_.matches(A);
    bool modified = same_pattern && pending && factor_valid_ && !factor_shifted_ && modify_rows(A);
    if (modified) {
      solve_with_factor(b, x);
      stats.relative_residual = residual(A, b, x);
      if (stats.relative_residual <= 1e-10) {
        stats.converged = true;
        stats.modified_rows = int(released_.size() + restored_.size());
        return stats;
      }
    }
    if (!same_pattern) analyse(A);
    factor_shifted_ = false;
    if (!factorise(A) || roundoff_pivots(A) > 0) {
      factor_shifted_ = true;
      const Sparse shifted = with_diagonal_shift(A);
      if (!pattern_.matches(shifted)) analyse(shifted);  // A's analysis serves where its diagonal is stored
      if (!factorise(shifted)) {
        factor_valid_ = false;
        stats.shifted = true;
        stats.relative_residual = 1;
        return stats;
      }
    }
    return solve_with_current_factor(A, b, x);
  }

 private:
  cholmod_common common_;
  cholmod_common helper_common_;  // the second thread's workspace (factorise_by_subtrees)
  cholmod_factor* factor_ = nullptr;
  SubtreeSchedule schedule_;      // of factor_'s analysis; planned at its first factorisation
  bool schedule_planned_ = false;
  SubtreeSolveWorkspace solve_workspace_;
  int factor_threads_ = 1;        // of the last factorisation
  bool factor_valid_ = false;
  SparsityPattern pattern_;
  std::vector<int> permuted_;  // original index -> row of L
  std::vector<int> released_, restored_;
  bool changes_pending_ = false;
  std::vector<int> order_;  // suggest_order(); empty: AMD
  bool factor_shifted_ = false;  // the factor is of A + shift (with_diagonal_shift)

  // x from the factor as it stands, refined against A where the factor is of A + shift.
  LinearSolveStats solve_with_current_factor(const Sparse& A, const Eigen::VectorXd& b, Eigen::VectorXd& x) {
    LinearSolveStats stats;
    stats.method = name();
    solve_with_factor(b, x);
    stats.relative_residual = residual(A, b, x);
    if (factor_shifted_) refine(A, b, x, stats.relative_residual);
    stats.shifted = factor_shifted_;
    stats.supernodal = factor_->is_super;
    stats.factor_threads = factor_threads_;
    stats.converged = std::isfinite(stats.relative_residual);
    return stats;
  }

  // A view of the upper triangle of A (stored in full; stype > 0 spares CHOLMOD a transpose).
  static cholmod_sparse view(const Sparse& A) {
    cholmod_sparse s{};
    s.nrow = s.ncol = A.rows();
    s.nzmax = A.nonZeros();
    s.p = const_cast<int*>(A.outerIndexPtr());
    s.i = const_cast<int*>(A.innerIndexPtr());
    s.x = const_cast<Real*>(A.valuePtr());
    s.stype = 1;
    s.itype = CHOLMOD_INT;
    s.xtype = CHOLMOD_REAL;
    s.dtype = CHOLMOD_DOUBLE;
    s.sorted = 1;
    s.packed = 1;
    return s;
  }

  void analyse(const Sparse& A) {
    if (factor_) cholmod_free_factor(&factor_, &common_);
    cholmod_sparse s = view(A);
    const bool given = order_.size() == std::size_t(A.rows());
    common_.method[0].ordering = given ? CHOLMOD_GIVEN : CHOLMOD_AMD;
    factor_ = cholmod_analyze_p(&s, given ? order_.data() : nullptr, nullptr, 0, &common_);
    if (!factor_) throw NumericalFailure("CHOLMOD could not analyse the pressure system (out of memory?)");
    pattern_.remember(A);
    const int* perm = static_cast<const int*>(factor_->Perm);
    permuted_.assign(A.rows(), 0);
    for (int k = 0; k < int(A.rows()); ++k) permuted_[perm[k]] = k;
    factor_valid_ = false;
    schedule_ = SubtreeSchedule{};
    schedule_planned_ = false;
  }

  // A simplicial factor of at least kSubtreeRows unknowns by subtrees (linear_solver/
  // subtree_factorisation.h), on two threads where the run has them and the elimination
  // tree splits, the same L on one thread; else cholmod_factorize.
  bool factorise(const Sparse& A) {
    const bool by_subtrees = !factor_->is_super && A.rows() >= kSubtreeRows;
    const int threads = std::min(2, omp_get_max_threads());  // before BLAS is held to one
    cholmod_sparse s = view(A);
    const SerialBlasScope serial_blas;
    if (by_subtrees) {
      // S = triu(P A P'), as cholmod_factorize builds it: on the threads, or by CHOLMOD's
      // transposes where A's pattern is not symmetric.
      const int* perm = static_cast<const int*>(factor_->Perm);
      cholmod_sparse* upper = permuted_upper_triangle(int(A.rows()), A.outerIndexPtr(), A.innerIndexPtr(), A.valuePtr(), perm,
                                                      permuted_.data(), &common_);
      if (!upper) {
        cholmod_sparse* lower = cholmod_ptranspose(&s, 2, static_cast<int*>(factor_->Perm), nullptr, 0, &common_);
        upper = lower ? cholmod_ptranspose(lower, 2, nullptr, nullptr, 0, &common_) : nullptr;
        cholmod_free_sparse(&lower, &common_);
      }
      if (!upper) throw NumericalFailure("CHOLMOD could not permute the pressure system (out of memory?)");
      if (!schedule_planned_) schedule_ = plan_subtree_schedule(upper, factor_, &common_), schedule_planned_ = true;
      factor_threads_ = schedule_.split() ? threads : 1;
      factor_valid_ = factorise_by_subtrees(upper, factor_, schedule_, threads, &common_, &helper_common_);
      cholmod_free_sparse(&upper, &common_);
      return factor_valid_;
    }
    factor_threads_ = 1;
    cholmod_factorize(&s, factor_, &common_);
    factor_valid_ = common_.status == CHOLMOD_OK && factor_->minor == factor_->n;
    return factor_valid_;
  }

  // A consistent singular system (interface rows that repeat divergence rows next to a
  // clamped body: method.md#pressure-system) need not meet an exact zero pivot: round-off
  // leaves one of about 1e-16 of its column, the factorisation goes on, and the columns of
  // L below it carry the round-off amplified by as much (a dam_break_obstacle run missed its
  // constraints by 45 %). Counts the pivots of D below 1e-13 of their column's largest
  // entry in A; genuine pivots lie far above, near 1/cond of their column (cond 3.8e4 for the
  // 2-D dam break's scaled system, method.md §4; on that obstacle's dumps the smallest
  // genuine pivot was 1e-11 of its column, the round-off ones 1e-16 and below). A genuine
  // pivot taken for round-off would cost a second factorisation, not accuracy (the shifted
  // solution is refined). Simplicial LDL^T only (D is L's stored diagonal); a supernodal
  // LL^T is left to the caller's residual check.
  int roundoff_pivots(const Sparse& A) const {
    if (factor_->is_super || factor_->is_ll) return 0;
    const int* perm = static_cast<const int*>(factor_->Perm);
    const int* column_start = static_cast<const int*>(factor_->p);
    const Real* values = static_cast<const Real*>(factor_->x);
    int count = 0;
#pragma omp parallel for schedule(dynamic, 4096) reduction(+ : count)
    for (int k = 0; k < int(factor_->n); ++k) {
      Real scale = 0;
      for (Sparse::InnerIterator it(A, perm[k]); it; ++it) scale = std::max(scale, std::abs(it.value()));
      count += std::abs(values[column_start[k]]) < 1e-13 * scale;
    }
    return count;
  }

  // After a shifted factorisation: x += (A + shift)^-1 (b - A x) while the residual of the
  // unshifted A falls, at most 3 times (one brings the shifted solve's 1e-7 to 1e-11 on the
  // dumped systems of that run).
  void refine(const Sparse& A, const Eigen::VectorXd& b, Eigen::VectorXd& x, Real& relative_residual) {
    for (int round = 0; round < 3 && relative_residual > 1e-14; ++round) {
      Eigen::VectorXd correction;
      solve_with_factor(b - A * x, correction);
      const Eigen::VectorXd refined = x + correction;
      const Real refined_residual = residual(A, b, refined);
      if (!(refined_residual < relative_residual)) break;
      x = refined;
      relative_residual = refined_residual;
    }
  }

  // Released rows first, then the restored ones one at a time. L factorises the matrix
  // with every row not yet added a unit row, so a row is added with the entries of its
  // column in the rows already present (and its diagonal); the entries towards restored
  // rows still to come are added with those rows. Indices are L's (permuted) ones.
  bool modify_rows(const Sparse& A) {
    if (factor_->is_super) return false;  // CHOLMOD modifies simplicial LDL^T factors only
    for (int k : released_)
      if (!cholmod_rowdel(permuted_[k], nullptr, factor_, &common_)) return factor_valid_ = false;
    std::vector<std::uint8_t> to_come(A.rows(), 0);
    for (int k : restored_) to_come[k] = 1;
    for (int k : restored_) {
      to_come[k] = 0;
      const int begin = A.outerIndexPtr()[k], end = A.outerIndexPtr()[k + 1];
      cholmod_sparse* column = cholmod_allocate_sparse(A.rows(), 1, end - begin, 0, 1, 0, CHOLMOD_REAL, &common_);
      if (!column) return factor_valid_ = false;
      int* p = static_cast<int*>(column->p);
      int* i = static_cast<int*>(column->i);
      Real* v = static_cast<Real*>(column->x);
      int count = 0;
      for (int e = begin; e < end; ++e) {
        const int row = A.innerIndexPtr()[e];
        if (to_come[row]) continue;
        i[count] = permuted_[row];
        v[count++] = A.valuePtr()[e];
      }
      p[0] = 0;
      p[1] = count;
      const int ok = cholmod_rowadd(permuted_[k], column, factor_, &common_);
      cholmod_free_sparse(&column, &common_);
      if (!ok || common_.status != CHOLMOD_OK) return factor_valid_ = false;
    }
    return true;
  }

  // By the factorisation's subtrees where it was split (on two threads where the run has
  // them: subtree_factorisation.h), else cholmod_solve.
  void solve_with_factor(const Eigen::VectorXd& b, Eigen::VectorXd& x) {
    if (schedule_planned_ && schedule_.split() && !factor_->is_super && !factor_->is_ll) {
      x.resize(b.size());
      const int threads = std::min(2, omp_get_max_threads());
      if (solve_by_subtrees(factor_, schedule_, threads, b.data(), x.data(), solve_workspace_)) return;
    }
    cholmod_dense rhs{};
    rhs.nrow = b.size();
    rhs.ncol = 1;
    rhs.nzmax = b.size();
    rhs.d = b.size();
    rhs.x = const_cast<Real*>(b.data());
    rhs.xtype = CHOLMOD_REAL;
    rhs.dtype = CHOLMOD_DOUBLE;
    cholmod_dense* solution = nullptr;
    {
      const SerialBlasScope serial_blas;
      solution = cholmod_solve(CHOLMOD_A, factor_, &rhs, &common_);
    }
    if (!solution) throw NumericalFailure("CHOLMOD could not solve the pressure system (out of memory?)");
    x = Eigen::Map<const Eigen::VectorXd>(static_cast<const Real*>(solution->x), b.size());
    cholmod_free_dense(&solution, &common_);
  }

  static Real residual(const Sparse& A, const Eigen::VectorXd& b, const Eigen::VectorXd& x) {
    const Real b_norm = b.norm();
    return b_norm > 0 ? (b - A * x).norm() / b_norm : 0;
  }
};
}  // namespace

std::unique_ptr<LinearSolver> make_cholmod_llt_solver() {
  return std::make_unique<DirectSolver<Eigen::CholmodDecomposition<Sparse, Eigen::Lower>>>("cholmod");
}

std::unique_ptr<LinearSolver> make_ldlt_solver(bool simplicial) { return std::make_unique<UpdatableLdlSolver>(simplicial); }

}  // namespace iqmpm
