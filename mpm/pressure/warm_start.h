// The starting guess of the pressure solve (solver.warm_start; method.md §8, §10). Unknowns
// come and go with the particles from step to step, grid locations stay: each solution is
// kept by location (p_g, p_f and h by dual cell, y by dual cell and wall side), which is
// also the dense grid tensor MPMNet reads ("Map"); a guess is read back onto the new
// step's unknowns ("Invmap"). Docs: method.md#warm-start.
#pragma once

#include <Eigen/Core>
#include <Eigen/SparseCore>
#include <array>
#include <cstdint>
#include <deque>
#include <memory>
#include <string>
#include <vector>

#include "core/types.h"

namespace iqmpm {

// Offsets of the blocks of the pressure system in its solution vector (-1: absent).
struct SolutionLayout {
  int ghost = -1, pressure = -1, wall = -1, interface = -1;
  int air = -1;  // experimental.trapped_air's pockets: no field of the warm start (zero guess)
};

enum class WarmStartKind {
  none,         // zero
  previous,     // the last step's solution
  extrapolate,  // linear in time through the last two
  projection,   // the A-norm-best combination of the last k solutions (Fischer 1998)
  learned,      // MPMNet's prediction (pressure/learned_warm_start.h), projected with the last k
};

struct WarmStartSpec {
  WarmStartKind kind = WarmStartKind::previous;
  int history = 4;    // projection, learned: solutions kept (k); learned with 0: the raw prediction
  std::string model;  // learned: TorchScript file (mpmnet/README.md)
};

// The blocks of the solution vector, in MPMNet's order of fields where they are fields.
enum SolutionBlock { ghost_block, pressure_block, wall_block, interface_block, block_count };

// Where each unknown of one step lives: per block, its offset in the solution vector (-1:
// absent), the location of each of its unknowns, and how many locations the block has.
struct UnknownLocations {
  std::array<int, block_count> offset{-1, -1, -1, -1};
  std::array<std::vector<int>, block_count> location;
  std::array<int, block_count> locations{};
};

// One solution by location (the Map): value 0 and active 0 where the step had no unknown.
struct GridSolution {
  double time = 0;  // end of the step it solved
  std::array<std::vector<Real>, block_count> value;
  std::array<std::vector<std::uint8_t>, block_count> active;
};

inline GridSolution map_to_grid(const UnknownLocations& where, const Eigen::VectorXd& x, double time) {
  GridSolution grid;
  grid.time = time;
  for (int b = 0; b < block_count; ++b) {
    grid.value[b].assign(where.locations[b], 0);
    grid.active[b].assign(where.locations[b], 0);
    if (where.offset[b] < 0) continue;
    for (std::size_t i = 0; i < where.location[b].size(); ++i) {
      grid.value[b][where.location[b][i]] = x[where.offset[b] + Eigen::Index(i)];
      grid.active[b][where.location[b][i]] = 1;
    }
  }
  return grid;
}

// The Invmap: each unknown of `where` in the blocks of `blocks` takes the value at its
// location (0 where the solution had none); other entries of x are left as they are.
inline void map_from_grid(const GridSolution& grid, const UnknownLocations& where, Eigen::VectorXd& x,
                          std::array<bool, block_count> blocks = {true, true, true, true}) {
  for (int b = 0; b < block_count; ++b) {
    if (!blocks[b] || where.offset[b] < 0 || grid.value[b].size() != std::size_t(where.locations[b])) continue;
    for (std::size_t i = 0; i < where.location[b].size(); ++i)
      x[where.offset[b] + Eigen::Index(i)] = grid.value[b][where.location[b][i]];
  }
}

class LearnedPredictor;

class WarmStart {
 public:
  WarmStart();  // previous
  // Loads the model of `learned` (InputError naming solver.model if it cannot be used).
  WarmStart(const WarmStartSpec& spec, int dim, const std::vector<int>& cells);
  ~WarmStart();
  WarmStart(WarmStart&&) noexcept;
  WarmStart& operator=(WarmStart&&) noexcept;

  // The first guess of a step's solve of A x = b, ending at `time`, with unknowns `where`.
  // x has the system's size; entries that no kind predicts (the mass block) are zero.
  void guess(const UnknownLocations& where, const Eigen::SparseMatrix<Real>& A, const Eigen::VectorXd& b, double time,
             Eigen::VectorXd& x);
  // Keeps a step's final solution.
  void remember(const UnknownLocations& where, const Eigen::VectorXd& x, double time);

  // The solutions kept, oldest first (the last one is the latest step's).
  const std::deque<GridSolution>& history() const { return history_; }
  const WarmStartSpec& spec() const { return spec_; }
  // Guesses that were not finite (a learned prediction, a projection that overflowed),
  // replaced by the last solution or the prediction alone.
  long rejected_predictions() const { return rejected_predictions_; }
  // Continues from a checkpoint's history and count (run/checkpoint.h).
  void restore(std::deque<GridSolution> history, long rejected_predictions) {
    history_ = std::move(history);
    rejected_predictions_ = rejected_predictions;
  }

 private:
  std::size_t kept() const;
  void project(const UnknownLocations& where, const Eigen::SparseMatrix<Real>& A, const Eigen::VectorXd& b,
               const Eigen::VectorXd* extra, Eigen::VectorXd& x);

  WarmStartSpec spec_;
  std::deque<GridSolution> history_;
  std::unique_ptr<LearnedPredictor> learned_;
  long rejected_predictions_ = 0;
};

// The A-norm-best x in the span of the columns of X for A x = b: X c with
// (X^T A X) c = X^T b, dependent columns dropped (Fischer 1998, "Projection techniques for
// iterative solution of Ax = b with successive right-hand sides").
Eigen::VectorXd a_norm_best_combination(const Eigen::SparseMatrix<Real>& A, const Eigen::VectorXd& b,
                                        const Eigen::MatrixXd& X);

}  // namespace iqmpm
