#include "simulation/runner.h"

#include <omp.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <memory>

#include "core/config.h"
#include "core/errors.h"
#include "core/log.h"
#include "io/output_writer.h"
#include "probes/probes.h"
#include "simulation/simulation.h"

namespace iqmpm {
namespace {

template <int dim>
ParticleFrame make_frame(const Simulation<dim>& sim, double time) {
  // Fluid particles (material 0, pressure p_f) then solid ones (1 + body, pressure p_g).
  ParticleFrame frame;
  const auto& fluid = sim.fluid();
  const auto& solid = sim.solid();
  frame.time = time;
  frame.count = int(fluid.size() + solid.size());
  frame.position.assign(3 * frame.count, 0);
  frame.velocity.assign(3 * frame.count, 0);
  frame.pressure = sim.fluid_particle_pressure();
  const auto solid_pressure = sim.solid_particle_pressure();
  frame.pressure.insert(frame.pressure.end(), solid_pressure.begin(), solid_pressure.end());
  frame.material.assign(fluid.size(), 0);
  for (int body : solid.body) frame.material.push_back(1 + body);
  auto copy = [&](const Particles<dim>& particles, std::size_t first) {
    for (std::size_t p = 0; p < particles.size(); ++p)
      for (int a = 0; a < dim; ++a) {
        frame.position[3 * (first + p) + a] = particles.position[p][a];
        frame.velocity[3 * (first + p) + a] = particles.velocity[p][a];
      }
  };
  copy(fluid, 0);
  copy(solid, fluid.size());
  return frame;
}

template <int dim>
RunResult run(const SceneSpec& scene, const RunOptions& options) {
  const auto wall_start = std::chrono::steady_clock::now();
  auto elapsed = [&] { return std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count(); };
  RunResult result;
  Simulation<dim> sim(scene);  // input errors surface here, before any file is written
  std::unique_ptr<OutputWriter> writer;
  if (!options.out_dir.empty()) writer = std::make_unique<OutputWriter>(options.out_dir);

  result.columns.push_back("t");
  for (const auto& probe : scene.probes) result.columns.push_back(probe.name);
  auto sample = [&](double t) {
    std::vector<double> row{t};
    for (const auto& probe : scene.probes) row.push_back(evaluate_probe(sim, probe));
    result.metrics.push_back(std::move(row));
  };

  const double end_time = scene.end_time;
  const double frame_interval = scene.frame_rate > 0 ? 1.0 / scene.frame_rate : end_time;
  double next_frame = frame_interval;
  const double initial_volume = sim.fluid_volume();
  const double initial_particle_volume = sim.fluid_particle_volume();
  double t = 0;
  long steps = 0;
  int max_active_cells = 0;
  long iterations_total = 0;
  int iterations_min = std::numeric_limits<int>::max(), iterations_max = 0;
  int wall_clamps = 0;
  long shifted_solves = 0;  // direct pressure solves retried with a tiny diagonal shift
  long newton_total = 0, newton_cg_total = 0;
  int newton_min = std::numeric_limits<int>::max(), newton_max = 0;
  long contact_rounds_total = 0;
  int contact_rounds_max = 0, unsettled_steps = 0;
  long modified_solves = 0;
  double solid_min_J = 1;
  std::string linear_method;
  std::string status = "ok";

  sample(0);
  if (writer && scene.write_frames) writer->write_frame(make_frame(sim, 0));
  try {
    while (t < end_time * (1 - 1e-12)) {
      // Clamp to frame times and to the end (method.md §3, time step).
      double dt = sim.stable_dt();
      const double next_stop = std::min(next_frame, end_time);
      if (t + dt > next_stop - 1e-12 * end_time) dt = next_stop - t;
      else if (t + 2 * dt > next_stop) dt = 0.5 * (next_stop - t);  // avoid a sliver step
      sim.step(dt);
      t = (t + dt > next_stop - 1e-12 * end_time) ? next_stop : t + dt;
      ++steps;
      const auto& stats = sim.last_step();
      max_active_cells = std::max(max_active_cells, stats.pressure_unknowns);
      iterations_total += stats.linear.iterations;
      iterations_min = std::min(iterations_min, stats.linear.iterations);
      iterations_max = std::max(iterations_max, stats.linear.iterations);
      wall_clamps += stats.wall_clamps;
      shifted_solves += stats.linear.shifted;
      newton_total += stats.newton_iterations;
      newton_cg_total += stats.newton_cg_iterations;
      newton_min = std::min(newton_min, stats.newton_iterations);
      newton_max = std::max(newton_max, stats.newton_iterations);
      solid_min_J = std::min(solid_min_J, double(stats.solid_min_J));
      contact_rounds_total += stats.contact_rounds;
      contact_rounds_max = std::max(contact_rounds_max, stats.contact_rounds);
      unsettled_steps += !stats.contact_settled;
      modified_solves += stats.modified_solves;
      linear_method = stats.linear.method;
      sample(t);
      for (std::size_t c = 1; c < result.metrics.back().size(); ++c)
        if (std::isinf(result.metrics.back()[c]))
          throw NumericalFailure(fmt::format("metric '{}' is infinite at t = {:.4g} s", result.columns[c], t));
      if (t >= next_frame - 1e-12 * end_time) {
        if (writer && scene.write_frames && (scene.frame_rate > 0 || t >= end_time * (1 - 1e-12)))
          writer->write_frame(make_frame(sim, t));
        next_frame += frame_interval;
      }
      if (options.on_progress)
        options.on_progress({t, end_time, dt, elapsed(), steps, stats.linear.iterations});
    }
  } catch (const NumericalFailure& failure) {
    status = fmt::format("failed at t = {:.6g} s, step {}: {}", t, steps + 1, failure.what());
    logger()->error("{}", status);
  }

  const double final_volume = sim.fluid_volume();
  const double final_particle_volume = sim.fluid_particle_volume();
  Json stage_seconds = Json::object();
  for (const auto& [stage, seconds] : sim.timer().stages()) stage_seconds[stage] = seconds;
  Json summary = {
      {"status", status},
      {"scene_name", scene.name},
      {"dim", dim},
      {"dx", scene.dx},
      {"end_time", end_time},
      {"t_final", t},
      {"wall_time_s", elapsed()},
      {"steps", steps},
      {"particles", sim.fluid().size() + sim.solid().size()},
      {"fluid_particles", sim.fluid().size()},
      {"solid_particles", sim.solid().size()},
      {"active_cells", sim.last_step().pressure_unknowns},
      {"active_cells_max", max_active_cells},
      {"stage_seconds", stage_seconds},
      {"linear_solver", linear_method},
      {"linear_iterations",
       {{"min", steps ? iterations_min : 0}, {"mean", steps ? double(iterations_total) / steps : 0.0}, {"max", iterations_max}}},
      {"newton_iterations",
       {{"min", steps && sim.has_solids() ? newton_min : 0},
        {"mean", steps ? double(newton_total) / steps : 0.0},
        {"max", newton_max},
        {"cg_per_step", steps ? double(newton_cg_total) / steps : 0.0}}},
      {"solid_min_J", solid_min_J},
      {"pressure_solves",  // per step; above 1 with coupling.interface = unilateral (active-set rounds)
       {{"mean", steps ? double(contact_rounds_total) / steps : 0.0},
        {"max", contact_rounds_max},
        {"unsettled_steps", unsettled_steps},
        {"factor_modified", modified_solves}}},  // solves done by modifying the LDL^T factor's changed rows
      {"wall_clamps", wall_clamps},
      {"shifted_solves", shifted_solves},
      {"initial_volume", initial_volume},
      {"final_volume", final_volume},
      {"volume_drift", initial_volume > 0 ? (final_volume - initial_volume) / initial_volume : 0.0},
      {"particle_volume_drift",  // the particle measure (Simulation::fluid_particle_volume)
       initial_particle_volume > 0 ? (final_particle_volume - initial_particle_volume) / initial_particle_volume : 0.0},
      {"threads", omp_get_max_threads()},
      {"version", IQMPM_VERSION},
      {"scene", scene.document},
  };
  Json final_metrics = Json::object();
  for (std::size_t c = 1; c < result.columns.size(); ++c) {
    const double v = result.metrics.back()[c];
    final_metrics[result.columns[c]] = std::isfinite(v) ? Json(v) : Json(nullptr);
  }
  summary["final_metrics"] = final_metrics;
  result.ok = status == "ok";
  result.summary = summary;
  if (writer) {
    writer->write_metrics(result.columns, result.metrics);
    writer->write_summary(summary);
  }
  return result;
}

}  // namespace

RunResult run_scene(const SceneSpec& scene, const RunOptions& options) {
  return scene.dim == 2 ? run<2>(scene, options) : run<3>(scene, options);
}

}  // namespace iqmpm
