// Young's modulus / Poisson ratio -> Lame parameters, shared by every hyperelastic
// model (method.md §1: the solid is described by mu, lambda).
#pragma once

#include "core/types.h"

#include <cmath>
#include <sstream>
#include <stdexcept>

namespace iqmpm {

struct LameParameters {
  Real mu;      // shear modulus
  Real lambda;  // first Lame parameter
};

// Standard 3-D relations mu = E / (2 (1 + nu)), lambda = E nu / ((1 + nu)(1 - 2 nu)).
// They are used unchanged in 2-D, i.e. 2-D scenes are plane strain.
// Throws std::invalid_argument (user input, always checked) unless E > 0 is finite and
// -1 < nu < 0.5; nu -> 0.5 would make lambda infinite, nu <= -1 makes mu non-positive.
inline LameParameters lame_from_young_poisson(Real E, Real nu) {
  if (!(E > 0) || !std::isfinite(E)) {
    std::ostringstream message;
    message << "Young's modulus E must be finite and > 0 (got E = " << E << ")";
    throw std::invalid_argument(message.str());
  }
  if (!(nu > -1 && nu < 0.5)) {
    std::ostringstream message;
    message << "Poisson ratio nu must satisfy -1 < nu < 0.5 (got nu = " << nu << ")";
    throw std::invalid_argument(message.str());
  }
  return {E / (2 * (1 + nu)), E * nu / ((1 + nu) * (1 - 2 * nu))};
}

}  // namespace iqmpm
