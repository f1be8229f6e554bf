// MPMNet's prediction of the next step's pressure fields (method.md §10,
// method.md#warm-start): a TorchScript model (mpmnet/README.md, "Model contract") reads the
// last T solved steps as dense grid tensors and returns the next step's. Built only when
// CMake finds libtorch (IQMPM_WITH_TORCH); otherwise load() refuses with an input error.
#pragma once

#include <cmath>
#include <deque>
#include <limits>
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

// A multiplier as MPMNet's float32 tensors hold it: values below float's normal range
// (|v| < 1.2e-38 Pa, a zero that round-off left in double) are 0. Kept, such a subnormal
// was the scale of its field in the network's normalisation and made the prediction
// infinite (method.md#warm-start).
inline float mpmnet_value(Real v) { return std::abs(v) < std::numeric_limits<float>::min() ? 0.0f : float(v); }

// Whether this build has libtorch (solver.warm_start = learned).
bool learned_warm_start_available();

}  // namespace iqmpm
