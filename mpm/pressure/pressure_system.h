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
#pragma once

#include <Eigen/SparseCore>
#include <string>
#include <vector>

#include "core/types.h"

namespace iqmpm {

using SparseMatrix = Eigen::SparseMatrix<Real, Eigen::ColMajor, int>;
using SparseRowMatrix = Eigen::SparseMatrix<Real, Eigen::RowMajor, int>;

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

  // Builds D and A = dt D M^-1 D^T + diag(compliance).
  void assemble(Real dt) {
    constraint_.resize(rows_, inverse_mass_.size());
    constraint_.setFromTriplets(triplets_.begin(), triplets_.end());
    SparseRowMatrix scaled = constraint_ * inverse_mass_.asDiagonal();
    SparseMatrix transpose = constraint_.transpose();
    matrix_ = dt * (scaled * transpose);
    for (int i = 0; i < rows_; ++i)
      if (compliance_[i] != 0) matrix_.coeffRef(i, i) += compliance_[i];
    matrix_.makeCompressed();
    dt_ = dt;
  }

  // r = D v* + offset.
  Eigen::VectorXd rhs(const Eigen::VectorXd& velocity) const {
    Eigen::VectorXd r = constraint_ * velocity;
    for (int i = 0; i < rows_; ++i) r[i] += offset_rhs_[i];
    return r;
  }

  // v^{n+1} = v* - dt M^-1 D^T lambda.
  Eigen::VectorXd corrected_velocity(const Eigen::VectorXd& velocity, const Eigen::VectorXd& lambda) const {
    return velocity - dt_ * inverse_mass_.cwiseProduct(constraint_.transpose() * lambda);
  }

  int unknowns() const { return rows_; }
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
  std::vector<Eigen::Triplet<Real>> triplets_;
  std::vector<Real> compliance_;
  std::vector<Real> offset_rhs_;
  int rows_ = 0;
  Real dt_ = 0;
  SparseRowMatrix constraint_;
  SparseMatrix matrix_;
};

}  // namespace iqmpm
