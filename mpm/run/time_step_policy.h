// The whole time-step policy in one place (method.md §3, time step): dt = cfl dx /
// max(particle speed, sqrt(|g| dx)), capped at dt_max, then clamped to the next output
// stop (a frame time or the end) without leaving a sliver step; a dt below dt_min stops
// the run. There is no sound-speed limit: the solve is implicit.
#pragma once

#include <algorithm>
#include <cmath>
#include <fmt/format.h>

#include "core/errors.h"
#include "scene/scene.h"
#include "simulation/simulation.h"

namespace iqmpm {

class TimeStepPolicy {
 public:
  explicit TimeStepPolicy(const SceneSpec& scene)
      : cfl_(scene.cfl), dt_min_(scene.dt_min), dt_max_(scene.dt_max), end_time_(scene.end_time) {}

  // dt from the particle speeds alone (no output stop).
  template <int dim>
  Real stable_dt(const Simulation<dim>& sim) const {
    Real max_speed = 0;
    for (const auto& v : sim.fluid().velocity) max_speed = std::max(max_speed, v.norm());
    for (const auto& v : sim.solid().velocity) max_speed = std::max(max_speed, v.norm());
    // A particle at rest gains sqrt(|g| dx) falling one cell: the floor keeps the first steps safe.
    const Real dx = sim.grid().dx;
    const Real speed = std::max(max_speed, std::sqrt(sim.gravity().norm() * dx));
    const Real dt = speed > 0 ? cfl_ * dx / speed : dt_max_;
    return std::min(dt, dt_max_);
  }

  // The step to take from t towards next_stop. Throws NumericalFailure below dt_min.
  template <int dim>
  double next_dt(const Simulation<dim>& sim, double t, double next_stop) const {
    double dt = stable_dt(sim);
    if (t + dt > next_stop - 1e-12 * end_time_) dt = next_stop - t;
    else if (t + 2 * dt > next_stop) dt = 0.5 * (next_stop - t);  // avoid a sliver step
    if (dt < dt_min_) throw NumericalFailure(fmt::format("time step {:.3g} s below dt_min {:.3g} s", dt, dt_min_));
    return dt;
  }

  // The time after a step of dt from t: exactly the stop when the step reaches it.
  double advance(double t, double dt, double next_stop) const {
    return (t + dt > next_stop - 1e-12 * end_time_) ? next_stop : t + dt;
  }
  bool reached(double t, double stop) const { return t >= stop - 1e-12 * end_time_; }
  bool finished(double t) const { return !(t < end_time_ * (1 - 1e-12)); }

 private:
  Real cfl_, dt_min_, dt_max_;
  double end_time_;
};

}  // namespace iqmpm
