#include "simulation/state.h"
#include "simulation/time_step.h"

namespace iqmpm {
template class Simulation<3>;
}  // namespace iqmpm
