// MPMNet's prediction of the next step's pressure fields (method.md §10,
// method.md#warm-start): a TorchScript model (mpmnet/README.md, "Model contract") reads the
// last T solved steps as dense grid tensors and returns the next step's. Built only when
// CMake finds libtorch (IQMPM_WITH_TORCH); otherwise load() refuses with an input error.
#pragma once

#include <deque>
#include <memory>
#include <string>
#include <vector>

#include "pressure/warm_start.h"

namespace iqmpm {

class LearnedPredictor {
 public:
  // The fields the network reads and writes, in its channel order.
  static constexpr std::array<SolutionBlock, 3> fields = {pressure_block, ghost_block, interface_block};

  // Loads the model and checks it against the scene (dimension, fields, the grid's size by
  // one dry prediction). InputError naming solver.model when it cannot be used.
  static std::unique_ptr<LearnedPredictor> load(const std::string& path, int dim, const std::vector<int>& cells);
  virtual ~LearnedPredictor() = default;

  virtual int sequence_length() const = 0;
  // The predicted fields of the step whose unknowns are `where`, from the last
  // sequence_length() solutions (oldest first; with fewer, the oldest is repeated, but the
  // warm start asks only once it has them all).
  virtual GridSolution predict(const std::deque<GridSolution>& history, const UnknownLocations& where) const = 0;
};

// Whether this build has libtorch (solver.warm_start = learned).
bool learned_warm_start_available();

}  // namespace iqmpm
