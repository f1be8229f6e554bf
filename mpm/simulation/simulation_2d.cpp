#include "simulation/simulation_impl.h"

namespace iqmpm {
template class Simulation<2>;
}  // namespace iqmpm
