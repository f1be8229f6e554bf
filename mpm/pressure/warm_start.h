// The starting guess of the pressure solve: the last solution carried by grid location
// (method.md §8). Unknowns come and go with the particles from step to step, locations
// stay: p_g, p_f and h by dual cell, y by (dual cell, wall side).
#pragma once

#include <Eigen/Core>
#include <array>
#include <vector>

#include "core/types.h"

namespace iqmpm {

// Offsets of the blocks of the pressure system in its solution vector (-1: absent).
struct SolutionLayout {
  int ghost = -1, pressure = -1, wall = -1, interface = -1;
};

class WarmStart {
 public:
  enum Block { ghost, pressure, wall, interface };

  // Each unknown of the block starting at `offset` (-1: absent) takes the last solution at
  // its location; x is left as it is where there was none.
  void guess(Block block, int offset, const std::vector<int>& location, Eigen::VectorXd& x) const {
    const std::vector<Real>& last = last_[block];
    if (offset < 0 || last.empty()) return;
    for (std::size_t i = 0; i < location.size(); ++i) x[offset + Eigen::Index(i)] = last[location[i]];
  }
  // Remembers the block's solution by location (out of `locations`); an absent block
  // leaves zeros.
  void remember(Block block, int offset, const std::vector<int>& location, int locations, const Eigen::VectorXd& x) {
    std::vector<Real>& last = last_[block];
    last.assign(locations, 0);
    if (offset < 0) return;
    for (std::size_t i = 0; i < location.size(); ++i) last[location[i]] = x[offset + Eigen::Index(i)];
  }

 private:
  std::array<std::vector<Real>, 4> last_;
};

}  // namespace iqmpm
