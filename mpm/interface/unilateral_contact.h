// The unilateral interface (coupling.interface = unilateral;
// docs/method.md#unilateral-interface): the bilateral constraint holds fluid to a solid it
// touches (method.md §9).
// The rows through which the fluid pulls on a solid become inequalities, solved by active
// sets: every h row, and the p_f rows of cells whose corners move with the solid. A row
// in tension (multiplier < 0) is released, so the fluid may separate there; a released
// row whose fluid compresses against the solid again (row value D v > 0: approach for h,
// convergence for p_f) is enforced again. One pressure solve per round. Released rows
// have zero multiplier (PressureSystem::release). A step starts from the cells released
// at the end of the last one.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <utility>
#include <vector>

#include "pressure/pressure_system.h"

namespace iqmpm {

class UnilateralContact {
 public:
  // Marks the inequality rows of the assembled system and releases those whose cell was
  // released at the end of the last step. `h_cells`: the dual cell of each h row (from
  // row h_offset; h_offset -1: no interface); `p_rows_on_solid`: the p_f rows (from
  // p_offset) acting on a solid; `p_cells`: the dual cell of each p_f row.
  void start(PressureSystem& system, int h_offset, const std::vector<int>& h_cells, int p_offset,
             const std::vector<int>& p_rows_on_solid, const std::vector<int>& p_cells) {
    const int rows = system.unknowns();
    h_offset_ = h_offset;
    inequality_.assign(rows, 0);
    cell_of_row_.assign(rows, -1);
    for (std::size_t j = 0; h_offset >= 0 && j < h_cells.size(); ++j) {
      inequality_[h_offset + j] = 1;
      cell_of_row_[h_offset + j] = h_cells[j];
    }
    for (int row : p_rows_on_solid) {
      if (p_offset < 0) break;
      inequality_[p_offset + row] = 1;
      cell_of_row_[p_offset + row] = p_cells[row];
    }
    released_.assign(rows, 0);
    for (int i = 0; i < rows; ++i) {
      if (!inequality_[i]) continue;
      const auto& released_cells = is_h_row(i) ? released_h_cells_ : released_p_cells_;
      if (!released_cells.empty()) released_[i] = released_cells[cell_of_row_[i]];
    }
    system.release(released_);
  }

  // One round: updates the set from the solution `lambda` and the velocities it gives.
  // Returns whether the set changed; remembers the released cells for the next step.
  bool update(const PressureSystem& system, const Eigen::VectorXd& velocity_star, const Eigen::VectorXd& lambda,
              int dual_cells) {
    if (inequality_.empty()) return false;
    const Eigen::VectorXd v = system.corrected_velocity(velocity_star, lambda);
    const Eigen::VectorXd value = system.full_constraint_times(v), scale = system.full_row_scale();
    const Real speed = v.size() ? v.cwiseAbs().maxCoeff() : 0;
    std::vector<int> released, restored;
    for (int i = 0; i < system.unknowns(); ++i) {
      if (!inequality_[i]) continue;
      if (!released_[i] && lambda[i] < 0) {
        released_[i] = 1;
        released.push_back(i);
      } else if (released_[i] && value[i] > 1e-9 * scale[i] * speed) {
        released_[i] = 0;
        restored.push_back(i);
      }
    }
    const bool changed = !released.empty() || !restored.empty();
    newly_released_ = std::move(released);
    newly_restored_ = std::move(restored);
    released_h_cells_.assign(dual_cells, 0);
    released_p_cells_.assign(dual_cells, 0);
    for (int i = 0; i < system.unknowns(); ++i)
      if (inequality_[i] && released_[i]) (is_h_row(i) ? released_h_cells_ : released_p_cells_)[cell_of_row_[i]] = 1;
    return changed;
  }

  const std::vector<std::uint8_t>& released_rows() const { return released_; }
  // The cells released at the end of the last step (h rows, p_f rows), which the next
  // step starts from: part of a checkpoint.
  const std::vector<std::uint8_t>& released_h_cells() const { return released_h_cells_; }
  const std::vector<std::uint8_t>& released_p_cells() const { return released_p_cells_; }
  void restore_released_cells(std::vector<std::uint8_t> h_cells, std::vector<std::uint8_t> p_cells) {
    released_h_cells_ = std::move(h_cells);
    released_p_cells_ = std::move(p_cells);
  }
  // The rows the last round released and restored (an LDL^T solver modifies its factor there).
  std::vector<int> take_newly_released() { return std::move(newly_released_); }
  std::vector<int> take_newly_restored() { return std::move(newly_restored_); }

 private:
  bool is_h_row(int i) const { return h_offset_ >= 0 && i >= h_offset_; }

  int h_offset_ = -1;
  std::vector<std::uint8_t> inequality_, released_;
  std::vector<int> cell_of_row_;
  std::vector<std::uint8_t> released_h_cells_, released_p_cells_;
  std::vector<int> newly_released_, newly_restored_;
};

}  // namespace iqmpm
