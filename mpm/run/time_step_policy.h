// The whole time-step policy in one place (method.md §3, time step): dt = cfl dx /
// max(particle speed, sqrt(|g| dx)), where a fluid particle of spray (its cell holds at most
// half a cell of water and solid) counts at cfl / spray_cfl of its speed
// (method.md#time-step), capped at dt_max and, with solid_step_error, at the
// dt that keeps the solids' estimated local error at that tolerance
// (method.md#solid-time-step), then clamped to the next output stop (a frame time or the
// end) without leaving a sliver step; a dt below dt_min stops the run. There is no
// sound-speed limit: the solve is implicit.
#pragma once

#include <algorithm>
#include <cmath>
#include <fmt/format.h>
#include <vector>

#include "core/errors.h"
#include "particles/volume_per_cell.h"
#include "scene/scene.h"
#include "simulation/simulation.h"
#include "solid/step_error.h"

namespace iqmpm {

class TimeStepPolicy {
 public:
  explicit TimeStepPolicy(const SceneSpec& scene)
      : cfl_(scene.cfl),
        spray_cfl_(scene.spray_cfl),
        dt_min_(scene.dt_min),
        dt_max_(scene.dt_max),
        solid_step_error_(scene.solid_step_error),
        end_time_(scene.end_time) {}

  // dt from the particle speeds and the solids' error (no output stop).
  template <int dim>
  Real stable_dt(const Simulation<dim>& sim) const {
    const Grid<dim>& grid = sim.grid();
    const Particles<dim>& fluid = sim.fluid();
    // Spray moves up to spray_cfl cells a step: its speed counts at cfl / spray_cfl.
    const std::vector<Real> material = spray_cfl_ != cfl_ ? material_volume_per_cell(grid, fluid, sim.solid()) : std::vector<Real>();
    const GridLayout<dim> cells = grid.dual_cells();
    const Real spray_volume = Real(0.5 + 1e-9) * grid.cell_volume();  // half a cell, to round-off
    Real max_speed = 0;
    const int n = int(fluid.size());
#pragma omp parallel for schedule(static) reduction(max : max_speed)
    for (int p = 0; p < n; ++p) {
      Real speed = fluid.velocity[p].norm();
      if (!material.empty()) {
        const IVec<dim> cell = dual_cell_of<dim>(grid.to_cells(fluid.position[p]));
        if (cells.contains(cell) && material[cells.index(cell)] <= spray_volume) speed *= cfl_ / spray_cfl_;
      }
      max_speed = std::max(max_speed, speed);
    }
    for (const auto& v : sim.solid().velocity) max_speed = std::max(max_speed, v.norm());
    // A particle at rest gains sqrt(|g| dx) falling one cell: the floor keeps the first steps safe.
    const Real dx = grid.dx;
    const Real speed = std::max(max_speed, std::sqrt(sim.gravity().norm() * dx));
    Real dt = speed > 0 ? cfl_ * dx / speed : dt_max_;
    if (solid_step_error_ > 0) dt = std::min(dt, solid_error_dt_limit(sim.solid_step_error(), solid_step_error_));
    return std::min(dt, dt_max_);
  }

  // A step whose solids' error estimate exceeds the tolerance this many times is taken
  // again (once) with the dt the estimate asks for: a sudden load (an impact) would
  // otherwise pass in one step far too long for it.
  static constexpr Real solid_error_rejection = 4;
  template <int dim>
  bool rejects_solid_step(const Simulation<dim>& sim) const {
    return solid_step_error_ > 0 && sim.solid_step_error().relative > solid_error_rejection * solid_step_error_;
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
  Real cfl_, spray_cfl_, dt_min_, dt_max_;
  Real solid_step_error_;  // 0: the solids do not limit dt
  double end_time_;
};

}  // namespace iqmpm
