// What a run will take before it takes it: peak memory (grid and particles) and output
// size, estimated from the scene alone, and the limits past which a run is refused as bad
// input (exit 2, nothing allocated or written). The model, what it includes and leaves
// out, and its calibration against measured peak RSS are in docs/method.md#resource-limits;
// the constants below are those of that calibration and err high.
#pragma once

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <fmt/format.h>
#include <string>

#include "core/errors.h"
#include "scene/scene.h"

namespace iqmpm {

struct ResourceEstimate {
  double cells = 0, corners = 0, nodes = 0;        // the dense grid layouts (grid/grid.h)
  double fluid_particles = 0, solid_particles = 0;  // from the shapes' volume, clipped to the domain box
  double unknowns = 0;         // pressure unknowns: the cells the material fills, with the margin it spreads into
  double matrix_nonzeros = 0;  // of the pressure system
  double factor_nonzeros = 0;  // of a direct solver's factor (0: PCG)
  double steps = 0;            // at the first step's dt (particles at rest), a lower bound
  double frames = 0;
  double memory_bytes = 0, output_bytes = 0;
};

struct ResourceLimits {
  double max_memory_bytes = 0, max_output_bytes = 0;
};

inline constexpr double kGiB = 1024.0 * 1024.0 * 1024.0;

// Three quarters of the machine's physical memory: the rest is the system's and the other
// processes', and a run that swaps is slower than one refused.
inline double default_memory_limit() {
  const double pages = double(sysconf(_SC_PHYS_PAGES)), page = double(sysconf(_SC_PAGE_SIZE));
  return pages > 0 && page > 0 ? 0.75 * pages * page : 16 * kGiB;
}

namespace resource_detail {

// Volume of a shape inside the domain box: boxes exactly; spheres and polygons whole (high
// when clipped).
inline double volume_inside(const ShapeSpec& s, const SceneSpec& scene) {
  const int dim = scene.dim;
  double v = 1;
  if (s.type == ShapeType::box) {
    for (int a = 0; a < dim; ++a)
      v *= std::max(0.0, std::min(s.max[a], scene.domain_max[a]) - std::max(s.min[a], scene.domain_min[a]));
    return v;
  }
  if (s.type == ShapeType::sphere) return dim == 2 ? M_PI * s.radius * s.radius : 4.0 / 3.0 * M_PI * std::pow(s.radius, 3);
  double twice_area = 0;  // shoelace
  const std::size_t n = s.vertices.size() / 2;
  for (std::size_t i = 0, j = n - 1; i < n; j = i++)
    twice_area += s.vertices[2 * j] * s.vertices[2 * i + 1] - s.vertices[2 * i] * s.vertices[2 * j + 1];
  return 0.5 * std::abs(twice_area);
}

inline double volume_inside(const std::vector<ShapeSpec>& shapes, const SceneSpec& scene) {
  double v = 0;  // overlapping shapes counted twice: high
  for (const auto& s : shapes) v += volume_inside(s, scene);
  return v;
}

}  // namespace resource_detail

inline ResourceEstimate estimate_resources(const SceneSpec& scene) {
  using resource_detail::volume_inside;
  const int dim = scene.dim;
  ResourceEstimate e;
  e.cells = e.corners = e.nodes = 1;
  for (int a = 0; a < dim; ++a) {
    const double n = std::round((scene.domain_max[a] - scene.domain_min[a]) / scene.dx);
    e.cells *= n;
    e.corners *= n + 1;
    e.nodes *= n + 2;
  }
  const double cell_volume = std::pow(scene.dx, dim), per_cell = std::pow(scene.particles_per_axis, dim);
  double solid_volume = 0;
  e.solid_particles = 0;
  for (const auto& solid : scene.solids) {
    const double volume = volume_inside(solid.shapes, scene), solid_per_cell = std::pow(solid.particles_per_axis, dim);
    solid_volume += volume;
    e.solid_particles += std::min(volume / cell_volume * solid_per_cell, e.cells * solid_per_cell);
  }
  const double fluid_volume = volume_inside(scene.fluid.shapes, scene);
  e.fluid_particles = std::min(fluid_volume / cell_volume * per_cell, e.cells * per_cell);
  // A flow spreads: the dam break's active cells grow to 1.09 times the cells it fills at
  // the start. A quarter more, never more than the grid.
  e.unknowns = std::min(e.cells, 1.25 * (fluid_volume + solid_volume) / cell_volume);
  // Q1-P0: a cell couples to the cells that share one of its corners, 3^dim of them.
  e.matrix_nonzeros = e.unknowns * std::pow(3, dim);
  const bool direct = scene.solver.method == LinearSolverMethod::ldlt || scene.solver.method == LinearSolverMethod::cholmod ||
                      scene.experimental.solid_response == SolidResponse::stiffness ||
                      (scene.solver.method == LinearSolverMethod::automatic && dim == 2 &&
                       e.unknowns <= scene.solver.direct_max_unknowns);
  // Nested dissection's fill: O(n log n) in 2-D, O(n^4/3) in 3-D (George 1973).
  if (direct)
    e.factor_nonzeros = dim == 2 ? 5 * e.unknowns * std::log2(std::max(2.0, e.unknowns)) : 12 * std::pow(e.unknowns, 4.0 / 3.0);
  const double g = std::sqrt(scene.gravity[0] * scene.gravity[0] + scene.gravity[1] * scene.gravity[1] +
                             (dim == 3 ? scene.gravity[2] * scene.gravity[2] : 0));
  const double first_dt = std::min(scene.dt_max, g > 0 ? scene.cfl * std::sqrt(scene.dx / g) : scene.dt_max);
  e.steps = std::ceil(scene.end_time / first_dt);
  const double frame_times = scene.frame_rate > 0 ? std::floor(scene.end_time * scene.frame_rate * (1 + 1e-12)) + 2 : 2;
  e.frames = scene.write_frames ? frame_times : 0;

  // Memory (bytes), each term fitted to the peak RSS of runs that vary it alone: a fixed
  // part (program, libraries, OpenMP and CHOLMOD workspaces); the dense per-cell,
  // per-corner and (with solids) per-node arrays of a step; each particle with what a step
  // and a frame copy of it take (a solid one with its Newton and interface data); the
  // pressure system per non-zero (its matrix, G, the operators' triplets, IC(0)); the
  // factor (value and row index); BoomerAMG's hierarchy, 15 bytes a non-zero of A (3-D
  // tank at dx 1/64 and 1/80, PCG: +60 and +125 MiB peak over IC(0), 14.2 and 15.2 bytes
  // an estimated non-zero); the metrics and steps.csv rows kept to the run's end.
  const bool solids = !scene.solids.empty();
  const bool amg_hierarchy = !direct && scene.solver.preconditioner == Preconditioner::boomeramg;
  // The warm start keeps solutions as dense grid fields, 18 bytes a cell each (fitted
  // with `previous`, one kept); the kinds that keep more add theirs.
  const WarmStartKind kind = scene.warm_start.kind;
  const double kept = kind == WarmStartKind::none ? 0 : kind == WarmStartKind::previous ? 1 : kind == WarmStartKind::extrapolate ? 2
                                                                                                 : std::max(scene.warm_start.history, 2);
  e.memory_bytes = 25e6 + (195 + 18 * (kept - 1)) * e.cells + (solids ? 100 : 0) * e.nodes + (dim == 2 ? 150 : 215) * e.fluid_particles +
                   (dim == 2 ? 5000 : 10000) * e.solid_particles + (amg_hierarchy ? 95 : 80) * e.matrix_nonzeros + 12 * e.factor_nonzeros +
                   e.steps * (8.0 * scene.probes.size() + 160);

  // Output (bytes): per frame, 64 bytes a particle (connectivity, position, velocity,
  // pressure, material) and a few kB of HDF5 and XDMF; metrics.csv and steps.csv rows;
  // pressure_fields.h5 uncompressed (3 fields of 4 bytes and a 1-byte mask per cell, every
  // step), which its compression only lowers.
  const double particles = e.fluid_particles + e.solid_particles;
  e.output_bytes = e.frames * (64 * particles + 4096) + e.steps * (25.0 * (1 + scene.probes.size()) + 160) +
                   (scene.write_pressure_fields ? e.steps * 15 * e.cells : 0);
  return e;
}

inline std::string format_bytes(double bytes) {
  return bytes >= kGiB ? fmt::format("{:.3g} GiB", bytes / kGiB) : fmt::format("{:.3g} MiB", bytes / (1024.0 * 1024.0));
}

// What the estimates count, and one line with both for `iqmpm check` and the log of `run`.
inline std::string describe_counts(const ResourceEstimate& e) {
  return fmt::format("{:.3g} dual cells, {:.3g} fluid and {:.3g} solid particles, about {:.3g} pressure unknowns{}, {:.3g} "
                     "frames, at least {:.3g} steps", e.cells, e.fluid_particles, e.solid_particles, e.unknowns,
                     e.factor_nonzeros > 0 ? fmt::format(", a direct factor of {:.3g} non-zeros", e.factor_nonzeros) : "",
                     e.frames, e.steps);
}

inline std::string describe(const ResourceEstimate& e) {
  return fmt::format("estimated peak memory {}, estimated output {} ({})", format_bytes(e.memory_bytes),
                     format_bytes(e.output_bytes), describe_counts(e));
}

// Throws InputError when the run would pass a limit, naming the keys that drive the
// estimate and the option that raises the limit.
inline void check_resources(const ResourceEstimate& e, const ResourceLimits& limits) {
  if (e.memory_bytes > limits.max_memory_bytes)
    throw InputError(fmt::format(
        "the scene needs an estimated {} of memory, more than the limit of {} ({}); the counts come from 'dx' and "
        "'particles_per_axis' (and the shapes' size), the rows kept per step from 'end_time'; accepted: a coarser dx or "
        "fewer particles_per_axis, or raise the limit with --max-memory GIB",
        format_bytes(e.memory_bytes), format_bytes(limits.max_memory_bytes), describe_counts(e)));
  if (e.output_bytes > limits.max_output_bytes)
    throw InputError(fmt::format(
        "the run would write an estimated {} of output, more than the limit of {} ({}); frames come from 'end_time' x "
        "'frame_rate' x the particles ('dx', 'particles_per_axis'), rows from 'end_time' / dt; accepted: a lower "
        "frame_rate or end_time, write_frames = false, or raise the limit with --max-output GIB",
        format_bytes(e.output_bytes), format_bytes(limits.max_output_bytes), describe_counts(e)));
}

}  // namespace iqmpm
