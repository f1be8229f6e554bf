// Two kinds of always-on errors (style.md): bad user input, and a numerical failure
// that stops a run with a diagnosis. Invariants of our own code use assert().
#pragma once

#include <stdexcept>
#include <string>

namespace iqmpm {

// A scene file, an option or a data file that cannot be accepted. The message names
// the key (as a path such as `fluid.shapes[0].min`) and what is accepted.
struct InputError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// The run cannot go on: NaN, a linear solver that did not converge, particles that left
// the domain. The message is the diagnosis written to summary.json.
struct NumericalFailure : std::runtime_error {
  using std::runtime_error::runtime_error;
};

}  // namespace iqmpm
