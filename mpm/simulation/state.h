// What one step hands to the next, saved and restored for checkpoints
// (docs/method.md#checkpoints): the particles with every attribute, the simulated time,
// the warm start's kept solutions, the unilateral interface's released cells and the
// stage timings. The grid state, operators and solver are rebuilt by every step from
// these, so a run resumed from them repeats the uninterrupted run bit for bit (at the same
// thread count: parallel sums may group differently on other counts).
#pragma once

#include <fmt/format.h>

#include <stdexcept>
#include <utility>

#include "core/errors.h"
#include "io/state_archive.h"
#include "simulation/simulation.h"

namespace iqmpm {
namespace state_detail {

inline std::vector<std::int64_t> widen(const std::vector<int>& values) { return {values.begin(), values.end()}; }

template <int dim>
void save_particles(StateArchive& archive, const std::string& kind, const Particles<dim>& p) {
  archive.put(kind + ".position", flatten(p.position));
  archive.put(kind + ".velocity", flatten(p.velocity));
  archive.put(kind + ".affine", flatten(p.affine));
  archive.put(kind + ".mass", p.mass);
  archive.put(kind + ".initial_volume", p.initial_volume);
  archive.put(kind + ".deformation_gradient", flatten(p.deformation_gradient));
  archive.put(kind + ".ghost_J", p.ghost_J);
  archive.put(kind + ".body", widen(p.body));
  archive.put(kind + ".initial_position", flatten(p.initial_position));
  archive.put(kind + ".acceleration", flatten(p.acceleration));
}

// The checkpoint's particles of `kind`, which must be as many as the scene seeded.
template <int dim>
Particles<dim> load_particles(const StateArchive& archive, const std::string& kind, std::size_t seeded) {
  Particles<dim> p;
  p.position = unflatten<Vec<dim>>(archive.doubles(kind + ".position"));
  p.velocity = unflatten<Vec<dim>>(archive.doubles(kind + ".velocity"));
  p.affine = unflatten<Mat<dim>>(archive.doubles(kind + ".affine"));
  p.mass = archive.doubles(kind + ".mass");
  p.initial_volume = archive.doubles(kind + ".initial_volume");
  p.deformation_gradient = unflatten<Mat<dim>>(archive.doubles(kind + ".deformation_gradient"));
  p.ghost_J = archive.doubles(kind + ".ghost_J");
  const auto& body = archive.integers(kind + ".body");
  p.body.assign(body.begin(), body.end());
  p.initial_position = unflatten<Vec<dim>>(archive.doubles(kind + ".initial_position"));
  // A checkpoint written before solid_step_error existed has none: the first step compares with nothing.
  if (archive.contains(kind + ".acceleration")) p.acceleration = unflatten<Vec<dim>>(archive.doubles(kind + ".acceleration"));
  const std::size_t n = p.position.size();
  const bool solid_attributes_fit = p.deformation_gradient.empty() ||
                                    (p.deformation_gradient.size() == n && p.ghost_J.size() == n && p.body.size() == n &&
                                     p.initial_position.size() == n && (p.acceleration.empty() || p.acceleration.size() == n));
  if (n != seeded || p.velocity.size() != n || p.affine.size() != n || p.mass.size() != n || p.initial_volume.size() != n ||
      !solid_attributes_fit)
    throw InputError(fmt::format("the checkpoint's {} particles ({}) do not match the scene's ({}): a checkpoint of "
                                 "another scene, or a damaged one", kind, n, seeded));
  return p;
}

}  // namespace state_detail

template <int dim>
void Simulation<dim>::save_state(StateArchive& archive) const {
  using namespace state_detail;
  save_particles(archive, "fluid", fluid_);
  save_particles(archive, "solid", solid_);
  Json& record = archive.record["simulation"];
  record["dim"] = dim;
  record["time"] = time_;
  record["solid_step_error"] = {solid_step_error_.dt, solid_step_error_.relative, solid_step_error_.displacement_scale};
  Json times = Json::array();
  for (std::size_t i = 0; i < warm_start_.history().size(); ++i) {
    const GridSolution& solution = warm_start_.history()[i];
    times.push_back(solution.time);
    for (int b = 0; b < block_count; ++b) {
      archive.put(fmt::format("warm_start.{}.{}.value", i, b), solution.value[b]);
      archive.put(fmt::format("warm_start.{}.{}.active", i, b), solution.active[b]);
    }
  }
  record["warm_start_times"] = times;
  record["rejected_warm_starts"] = warm_start_.rejected_predictions();
  archive.put("contact.released_h_cells", contact_.released_h_cells());
  archive.put("contact.released_p_cells", contact_.released_p_cells());
  Json stages = Json::array();
  for (const auto& [stage, seconds] : timer_.stages()) stages.push_back({stage, seconds});
  record["stage_seconds"] = stages;
}

template <int dim>
void Simulation<dim>::restore_state(const StateArchive& archive) {
  using namespace state_detail;
  const Json& record = archive.record.at("simulation");
  if (record.at("dim").get<int>() != dim)
    throw InputError(fmt::format("the checkpoint is of a {}-D run, the scene is {}-D", record.at("dim").get<int>(), dim));
  fluid_ = load_particles<dim>(archive, "fluid", fluid_.size());
  solid_ = load_particles<dim>(archive, "solid", solid_.size());
  time_ = record.at("time").get<Real>();
  solid_step_error_ = SolidStepError{};  // older checkpoints: none measured
  if (record.contains("solid_step_error")) {
    const Json& error = record.at("solid_step_error");
    solid_step_error_.dt = error.at(0).get<Real>();
    if (error.at(1).is_number()) solid_step_error_.relative = error.at(1).get<Real>();  // NaN is written as null
    solid_step_error_.displacement_scale = error.at(2).get<std::vector<Real>>();
  }
  std::deque<GridSolution> history;
  const Json& times = record.at("warm_start_times");
  for (std::size_t i = 0; i < times.size(); ++i) {
    GridSolution solution;
    solution.time = times[i].get<double>();
    for (int b = 0; b < block_count; ++b) {
      solution.value[b] = archive.doubles(fmt::format("warm_start.{}.{}.value", i, b));
      solution.active[b] = archive.bytes(fmt::format("warm_start.{}.{}.active", i, b));
    }
    history.push_back(std::move(solution));
  }
  warm_start_.restore(std::move(history), record.at("rejected_warm_starts").get<long>());
  contact_.restore_released_cells(archive.bytes("contact.released_h_cells"), archive.bytes("contact.released_p_cells"));
  timer_ = StageTimer();
  for (const auto& stage : record.at("stage_seconds")) timer_.add(stage.at(0).get<std::string>(), stage.at(1).get<double>());
}

template <int dim>
void Simulation<dim>::keep_step_start() {
  step_start_.requested = true;
  step_start_.kept = false;
  step_start_.time = time_;
  step_start_.solid_step_error = solid_step_error_;
  step_start_.released_h_cells = contact_.released_h_cells();
  step_start_.released_p_cells = contact_.released_p_cells();
}

template <int dim>
void Simulation<dim>::return_to_step_start() {
  if (!step_start_.kept) throw std::logic_error("return_to_step_start: no step was taken after keep_step_start");
  std::swap(fluid_, step_start_.fluid);
  std::swap(solid_, step_start_.solid);
  step_start_.kept = false;
  time_ = step_start_.time;
  solid_step_error_ = step_start_.solid_step_error;
  contact_.restore_released_cells(step_start_.released_h_cells, step_start_.released_p_cells);
}

}  // namespace iqmpm
