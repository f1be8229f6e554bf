#include "run/runner.h"

#include <omp.h>

#include <unsupported/Eigen/SparseExtra>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <functional>
#include <memory>
#include <stdexcept>

#include "core/config.h"
#include "core/errors.h"
#include "core/log.h"
#include "diagnostics/health.h"
#include "diagnostics/measurements.h"
#include "diagnostics/probes.h"
#include "io/output_writer.h"
#include "io/pressure_field_writer.h"
#include "run/interrupt.h"
#include "run/run_statistics.h"
#include "run/time_step_policy.h"
#include "simulation/simulation.h"

namespace iqmpm {
namespace {

Json stage_object(const StageTimer& timer) {
  Json stages = Json::object();
  for (const auto& [stage, seconds] : timer.stages()) stages[stage] = seconds;
  return stages;
}

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
  frame.pressure = fluid_particle_pressure(sim);
  const auto solid_pressure = solid_particle_pressure(sim);
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

// --dump-system: the step's pressure system A, its right-hand side r, the constraint rows D
// over the stacked velocities (A = dt D M^-1 D^T + C), and where each unknown lives (block and
// dual cell; grid size; how many velocity entries are the solid's), so benchmarks/solvers can
// try solvers and preconditioners on real matrices and trace a step's interface force to the
// rows that drive it. `label` is the step number, with the attempt for a step that failed (so
// that a failure can be studied offline).
template <int dim>
void dump_pressure_system(const Simulation<dim>& sim, const std::string& directory, const std::string& label) {
  const PressureSystem& system = sim.pressure_system();
  const std::string stem = fmt::format("{}/{{}}_step{}", directory, label);
  Eigen::saveMarket(system.matrix(), fmt::format(stem, "system") + ".mtx");  // both triangles, "general"
  Eigen::saveMarketVector(system.rhs(sim.grid_velocity_before_projection()), fmt::format(stem, "rhs") + ".mtx");
  Eigen::saveMarket(system.constraint(), fmt::format(stem, "constraint") + ".mtx");
  Json layout;
  layout["cells"] = std::vector<int>(sim.grid().cells.data(), sim.grid().cells.data() + dim);
  layout["unknowns"] = system.size();
  for (const auto& block : system.blocks()) layout["blocks"].push_back({{"name", block.name}, {"offset", block.offset}, {"size", block.size}});
  layout["dual_cell"] = sim.dual_cell_of_unknowns();
  const GridLayout<dim> dual_cells = sim.grid().dual_cells();
  layout["dual_cells"] = {{"lo", std::vector<int>(dual_cells.lo().data(), dual_cells.lo().data() + dim)},
                          {"extent", std::vector<int>(dual_cells.extent().data(), dual_cells.extent().data() + dim)}};
  layout["solid_velocity_entries"] = sim.solid_velocity_entries();
  write_file_atomically(fmt::format(stem, "layout") + ".json", layout.dump() + "\n");
}

// Rows of equal width as one flat array (a checkpoint's), and back.
std::vector<double> flatten_rows(const std::vector<std::vector<double>>& rows) {
  std::vector<double> flat;
  for (const auto& row : rows) flat.insert(flat.end(), row.begin(), row.end());
  return flat;
}
std::vector<std::vector<double>> unflatten_rows(const std::vector<double>& flat, std::size_t width) {
  std::vector<std::vector<double>> rows;
  for (std::size_t i = 0; width > 0 && i + width <= flat.size(); i += width)
    rows.emplace_back(flat.begin() + std::ptrdiff_t(i), flat.begin() + std::ptrdiff_t(i + width));
  return rows;
}

// One step from t: a step that fails in a solver or fails a health check is taken again
// from its start with half the dt, up to health.max_retries times and not below dt_min
// (docs/method.md#health-checks); then NumericalFailure with the diagnosis. A first
// attempt whose solid error estimate is far above solid_step_error is taken again once with
// the dt the estimate asks for, at most half the dt (so that no sliver is left before a
// stop) and not below dt_min (method.md#solid-time-step); the retake is not a halving.
// Returns the dt taken; `retries` counts the halvings, `retakes` the solid error's.
// `failed_attempt(n)` runs after the n-th attempt (1-based) failed, before it is undone.
template <int dim>
double take_checked_step(Simulation<dim>& sim, HealthChecks<dim>* health, const SceneSpec& scene,
                         const TimeStepPolicy& policy, double t, double dt, long step, long& retries, long& retakes,
                         StageTimer& timer, const std::function<void(int)>& failed_attempt) {
  bool retaken = false;
  for (int halvings = 0;;) {
    const bool may_retry = halvings < scene.health.max_retries && dt / 2 >= scene.dt_min;
    const bool may_retake = !retaken && halvings == 0 && scene.solid_step_error > 0;
    if (may_retry || may_retake) sim.keep_step_start();  // free: the step's sort hands over the arrays it replaces
    std::string problem;
    try {
      sim.step(dt);
      if (health) {
        auto scope = timer.scope("health checks");
        problem = health->violation(sim);
      }
    } catch (const NumericalFailure& failure) {
      problem = failure.what();
    }
    if (problem.empty() && may_retake && policy.rejects_solid_step(sim)) {
      const double retake_dt = std::min(double(policy.stable_dt(sim)), dt / 2);
      if (retake_dt >= scene.dt_min) {
        logger()->debug("step {} at t = {:.6g} s with dt = {:.3g} s: solid error {:.3g} of the tolerance; taking it "
                        "again with dt = {:.3g} s", step, t, dt, sim.solid_step_error().relative / scene.solid_step_error,
                        retake_dt);
        sim.return_to_step_start();
        dt = retake_dt;
        retaken = true;
        ++retakes;
        continue;
      }
    }
    if (problem.empty()) return dt;
    failed_attempt(halvings + 1);
    if (!may_retry)
      throw NumericalFailure(halvings == 0 ? problem : fmt::format("{} (after {} halvings of dt, at dt = {:.3g} s)", problem, halvings, dt));
    logger()->warn("step {} at t = {:.6g} s with dt = {:.3g} s: {}; taking it again with dt = {:.3g} s", step, t, dt, problem, dt / 2);
    sim.return_to_step_start();
    dt /= 2;
    ++halvings;
    ++retries;
  }
}

template <int dim>
RunResult run(const SceneSpec& scene, const RunOptions& options) {
  const auto wall_start = std::chrono::steady_clock::now();
  auto elapsed = [&] { return std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count(); };
  RunResult result;
  // Input errors surface here, before any file is written.
  Simulation<dim> sim(scene);
  const Probes<dim> probes(scene, sim);
  const TimeStepPolicy policy(scene);
  // Of the seeded particles: a resumed run seeds the same ones before it restores.
  const double initial_volume = fluid_volume(sim);
  const double initial_particle_volume = fluid_particle_volume(sim);

  // steps.csv: the pressure solve of every step (benchmarks.md, "Output contract").
  const std::vector<std::string> step_columns{"step", "t", "dt", "unknowns", "iterations", "initial_residual", "solve_s", "warm_start_s", "contact_rounds", "energy", "constraint_residual", "solid_error"};
  const std::array<const char*, 12> step_column_units{"1", "s", "s", "1", "1", "1", "s", "s", "1", dim == 2 ? "J/m" : "J", "1", "1"};
  if (step_column_units.size() != step_columns.size()) throw std::logic_error("steps.csv: a column without a unit");
  std::vector<std::vector<double>> step_rows;
  result.columns.push_back("t");
  for (std::size_t i = 0; i < probes.size(); ++i) result.columns.push_back(probes.name(i));

  const double end_time = scene.end_time;
  const double frame_interval = scene.frame_rate > 0 ? 1.0 / scene.frame_rate : end_time;
  double next_frame = frame_interval;
  double t = 0;
  double earlier_wall_s = 0;        // of the runs this one continues
  Json resumed_from = Json::array();  // where each resume started
  RunStatistics statistics;
  long dt_retries = 0;
  long solid_error_retakes = 0;  // steps taken again for their solid error (solid_step_error)
  // The runner's own stages beside the simulation's in summary.json's stage_seconds: the
  // health checks, the time step's size, the probes and the output.
  StageTimer run_timer;
  // Of the seeded particles too (their pieces, the energy scale).
  std::unique_ptr<HealthChecks<dim>> health;
  if (scene.health.checks) health = std::make_unique<HealthChecks<dim>>(sim, scene.health.energy_growth);
  if (options.resume) {
    const StateArchive& archive = *options.resume;
    try {
      const Json& state = archive.record.at("run");
      t = state.at("t").get<double>();
      next_frame = scene.frame_rate > 0 ? state.at("next_frame").get<double>() : end_time;
      statistics.restore(state.at("statistics"));
      earlier_wall_s = state.at("wall_time_s").get<double>();
      resumed_from = state.at("resumed_from");
      dt_retries = state.at("dt_retries").get<long>();
      solid_error_retakes = state.value("solid_error_retakes", 0L);  // older checkpoints lack it
      if (state.contains("run_stage_seconds")) {
        for (const auto& [stage, seconds] : state.at("run_stage_seconds").items()) run_timer.add(stage, seconds.template get<double>());
      } else {
        run_timer.add("health checks", state.value("health_checks_s", 0.0));  // older checkpoints lack both
      }
      result.metrics = unflatten_rows(archive.doubles("run.metrics"), result.columns.size());
      // A checkpoint written before solid_error existed has the columns before it (NaN there).
      const std::vector<std::string> stored_columns =
          state.contains("step_columns") ? state.at("step_columns").get<std::vector<std::string>>()
                                         : std::vector<std::string>(step_columns.begin(), step_columns.end() - 1);
      const std::vector<double>& stored_steps = archive.doubles("run.steps");
      if (stored_steps.size() != stored_columns.size() * std::size_t(statistics.steps()))
        throw InputError("the checkpoint's steps table does not match its step count: a damaged checkpoint");
      for (const auto& stored_row : unflatten_rows(stored_steps, stored_columns.size())) {
        std::vector<double> row(step_columns.size(), NAN);
        for (std::size_t c = 0; c < stored_columns.size(); ++c) {
          const auto it = std::find(step_columns.begin(), step_columns.end(), stored_columns[c]);
          if (it != step_columns.end()) row[std::size_t(it - step_columns.begin())] = stored_row[c];
        }
        step_rows.push_back(std::move(row));
      }
      sim.restore_state(archive);
      if (health) health->measure_reference(sim);
    } catch (const Json::exception& e) {
      throw InputError(fmt::format("the checkpoint's record is incomplete ({}): written by another version of iqmpm?", e.what()));
    }
    if (policy.finished(t))
      throw InputError(fmt::format("scene key 'end_time' = {:g}: the checkpoint is at t = {:.6g} s; accepted: a later "
                                   "end_time (iqmpm resume DIR --set end_time=T)", end_time, t));
    if (scene.write_pressure_fields)
      throw InputError("scene key 'write_pressure_fields' = true: a resumed run does not continue pressure_fields.h5; "
                       "accepted: false (iqmpm resume DIR --set write_pressure_fields=false), or run the scene again");
    resumed_from.push_back({{"t", t}, {"step", statistics.steps()}});
    const int threads_before = archive.record.value("threads", 0);
    if (threads_before != omp_get_max_threads())
      logger()->warn("the checkpoint was written with {} threads, this run has {}: sums on the threads may group "
                     "differently, so the results may differ from an uninterrupted run at round-off level",
                     threads_before, omp_get_max_threads());
  }

  std::unique_ptr<OutputWriter> writer;
  if (!options.out_dir.empty())
    writer = options.resume ? std::make_unique<OutputWriter>(options.out_dir, scene.write_frames, options.resume->record.at("run").at("frames"))
                            : std::make_unique<OutputWriter>(options.out_dir, scene.write_frames);
  std::unique_ptr<PressureFieldWriter> pressure_fields;
  if (writer && scene.write_pressure_fields)
    pressure_fields = std::make_unique<PressureFieldWriter>(options.out_dir, scene.name, scene.dx, scene.domain_min,
                                                            std::vector<int>(sim.grid().cells.data(), sim.grid().cells.data() + dim));

  auto sample = [&](double time) {
    auto scope = run_timer.scope("probes");
    std::vector<double> row{time};
    for (std::size_t i = 0; i < probes.size(); ++i) row.push_back(probes.evaluate(sim, i));
    result.metrics.push_back(std::move(row));
  };

  // checkpoint.h5: everything the loop below carries from one step to the next.
  Json last_checkpoint = nullptr;
  double last_checkpoint_wall_s = 0;
  int frames_since_checkpoint = 0;
  auto write_checkpoint = [&] {
    auto scope = run_timer.scope("output");
    StateArchive archive;
    archive.record["format"] = "iqmpm checkpoint";
    archive.record["format_version"] = 1;
    archive.record["version"] = IQMPM_VERSION;
    archive.record["threads"] = omp_get_max_threads();
    archive.record["scene"] = scene.document;
    archive.record["run"] = {{"t", t},
                             {"next_frame", next_frame},
                             {"statistics", statistics.state()},
                             {"wall_time_s", earlier_wall_s + elapsed()},
                             {"resumed_from", resumed_from},
                             {"dt_retries", dt_retries},
                             {"solid_error_retakes", solid_error_retakes},
                             {"step_columns", step_columns},
                             {"run_stage_seconds", stage_object(run_timer)},
                             {"frames", writer->frames_written()}};
    archive.put("run.metrics", flatten_rows(result.metrics));
    archive.put("run.steps", flatten_rows(step_rows));
    sim.save_state(archive);
    archive.write(fmt::format("{}/checkpoint.h5", options.out_dir));
    last_checkpoint = {{"t", t}, {"step", statistics.steps()}};
    last_checkpoint_wall_s = elapsed();
    frames_since_checkpoint = 0;
  };
  const bool checkpoint_by_frames = scene.checkpoint.every_frames > 0;
  const double checkpoint_interval_s = scene.checkpoint.every_minutes > 0 ? 60 * scene.checkpoint.every_minutes : INFINITY;

  std::string status = "ok";
  if (!options.resume) {
    sample(0);
    if (writer && scene.write_frames) writer->write_frame(make_frame(sim, 0));
  }
  try {
    while (!policy.finished(t)) {
      const double next_stop = std::min(next_frame, end_time);
      double dt = [&] {
        auto scope = run_timer.scope("time step size");
        return policy.next_dt(sim, t, next_stop);
      }();
      const double solve_before = sim.timer().seconds("solve"), guess_before = sim.timer().seconds("warm start");
      const long step = statistics.steps() + 1;
      const bool dump_step = writer && std::find(options.dump_steps.begin(), options.dump_steps.end(), step) != options.dump_steps.end();
      dt = take_checked_step(sim, health.get(), scene, policy, t, dt, step, dt_retries, solid_error_retakes, run_timer,
                             [&](int attempt) {
                               if (!dump_step) return;
                               // A StepStats of the attempt counts the unknowns once the system is assembled.
                               if (sim.last_step().pressure_unknowns > 0)
                                 dump_pressure_system(sim, options.out_dir, fmt::format("{}_failed{}", step, attempt));
                               else
                                 logger()->warn("--dump-system {}: attempt {} failed before its pressure system was "
                                                "assembled; nothing to write", step, attempt);
                             });
      if (health) health->accept();
      t = policy.advance(t, dt, next_stop);
      statistics.add(sim.last_step());
      const StepStats& last = sim.last_step();
      step_rows.push_back({double(statistics.steps()), t, dt, double(last.pressure_unknowns), double(last.linear.iterations),
                           last.linear.initial_relative_residual, sim.timer().seconds("solve") - solve_before, sim.timer().seconds("warm start") - guess_before,
                           double(last.contact_rounds), health ? health->energy() : NAN,
                           health ? health->constraint_residual() : NAN, double(last.solid_step_error)});
      if (pressure_fields) {
        auto scope = run_timer.scope("output");
        pressure_fields->append(sim.pressure_fields(), dt, statistics.steps(), last.linear.iterations);
      }
      if (dump_step) dump_pressure_system(sim, options.out_dir, std::to_string(step));
      sample(t);
      for (std::size_t c = 1; c < result.metrics.back().size(); ++c)
        if (std::isinf(result.metrics.back()[c]))
          throw NumericalFailure(fmt::format("metric '{}' is infinite at t = {:.4g} s", result.columns[c], t));
      if (policy.reached(t, next_frame)) {
        auto scope = run_timer.scope("output");
        if (writer && scene.write_frames && (scene.frame_rate > 0 || policy.finished(t))) writer->write_frame(make_frame(sim, t));
        if (writer) {  // the metrics so far, every frame
          writer->write_metrics(result.columns, result.metrics);
          writer->write_table("steps.csv", step_columns, step_rows);
        }
        next_frame += frame_interval;
        ++frames_since_checkpoint;
      }
      const bool done = policy.finished(t) || received_signal() != 0;  // the end's checkpoint follows the loop
      if (writer && !done &&
          ((checkpoint_by_frames && frames_since_checkpoint >= scene.checkpoint.every_frames) ||
           elapsed() - last_checkpoint_wall_s >= checkpoint_interval_s))
        write_checkpoint();
      if (options.on_progress)
        options.on_progress({t, end_time, dt, elapsed(), statistics.steps(), sim.last_step().linear.iterations});
      if (received_signal() != 0) {
        result.signal = received_signal();
        status = fmt::format("interrupted by {} at t = {:.6g} s, step {}", signal_name(result.signal), t, statistics.steps());
        logger()->warn("{}", status);
        break;
      }
    }
  } catch (const NumericalFailure& failure) {
    status = fmt::format("failed at t = {:.6g} s, step {}: {}", t, statistics.steps() + 1, failure.what());
    logger()->error("{}", status);
  }
  // A failed step leaves a state no run should continue from: the last checkpoint stays.
  const bool failed = status != "ok" && result.signal == 0;
  if (writer && !failed) write_checkpoint();

  const double final_volume = fluid_volume(sim);
  const double final_particle_volume = fluid_particle_volume(sim);
  Json stage_seconds = stage_object(sim.timer());
  for (const auto& [stage, seconds] : run_timer.stages()) stage_seconds[stage] = seconds;
  const long steps = statistics.steps();
  Json summary = {
      {"status", status},
      {"scene_name", scene.name},
      {"dim", dim},
      {"dx", scene.dx},
      {"end_time", end_time},
      {"t_final", t},
      {"wall_time_s", earlier_wall_s + elapsed()},
      {"steps", steps},
      {"particles", sim.fluid().size() + sim.solid().size()},
      {"fluid_particles", sim.fluid().size()},
      {"solid_particles", sim.solid().size()},
      {"active_cells", sim.last_step().pressure_unknowns},
      {"stage_seconds", stage_seconds},
      {"initial_volume", initial_volume},
      {"final_volume", final_volume},
      {"volume_drift", initial_volume > 0 ? (final_volume - initial_volume) / initial_volume : 0.0},
      {"particle_volume_drift",  // the particle measure (diagnostics/measurements.h)
       initial_particle_volume > 0 ? (final_particle_volume - initial_particle_volume) / initial_particle_volume : 0.0},
      {"threads", omp_get_max_threads()},
      {"version", IQMPM_VERSION},
      {"dt_retries", dt_retries},        // steps taken again with half the dt (docs/method.md#health-checks)
      {"solid_error_retakes", solid_error_retakes},  // steps taken again for their solid error (method.md#solid-time-step)
      {"energy_scale", health ? Json(health->energy_scale()) : Json(nullptr)},  // of health.energy_growth (J; J/m in 2-D)
      {"checkpoint", last_checkpoint},   // the state checkpoint.h5 holds (null: none written)
      {"resumed_from", resumed_from},    // where each `iqmpm resume` of this run started
      {"scene", scene.document},
  };
  statistics.write(summary, sim.has_solids());
  summary["rejected_warm_starts"] = sim.rejected_warm_starts();
  Json final_metrics = Json::object();
  for (std::size_t c = 1; c < result.columns.size(); ++c) {
    const double v = result.metrics.back()[c];
    final_metrics[result.columns[c]] = std::isfinite(v) ? Json(v) : Json(nullptr);
  }
  summary["final_metrics"] = final_metrics;
  // The unit of every column of metrics.csv and steps.csv.
  Json metric_units = {{"t", "s"}}, step_units = Json::object();
  for (std::size_t i = 0; i < probes.size(); ++i) metric_units[probes.name(i)] = probes.unit(i);
  for (std::size_t c = 0; c < step_columns.size(); ++c) step_units[step_columns[c]] = step_column_units[c];
  summary["units"] = {{"metrics.csv", metric_units}, {"steps.csv", step_units}};
  result.ok = status == "ok";
  result.summary = summary;
  if (writer) {
    writer->write_metrics(result.columns, result.metrics);
    writer->write_table("steps.csv", step_columns, step_rows);
    if (pressure_fields) pressure_fields->close();
    writer->write_summary(summary);
  }
  return result;
}

}  // namespace

RunResult run_scene(const SceneSpec& scene, const RunOptions& options) {
  return scene.dim == 2 ? run<2>(scene, options) : run<3>(scene, options);
}

}  // namespace iqmpm
