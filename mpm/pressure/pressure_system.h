// The pressure-only system (method.md §5, slide equation 36) as an assembly of optional
// blocks. Every block is a group of rows of one constraint operator D acting on the stacked
// grid velocities (solid nodes first, then fluid corners):
//     p_g rows:  G^sT v_s            (ghost matrix; compliance S/dt)
//     p_f rows:  G^fT v_f            (incompressibility)
//     y rows:    B v_f               (free-slip walls; target b)
//     h rows:   -H^s v_s + H^f v_f   (interface normal-velocity jump)
// Eliminating v from (27) gives A = dt D M^-1 D^T + diag(compliance), which reproduces
// every block A11 ... A44 of (36) (A12 = A13 = 0 fall out), and the right-hand side
// r = D v* + (S p_g^n / dt, 0, -b, 0). The velocities are recovered as
// v^{n+1} = v* - dt M^-1 D^T lambda. A scene adds only the blocks it needs.
//
// The solid's stiffness in the solve (coupling.solid_response = stiffness): the entries of
// v that belong to free solid nodes get the Newton Hessian H = M^s + dt^2 K at v* (the
// linearised implicit-Euler step, method.md §3 step 2) as their mass instead of the lumped
// M^s, so the pressure "sees" a solid that resists being deformed within the step rather
// than a cloud of free nodal masses. H^-1 is dense, so those velocities stay unknowns:
//     [ A_rest     dt D_b ] [lambda]   [r]
//     [ dt D_b^T  -dt H   ] [  u   ] = [0],   v_b^{n+1} = v_b* - dt u,
// with D_b the constraint columns of those entries and A_rest = dt D M^-1 D^T + C over
// the other entries. Eliminating u (u = H^-1 D_b^T lambda) gives the pressure-only system
// with H^-1 in place of M^s-1; with H = M^s it is (36) exactly. The matrix is symmetric
// quasi-definite (A_rest positive (semi-)definite, -dt H negative definite), so an LDL^T
// factorisation needs no pivoting.
//
// Inequality rows (coupling.interface = unilateral) are handled by the caller's active
// set: a released row stays in place with zero multiplier (release()).
//
// A row of D that touches only held velocities (zero inverse mass: a fluid pressure cell
// inside a clamped body, where a fluid particle strayed) is an empty row of A: no force
// can act through it. It is made a unit row with zero right-hand side and multiplier
// (vacant()), instead of meeting a zero pivot in the factorisation: a shifted factorisation
// gave it an arbitrary multiplier, and the rows around it a residual of up to 2 %
// (dam_break_obstacle; method.md §5).
#pragma once

#include <Eigen/SparseCore>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <string>
#include <utility>
#include <vector>

#include "core/types.h"
#include "pressure/weighted_gram.h"

namespace iqmpm {

using SparseMatrix = Eigen::SparseMatrix<Real, Eigen::ColMajor, int>;
using SparseRowMatrix = Eigen::SparseMatrix<Real, Eigen::RowMajor, int>;

// m(c, c) += value for each (c, value) of `diagonal` (sorted by c, each c once). Where every
// one of them is stored (the usual case: the solid's compliance on its ghost rows) they are
// added in place; otherwise in one pass over m: coeffRef on a compressed matrix inserts a
// missing entry at a time and moves the rest each time (a quarter of an obstacle dam
// break's run, whose clamped corners leave many rows without a diagonal). The sum adds to
// stored entries and creates the missing ones, as coeffRef does; either way the matrix is
// the same, to the bit.
inline void add_to_diagonal(SparseMatrix& m, const std::vector<std::pair<int, Real>>& diagonal) {
  if (diagonal.empty()) return;
  if (m.isCompressed()) {
    std::vector<Real*> stored;
    stored.reserve(diagonal.size());
    for (const auto& [c, value] : diagonal) {
      const int* begin = m.innerIndexPtr() + m.outerIndexPtr()[c];
      const int* end = m.innerIndexPtr() + m.outerIndexPtr()[c + 1];
      const int* at = std::lower_bound(begin, end, c);  // a column's row indices are sorted
      if (at == end || *at != c) break;
      stored.push_back(m.valuePtr() + (at - m.innerIndexPtr()));
    }
    if (stored.size() == diagonal.size()) {
      for (std::size_t k = 0; k < stored.size(); ++k) *stored[k] += diagonal[k].second;
      return;
    }
  }
  SparseMatrix added(m.rows(), m.cols());
  added.reserve(Eigen::VectorXi::Constant(m.cols(), 1));
  for (const auto& [c, value] : diagonal) added.insert(c, c) = value;
  m = m + added;
}

class PressureSystem {
 public:
  struct Block {
    std::string name;
    int offset = 0;
    int size = 0;
  };

  // velocity_unknowns: length of the stacked velocity vector; inverse_mass per entry.
  void reset(const Eigen::VectorXd& inverse_mass) {
    inverse_mass_ = inverse_mass;
    blocks_.clear();
    triplets_.clear();
    compliance_.clear();
    offset_rhs_.clear();
    rows_ = 0;
    block_columns_.clear();
    block_mass_ = SparseMatrix();
    column_extension_.clear();
    released_.clear();
    matrix_ = SparseMatrix();
    unreleased_ = SparseMatrix();
  }

  // Released rows (one flag per row; empty: none): their multiplier is zero, an inequality
  // constraint that is inactive (coupling.interface = unilateral). In the matrix their row
  // and column become the unit vector and their right-hand side zero; since A = dt D M^-1
  // D^T + C, that is the system without those rows of D, and the pattern (and D) stays the
  // same from one active-set round to the next. Before or after assemble.
  void release(std::vector<std::uint8_t> rows) {
    released_ = std::move(rows);
    if (matrix_.rows() == size()) apply_release();
  }
  bool released(int row) const { return row < int(released_.size()) && released_[row]; }
  // A row that moves no free velocity (see the top of the file); fixed per assembly.
  bool vacant(int row) const { return row < int(vacant_.size()) && vacant_[row]; }
  int vacant_rows() const { return int(std::count(vacant_.begin(), vacant_.end(), 1)); }

  // D v over every row, released ones included (for the active set's check).
  Eigen::VectorXd full_constraint_times(const Eigen::VectorXd& velocity) const { return constraint_ * velocity; }
  // sum_k |D(i, k)| per row: the scale of a row's value.
  Eigen::VectorXd full_row_scale() const { return constraint_.cwiseAbs() * Eigen::VectorXd::Ones(constraint_.cols()); }

  // The stacked velocity entries `columns` take the SPD mass matrix `mass` (rows and
  // columns in the order of `columns`) instead of their inverse_mass entries; call after
  // reset and before assemble.
  void set_mass_block(std::vector<int> columns, SparseMatrix mass) {
    block_columns_ = std::move(columns);
    block_mass_ = std::move(mass);
  }

  // Velocity entries that are combinations of others (the solid's weak nodes, method.md
  // #weak-solid-nodes): column c's entries of D go to the columns of `extension[c]` times
  // their weights, so D acts on the reduced velocities v = T x; the extended entries need
  // zero inverse mass (nothing is left to move them). Call after reset and before assemble.
  void set_column_extension(std::vector<std::vector<std::pair<int, Real>>> extension) {
    column_extension_ = std::move(extension);
  }

  // Adds a block of rows. `rows` are triplets with block-local row indices and column
  // indices local to one material's velocities, which start at `column_offset` in the
  // stacked vector; compliance and rhs_offset have one entry per row (empty means zero).
  int add_block(const std::string& name, int size, const std::vector<Eigen::Triplet<Real>>& rows,
                const std::vector<Real>& compliance = {}, const std::vector<Real>& rhs_offset = {},
                int column_offset = 0) {
    Block block{name, rows_, size};
    for (const auto& t : rows) triplets_.emplace_back(t.row() + rows_, t.col() + column_offset, t.value());
    for (int i = 0; i < size; ++i) {
      compliance_.push_back(compliance.empty() ? 0 : compliance[i]);
      offset_rhs_.push_back(rhs_offset.empty() ? 0 : rhs_offset[i]);
    }
    rows_ += size;
    blocks_.push_back(block);
    return int(blocks_.size()) - 1;
  }

  // Adds entries to the rows of an existing block (block-local rows, stacked columns), e.g.
  // constraint terms on another material's velocities.
  void add_entries(int block, const std::vector<Eigen::Triplet<Real>>& entries) {
    const int offset = blocks_[block].offset;
    for (const auto& t : entries) triplets_.emplace_back(t.row() + offset, t.col(), t.value());
  }

  // Builds D and A = dt D M^-1 D^T + diag(compliance), bordered by the mass block if any.
  void assemble(Real dt) {
    constraint_.resize(rows_, inverse_mass_.size());
    if (column_extension_.empty()) {
      set_rows(constraint_, triplets_);
    } else {
      std::vector<Eigen::Triplet<Real>> extended;
      extended.reserve(triplets_.size());
      for (const auto& t : triplets_) {
        if (t.col() >= int(column_extension_.size()) || column_extension_[t.col()].empty()) {
          extended.push_back(t);
          continue;
        }
        for (const auto& [column, weight] : column_extension_[t.col()]) extended.emplace_back(t.row(), column, weight * t.value());
      }
      constraint_.setFromTriplets(extended.begin(), extended.end());
    }
    for (int column : block_columns_) inverse_mass_[column] = 0;
    SparseMatrix multipliers = weighted_gram(constraint_, inverse_mass_, dt);
    std::vector<std::pair<int, Real>> compliance;
    for (int i = 0; i < rows_; ++i)
      if (compliance_[i] != 0) compliance.emplace_back(i, compliance_[i]);
    add_to_diagonal(multipliers, compliance);
    dt_ = dt;
    if (block_columns_.empty()) {
      matrix_ = std::move(multipliers);
      mark_vacant_rows();
      matrix_.makeCompressed();
      unreleased_ = SparseMatrix();
      apply_release();
      return;
    }
    const int nb = int(block_columns_.size());
    SparseMatrix select(inverse_mass_.size(), nb);  // v_b = select^T v
    std::vector<Eigen::Triplet<Real>> entries;
    for (int k = 0; k < nb; ++k) entries.emplace_back(block_columns_[k], k, 1);
    select.setFromTriplets(entries.begin(), entries.end());
    const SparseMatrix coupling = SparseMatrix(constraint_) * select;  // D_b
    entries.clear();
    entries.reserve(multipliers.nonZeros() + 2 * coupling.nonZeros() + block_mass_.nonZeros());
    auto append = [&](const SparseMatrix& m, int row0, int col0, Real scale) {
      for (int c = 0; c < m.outerSize(); ++c)
        for (SparseMatrix::InnerIterator it(m, c); it; ++it)
          entries.emplace_back(row0 + it.row(), col0 + it.col(), scale * it.value());
    };
    append(multipliers, 0, 0, 1);
    append(coupling, 0, rows_, dt);
    append(coupling.transpose(), rows_, 0, dt);
    append(block_mass_, rows_, rows_, -dt);
    matrix_.resize(rows_ + nb, rows_ + nb);
    matrix_.setFromTriplets(entries.begin(), entries.end());
    mark_vacant_rows();
    matrix_.makeCompressed();
    unreleased_ = SparseMatrix();
    apply_release();
  }

  // r = D v* + offset (and zeros for the mass block's rows).
  Eigen::VectorXd rhs(const Eigen::VectorXd& velocity) const {
    Eigen::VectorXd r = Eigen::VectorXd::Zero(size());
    r.head(rows_) = constraint_ * velocity;
    for (int i = 0; i < rows_; ++i) r[i] = released(i) || vacant(i) ? 0 : r[i] + offset_rhs_[i];
    return r;
  }

  // v^{n+1} = v* - dt M^-1 D^T lambda, and v_b* - dt u on the mass block's entries;
  // `solution` is (lambda, u) as solved.
  Eigen::VectorXd corrected_velocity(const Eigen::VectorXd& velocity, const Eigen::VectorXd& solution) const {
    return corrected_velocity(velocity, solution, constraint_force(solution));
  }
  // The same with the constraint force D^T lambda of `solution` already computed.
  Eigen::VectorXd corrected_velocity(const Eigen::VectorXd& velocity, const Eigen::VectorXd& solution,
                                     const Eigen::VectorXd& force) const {
    Eigen::VectorXd v = velocity - dt_ * inverse_mass_.cwiseProduct(force);
    for (int k = 0; k < int(block_columns_.size()); ++k) v[block_columns_[k]] -= dt_ * solution[rows_ + k];
    return v;
  }

  // The multipliers that act: the solution's first unknowns() entries with those of
  // released and vacant rows exactly zero (an iterative solve leaves them at its tolerance).
  Eigen::VectorXd acting_multipliers(const Eigen::VectorXd& solution) const {
    Eigen::VectorXd lambda = solution.head(rows_);
    for (int i = 0; i < rows_; ++i)
      if (released(i) || vacant(i)) lambda[i] = 0;
    return lambda;
  }

  // D^T lambda per stacked velocity entry: the constraints' force on it (v^{n+1} = v* -
  // dt M^-1 D^T lambda), from the acting multipliers.
  Eigen::VectorXd constraint_force(const Eigen::VectorXd& solution) const {
    return constraint_.transpose() * acting_multipliers(solution);
  }

  // How far the corrected velocities miss the constraints (a health check): per enforced
  // row, D v^{n+1} + offset - compliance x lambda, which an exact solve makes zero (A lambda
  // = r and v^{n+1} = v* - dt M^-1 D^T lambda give D v^{n+1} = -offset + C lambda); its norm
  // relative to the right-hand side's, or to 1e-8 of the size of D v*'s terms where that
  // is smaller (a body or water at rest: D v* is round-off, and so is the miss; a block
  // falling freely read 1e-5 against 1e-12 of its terms).
  Real relative_constraint_residual(const Eigen::VectorXd& velocity_star, const Eigen::VectorXd& velocity_next,
                                    const Eigen::VectorXd& solution) const {
    const Eigen::VectorXd next = constraint_ * velocity_next;
    const Eigen::VectorXd star = constraint_ * velocity_star;
    const Eigen::VectorXd terms = constraint_.cwiseAbs() * velocity_star.cwiseAbs();
    Real residual2 = 0, rhs2 = 0, terms2 = 0;
    for (int i = 0; i < rows_; ++i) {
      if (released(i) || vacant(i)) continue;  // inequality rows; rows no force can act through
      const Real miss = next[i] + offset_rhs_[i] - compliance_[i] * solution[i];
      const Real rhs = star[i] + offset_rhs_[i];
      residual2 += miss * miss;
      rhs2 += rhs * rhs;
      terms2 += terms[i] * terms[i];
    }
    if (residual2 == 0) return 0;
    const Real scale = std::max({std::sqrt(rhs2), 1e-8 * std::sqrt(terms2), std::numeric_limits<Real>::min()});
    return std::sqrt(residual2) / scale;
  }

  // The multipliers (p_g, p_f, y, h, p_a): the solution's first unknowns() entries.
  int unknowns() const { return rows_; }
  // The rows of the solved system: the multipliers, then the mass block's velocities.
  int size() const { return rows_ + int(block_columns_.size()); }
  bool has_mass_block() const { return !block_columns_.empty(); }
  const SparseMatrix& matrix() const { return matrix_; }
  const SparseRowMatrix& constraint() const { return constraint_; }
  const std::vector<Block>& blocks() const { return blocks_; }
  const Block* find(const std::string& name) const {
    for (const auto& b : blocks_)
      if (b.name == name) return &b;
    return nullptr;
  }

 private:
  Eigen::VectorXd inverse_mass_;
  std::vector<Block> blocks_;
  // D = the triplets' sum, sized beforehand. The fluid operators emit their rows in
  // order, each row's columns rising (corners in layout order), and each entry once: such
  // triplets are copied straight into D's compressed rows, the same matrix as Eigen's
  // setFromTriplets builds (a transposed copy, its repeats summed, then transposed back;
  // 2.6 % of the main thread at a/128). Any other triplets go through setFromTriplets.
  static void set_rows(SparseRowMatrix& D, const std::vector<Eigen::Triplet<Real>>& triplets) {
    for (std::size_t e = 1; e < triplets.size(); ++e) {
      const auto& before = triplets[e - 1];
      const auto& entry = triplets[e];
      if (entry.row() < before.row() || (entry.row() == before.row() && entry.col() <= before.col())) {
        D.setFromTriplets(triplets.begin(), triplets.end());
        return;
      }
    }
    D.resizeNonZeros(Eigen::Index(triplets.size()));
    int* start = D.outerIndexPtr();
    std::fill(start, start + D.rows() + 1, 0);
    for (std::size_t e = 0; e < triplets.size(); ++e) {
      ++start[triplets[e].row() + 1];
      D.innerIndexPtr()[e] = triplets[e].col();
      D.valuePtr()[e] = triplets[e].value();
    }
    for (Eigen::Index i = 0; i < D.rows(); ++i) start[i + 1] += start[i];
  }

  std::vector<Eigen::Triplet<Real>> triplets_;
  std::vector<Real> compliance_;
  std::vector<Real> offset_rhs_;
  int rows_ = 0;
  Real dt_ = 0;
  std::vector<int> block_columns_;
  SparseMatrix block_mass_;
  std::vector<std::vector<std::pair<int, Real>>> column_extension_;  // per stacked column; empty: itself
  std::vector<std::uint8_t> released_;
  // The assembled matrix with no row released, kept from the first release after an
  // assembly on (the active set may enforce a released row again); empty until then, so a
  // bilateral run never copies the matrix.
  SparseMatrix unreleased_;

  std::vector<std::uint8_t> vacant_;
  // Rows of the multipliers whose column of matrix_ holds no non-zero value get a unit
  // diagonal (A is positive semi-definite, so a zero diagonal of A_rest means an empty row
  // of it; with the mass block the row must also have no coupling entry).
  void mark_vacant_rows() {
    vacant_.assign(rows_, 0);
    std::vector<std::pair<int, Real>> empty;  // a stored zero plus 1 is the 1 it needs
    for (int c = 0; c < rows_; ++c) {
      bool any = false;
      for (SparseMatrix::InnerIterator it(matrix_, c); it && !any; ++it) any = it.value() != 0;
      if (!any) vacant_[c] = 1, empty.emplace_back(c, 1);
    }
    add_to_diagonal(matrix_, empty);
  }

  // matrix_ = the assembled matrix with the released rows and columns made unit vectors.
  void apply_release() {
    const bool any = std::find(released_.begin(), released_.end(), 1) != released_.end();
    if (unreleased_.rows() == 0) {
      if (!any) return;
      unreleased_ = matrix_;
    } else {
      matrix_ = unreleased_;
      if (!any) return;
    }
    std::vector<std::pair<int, Real>> missing_diagonal;
    for (int c = 0; c < matrix_.outerSize(); ++c) {
      bool diagonal = false;
      for (SparseMatrix::InnerIterator it(matrix_, c); it; ++it) {
        const int r = int(it.row());
        if (!(released(r) || (c < rows_ && released(c)))) continue;
        it.valueRef() = r == c ? 1 : 0;
        diagonal = diagonal || r == c;
      }
      if (c < rows_ && released(c) && !diagonal) missing_diagonal.emplace_back(c, 1);
    }
    add_to_diagonal(matrix_, missing_diagonal);  // rows of D that moved nothing
    matrix_.makeCompressed();
  }
  SparseRowMatrix constraint_;
  SparseMatrix matrix_;
};

}  // namespace iqmpm
