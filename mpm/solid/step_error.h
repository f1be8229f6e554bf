// The solids' local time-integration error of a step (scene key solid_step_error,
// method.md#solid-time-step): Zienkiewicz and Xie's a-posteriori estimate for the
// trapezoidal and midpoint rules, e = dt^2 / 12 |a^{n+1} - a^n|, the third-order term the
// rule leaves out of a particle's position. Each particle keeps its last step's mean
// acceleration (v^{n+1} - v^n) / dt; two successive means lie (dt + dt_last) / 2 apart, so
// the change over this step is their difference scaled by 2 dt / (dt + dt_last).
#pragma once

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "core/types.h"
#include "particles/particles.h"

namespace iqmpm {

struct SolidStepError {
  Real dt = 0;  // of the step it was measured over; 0: no step yet
  // Over the bodies: the largest particle error over the body's displacement scale. NaN
  // when the step had no earlier acceleration to compare with.
  Real relative = std::numeric_limits<Real>::quiet_NaN();
  // Per body: the largest displacement of its particles from where they were seeded, over
  // the run so far, at least the floor. Not the current one: a vibration passing through
  // its seeded shape would take tiny steps there.
  std::vector<Real> displacement_scale;
};

// After G2P: `solid.velocity` holds v^{n+1}, `start_velocity` v^n. Stores the step's mean
// accelerations in `solid.acceleration` and returns the step's error; the comparison needs
// the accelerations of the step before (`last`, solid.acceleration as it came in).
template <int dim>
SolidStepError measure_solid_step_error(Particles<dim>& solid, const std::vector<Vec<dim>>& start_velocity, Real dt,
                                        const SolidStepError& last, int bodies, Real displacement_floor) {
  const int n = int(solid.size());
  const bool comparable = last.dt > 0 && solid.acceleration.size() == solid.size();
  SolidStepError error;
  error.dt = dt;
  error.displacement_scale = last.displacement_scale;
  error.displacement_scale.resize(bodies, displacement_floor);
  std::vector<Real>& largest_displacement = error.displacement_scale;
  std::vector<Real> largest_error(bodies, 0);
  if (!comparable) solid.acceleration.assign(n, Vec<dim>::Zero());
  const Real scale = dt * dt * dt / (6 * (dt + last.dt));  // dt^2 / 12 at equal steps
  for (int p = 0; p < n; ++p) {
    const Vec<dim> acceleration = (solid.velocity[p] - start_velocity[p]) / dt;
    const int b = solid.body[p];
    if (comparable) largest_error[b] = std::max(largest_error[b], scale * (acceleration - solid.acceleration[p]).norm());
    largest_displacement[b] = std::max(largest_displacement[b], (solid.position[p] - solid.initial_position[p]).norm());
    solid.acceleration[p] = acceleration;
  }
  if (comparable) {
    error.relative = 0;
    for (int b = 0; b < bodies; ++b) error.relative = std::max(error.relative, largest_error[b] / largest_displacement[b]);
  }
  return error;
}

// The next step's largest dt for a relative error `tolerance`: the local error is third
// order in dt, growth at most 2x a step.
inline Real solid_error_dt_limit(const SolidStepError& last, Real tolerance) {
  if (!(last.dt > 0) || std::isnan(last.relative)) return std::numeric_limits<Real>::infinity();
  const Real factor = last.relative > 0 ? std::cbrt(tolerance / last.relative) : Real(2);
  return last.dt * std::min(factor, Real(2));
}

}  // namespace iqmpm
