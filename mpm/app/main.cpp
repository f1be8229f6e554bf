// iqmpm: command-line front end of the IQ-MPM solver.
//   iqmpm run SCENE [--out DIR] [--set key=value ...] [--threads N] [--quiet] [--max-memory GIB] [--max-output GIB]
//   iqmpm resume OUT_DIR [--set end_time=T ...] [--threads N] [--quiet] [--max-memory GIB] [--max-output GIB]
//   iqmpm check SCENE [--set key=value ...] [--max-memory GIB] [--max-output GIB]
//   iqmpm keys            (reference of every scene key, default and accepted values)
// Exit codes: 0 ok, 2 bad input, 3 numerical failure (diagnosis in summary.json),
// 130 / 143 interrupted by SIGINT / SIGTERM (outputs up to the interruption and checkpoint.h5
// written; `iqmpm resume` continues).
#include <omp.h>
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fmt/format.h>
#include <spdlog/sinks/stdout_color_sinks.h>

#include "core/config.h"
#include "core/errors.h"
#include "core/log.h"
#include "scene/scene.h"
#include "run/interrupt.h"
#include "run/resource_estimate.h"
#include "run/resume.h"
#include "run/runner.h"

namespace {

using namespace iqmpm;

std::string format_duration(double seconds) {
  if (!std::isfinite(seconds) || seconds < 0) return "--";
  const int s = int(seconds + 0.5);
  return s >= 3600 ? fmt::format("{}h{:02d}m", s / 3600, (s / 60) % 60) : fmt::format("{}m{:02d}s", s / 60, s % 60);
}

// A one-line bar on a terminal; a plain log line every 10 % otherwise.
class ProgressReporter {
 public:
  explicit ProgressReporter(bool quiet) : quiet_(quiet), terminal_(isatty(fileno(stderr))) {}

  void operator()(const RunProgress& p) {
    if (quiet_) return;
    const double fraction = p.end_time > 0 ? p.time / p.end_time : 1;
    const double eta = fraction > 0 ? p.elapsed_s * (1 - fraction) / fraction : -1;
    if (terminal_) {
      if (p.elapsed_s - last_draw_ < 0.1 && fraction < 1) return;
      last_draw_ = p.elapsed_s;
      const int width = 30, filled = int(fraction * width);
      fmt::print(stderr, "\r[{}{}] {:5.1f}%  t = {:.4f}/{:.4g} s  dt = {:.2e} s  step {}  CG {}  ETA {}   ",
                 std::string(filled, '#'), std::string(width - filled, '.'), 100 * fraction, p.time, p.end_time, p.dt,
                 p.steps, p.linear_iterations, format_duration(eta));
      if (fraction >= 1) fmt::print(stderr, "\n");
    } else {
      const int decile = int(fraction * 10 + 1e-9);
      if (decile <= last_decile_) return;
      last_decile_ = decile;
      spdlog::info("t = {:.4f}/{:.4g} s ({:.0f} %), dt = {:.2e} s, step {}, elapsed {}, ETA {}", p.time, p.end_time,
                   100 * fraction, p.dt, p.steps, format_duration(p.elapsed_s), format_duration(eta));
    }
  }

 private:
  bool quiet_, terminal_;
  double last_draw_ = -1;
  int last_decile_ = 0;
};

void print_stage_table(const Json& summary) {
  const double wall = summary["wall_time_s"].get<double>();
  fmt::print("\n{:<21} {:>10} {:>8}\n", "stage", "seconds", "share");
  double staged = 0;
  for (const auto& [stage, seconds] : summary["stage_seconds"].items()) {
    fmt::print("{:<21} {:>10.3f} {:>7.1f}%\n", stage, seconds.get<double>(), 100 * seconds.get<double>() / wall);
    staged += seconds.get<double>();
  }
  fmt::print("{:<21} {:>10.3f} {:>7.1f}%\n", "other (set-up, rest)", wall - staged, 100 * (wall - staged) / wall);
  fmt::print("{:<21} {:>10.3f}\n", "wall time", wall);
  const auto& it = summary["linear_iterations"];
  fmt::print("steps {}, particles {}, active cells {} (max {}), solver {}, CG iterations min/mean/max {}/{:.1f}/{}, volume drift {:.3e} (particle measure {:.3e})\n",
             summary["steps"].get<long>(), summary["particles"].get<long>(), summary["active_cells"].get<int>(),
             summary["active_cells_max"].get<int>(), summary["linear_solver"].get<std::string>(), it["min"].get<int>(),
             it["mean"].get<double>(), it["max"].get<int>(), summary["volume_drift"].get<double>(),
             summary["particle_volume_drift"].get<double>());
  const auto& solves = summary["pressure_solves"];
  if (solves["max"].get<int>() > 1)
    fmt::print("pressure solves per step (unilateral interface) mean {:.2f}, max {}, steps whose active set did not settle {}, "
               "solves by modifying the LDL^T factor {}\n",
               solves["mean"].get<double>(), solves["max"].get<int>(), solves["unsettled_steps"].get<int>(),
               solves["factor_modified"].get<long>());
}

}  // namespace

int main(int argc, char** argv) {
  // OpenMP workers that spin after a parallel loop take the core from the serial stages
  // (the pressure solve): on a 2-core machine with one other busy process the dam break ran
  // 3.8x slower with the default (active) policy. The policy is read when the OpenMP
  // runtime loads, so it is set and the program restarted once, unless the user chose one.
  if (!std::getenv("OMP_WAIT_POLICY")) {
    setenv("OMP_WAIT_POLICY", "passive", 1);
    execv("/proc/self/exe", argv);  // returns only on failure: go on with the default policy
  }
  CLI::App app{"iqmpm: interface-quadrature MPM solver (incompressible fluid, free-slip walls)"};
  app.set_version_flag("--version", std::string(IQMPM_VERSION));
  app.require_subcommand(1);

  std::string scene_path, out_dir = "out";
  std::vector<std::string> overrides;
  int threads = 0;
  bool quiet = false;
  std::vector<long> dump_steps;
  double max_memory_gib = default_memory_limit() / kGiB, max_output_gib = 20;
  // Both commands refuse a scene past the limits (run/resource_estimate.h).
  auto add_limits = [&](CLI::App* command) {
    command->add_option("--max-memory", max_memory_gib, "refuse a scene whose estimated peak memory passes this (GiB; default 3/4 of physical memory)")
        ->check(CLI::PositiveNumber)->capture_default_str();
    command->add_option("--max-output", max_output_gib, "refuse a run whose estimated output passes this (GiB)")
        ->check(CLI::PositiveNumber)->capture_default_str();
  };

  auto* run = app.add_subcommand("run", "run a scene to its end time, writing frames, metrics.csv and summary.json");
  run->add_option("scene", scene_path, "scene file (JSON); `iqmpm keys` lists every key")->required()->check(CLI::ExistingFile);
  run->add_option("--out,-o", out_dir, "output folder (created; existing files are replaced)")->capture_default_str();
  run->add_option("--set,-s", overrides, "override a scene key, e.g. --set dx=0.002 --set solver.method=pcg (repeatable)");
  run->add_option("--threads,-j", threads, "OpenMP threads (0: all cores; at most 1024)")->check(CLI::Range(0, 1024))->capture_default_str();
  run->add_flag("--quiet,-q", quiet, "no progress output");
  run->add_option("--dump-system", dump_steps,
                  "write the pressure system of these steps (1-based) to the output folder: system_stepN.mtx (Matrix Market), "
                  "rhs_stepN.mtx, constraint_stepN.mtx (the rows D over the stacked velocities, solid nodes first) and layout_stepN.json "
                  "(blocks, dual cell of each unknown, the dual cells' box, how many velocity entries are the solid's), for "
                  "benchmarks/solvers; an attempt of such a "
                  "step that fails a check is written as well, as stepN_failedK (K: attempt), before dt is halved (not one that failed "
                  "before its system was assembled, e.g. in the solid's Newton step: a warning says so)")
      ->check(CLI::PositiveNumber)->delimiter(',');
  add_limits(run);

  auto* resume = app.add_subcommand("resume", "continue a run from OUT_DIR/checkpoint.h5 in the same folder (written every "
                                              "checkpoint.every_frames frames, on SIGINT / SIGTERM and at the end)");
  resume->add_option("out", out_dir, "the run's output folder")->required()->check(CLI::ExistingDirectory);
  resume->add_option("--set,-s", overrides, "change end_time, cfl, dt_min, dt_max, write_pressure_fields, checkpoint.*, "
                                            "solver.* or newton.* (repeatable)");
  resume->add_option("--threads,-j", threads, "OpenMP threads (0: all cores; at most 1024); the checkpoint's count repeats "
                                              "the uninterrupted run bit for bit")->check(CLI::Range(0, 1024))->capture_default_str();
  resume->add_flag("--quiet,-q", quiet, "no progress output");
  add_limits(resume);

  auto* check = app.add_subcommand("check", "validate a scene file (and --set overrides) without running it");
  check->add_option("scene", scene_path, "scene file (JSON)")->required()->check(CLI::ExistingFile);
  check->add_option("--set,-s", overrides, "override a scene key (repeatable)");
  add_limits(check);

  auto* keys = app.add_subcommand("keys", "print every scene key with its type, default, accepted values and meaning");

  // Bad command lines are bad input: exit 2 with the message and the usage (help and
  // --version exit 0 as CLI11 does).
  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForAllHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForVersion& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    fmt::print(stderr, "error: {}\n\n{}", e.what(), app.help());
    return 2;
  }

  auto console = spdlog::stderr_color_mt("console");
  spdlog::set_default_logger(console);
  spdlog::set_pattern("[%H:%M:%S] %^%l%$ %v");
  logger()->set_level(spdlog::level::info);

  try {
    if (*keys) {
      fmt::print("| key | type | default | accepted | meaning |\n|---|---|---|---|---|\n");
      for (const auto& k : document_scene_keys())
        fmt::print("| `{}` | {} | {} | {} | {} |\n", k.path, k.type, k.default_value, k.accepted, k.meaning);
      return 0;
    }
    std::shared_ptr<const StateArchive> checkpoint;
    if (*resume) checkpoint = read_checkpoint(out_dir);
    const SceneSpec scene = checkpoint ? scene_to_resume(*checkpoint, overrides) : load_scene(scene_path, overrides);
    // Before anything is allocated or the output folder exists.
    const ResourceEstimate estimate = estimate_resources(scene);
    check_resources(estimate, {max_memory_gib * kGiB, max_output_gib * kGiB});
    if (*check) {
      fmt::print("{}: valid ({}-D, dx = {:g} m, end_time = {:g} s, {} probes)\n{}\n", scene_path, scene.dim, scene.dx,
                 scene.end_time, scene.probes.size(), describe(estimate));
      return 0;
    }
    if (threads > 0) omp_set_num_threads(threads);
    spdlog::info("iqmpm {}: {} '{}' ({}-D, dx = {:g} m, end_time = {:g} s), {} threads, output in {}", IQMPM_VERSION,
                 checkpoint ? fmt::format("resuming at t = {:.6g} s", checkpoint->record.at("run").at("t").get<double>()) : "scene",
                 scene.name.empty() ? scene_path : scene.name, scene.dim, scene.dx, scene.end_time, omp_get_max_threads(),
                 out_dir);
    spdlog::info("{}", describe(estimate));
    ProgressReporter progress(quiet);
    RunOptions options;
    options.out_dir = out_dir;
    options.dump_steps = dump_steps;
    options.resume = checkpoint;
    options.on_progress = [&](const RunProgress& p) { progress(p); };
    catch_interrupts();
    const RunResult result = run_scene(scene, options);
    if (!quiet) print_stage_table(result.summary);
    if (result.signal != 0) {
      spdlog::warn("the metrics up to the interruption and summary.json are in {}", out_dir);
      return 128 + result.signal;
    }
    if (!result.ok) {
      spdlog::error("run failed: {}", result.summary["status"].get<std::string>());
      spdlog::error("partial metrics and the diagnosis are in {}/summary.json", out_dir);
      return 3;
    }
    spdlog::info("done: {}/summary.json, {}/metrics.csv, {}/particles.xdmf", out_dir, out_dir, out_dir);
    return 0;
  } catch (const InputError& error) {
    spdlog::error("{}", error.what());
    return 2;
  }
}
