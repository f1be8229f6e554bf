#include "simulation/simulation_impl.h"

namespace iqmpm {
template class Simulation<3>;
}  // namespace iqmpm
