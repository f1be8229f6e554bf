// Shared helpers of the tests that run scenes: benchmark scene paths, metrics columns, and
// a single OpenMP thread for the long runs.
#pragma once

#include <gtest/gtest.h>
#include <omp.h>

#include <cmath>
#include <string>

#include "run/runner.h"

namespace iqmpm::testing {

inline std::string scene_path(const std::string& relative) { return std::string(IQMPM_BENCHMARKS_DIR) + "/" + relative; }

// Index of a metrics column (-1, and a test failure, if there is none).
inline int column_index(const RunResult& result, const std::string& name) {
  for (std::size_t c = 0; c < result.columns.size(); ++c)
    if (result.columns[c] == name) return int(c);
  ADD_FAILURE() << "no metric " << name;
  return -1;
}

// Mean of a metrics column over t in [from, to].
inline double column_mean(const RunResult& result, const std::string& name, double from, double to) {
  const int column = column_index(result, name);
  if (column < 0) return NAN;
  double sum = 0;
  int count = 0;
  for (const auto& row : result.metrics)
    if (row[0] >= from && row[0] <= to) sum += row[column], ++count;
  return count > 0 ? sum / count : NAN;
}

// ctest runs two tests at a time on CI's 2 cores. The long coupled runs, at 2 OpenMP
// threads each side by side, took 250 and 310 s (measured; 25 and 57 s alone on one
// thread), so they run on one thread.
struct OneThread {
  int previous = omp_get_max_threads();
  OneThread() { omp_set_num_threads(1); }
  ~OneThread() { omp_set_num_threads(previous); }
};

}  // namespace iqmpm::testing
