// Runs a scene to its end time: the time loop, probes, frames, checkpoints, summary (the
// output contract of benchmarks.md). A numerical failure ends the run with status != "ok".
#pragma once

#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "io/state_archive.h"
#include "scene/scene.h"

namespace iqmpm {

struct RunProgress {
  double time = 0, end_time = 0, dt = 0, elapsed_s = 0;
  long steps = 0;
  int linear_iterations = 0;
};

struct RunOptions {
  std::string out_dir;  // empty: no files written (tests)
  std::function<void(const RunProgress&)> on_progress;  // called after every step
  std::vector<long> dump_steps;  // steps (1-based) whose pressure system is written to out_dir
  // Continue from this checkpoint of a run of the same scene in out_dir (iqmpm resume;
  // run/resume.h); null: start from the seeded particles.
  std::shared_ptr<const StateArchive> resume;
};

struct RunResult {
  bool ok = false;
  int signal = 0;  // the run stopped on this signal (SIGINT, SIGTERM; run/interrupt.h); 0: it did not
  Json summary;
  std::vector<std::string> columns;          // metrics.csv header
  std::vector<std::vector<double>> metrics;  // metrics.csv rows
};

RunResult run_scene(const SceneSpec& scene, const RunOptions& options);

}  // namespace iqmpm
