// Per-step solver statistics accumulated over a run, for summary.json.
#pragma once

#include <algorithm>
#include <limits>
#include <string>

#include "scene/json_reader.h"
#include "simulation/simulation.h"

namespace iqmpm {

class RunStatistics {
 public:
  void add(const StepStats& s) {
    ++steps_;
    active_cells_max_ = std::max(active_cells_max_, s.pressure_unknowns);
    linear_.add(s.linear.iterations);
    wall_clamps_ += s.wall_clamps;
    shifted_solves_ += s.linear.shifted;
    newton_.add(s.newton_iterations);
    newton_cg_total_ += s.newton_cg_iterations;
    extended_nodes_.add(s.extended_solid_nodes);
    air_pockets_.add(s.air_pockets);
    air_pocket_steps_ += s.air_pockets > 0;
    largest_air_pocket_ = std::max(largest_air_pocket_, s.air_pocket_cells);
    solid_min_J_ = std::min(solid_min_J_, double(s.solid_min_J));
    contact_rounds_.add(s.contact_rounds);
    unsettled_steps_ += !s.contact_settled;
    modified_solves_ += s.modified_solves;
    linear_method_ = s.linear.method;
  }
  long steps() const { return steps_; }

  // All of it, for a checkpoint, and back.
  Json state() const {
    auto range = [](const Range& r) { return Json{r.total, r.min, r.max}; };
    return {{"steps", steps_}, {"active_cells_max", active_cells_max_}, {"linear", range(linear_)}, {"newton", range(newton_)},
            {"contact_rounds", range(contact_rounds_)}, {"newton_cg_total", newton_cg_total_}, {"wall_clamps", wall_clamps_},
            {"shifted_solves", shifted_solves_}, {"solid_min_J", solid_min_J_}, {"unsettled_steps", unsettled_steps_},
            {"modified_solves", modified_solves_}, {"linear_method", linear_method_},
            {"extended_solid_nodes", range(extended_nodes_)}, {"air_pockets", range(air_pockets_)},
            {"air_pocket_steps", air_pocket_steps_}, {"largest_air_pocket", largest_air_pocket_}};
  }
  void restore(const Json& state) {
    auto range = [](const Json& j) { return Range{j.at(0).get<long>(), j.at(1).get<int>(), j.at(2).get<int>()}; };
    steps_ = state.at("steps").get<long>();
    active_cells_max_ = state.at("active_cells_max").get<int>();
    linear_ = range(state.at("linear"));
    newton_ = range(state.at("newton"));
    contact_rounds_ = range(state.at("contact_rounds"));
    newton_cg_total_ = state.at("newton_cg_total").get<long>();
    wall_clamps_ = state.at("wall_clamps").get<int>();
    shifted_solves_ = state.at("shifted_solves").get<long>();
    solid_min_J_ = state.at("solid_min_J").get<double>();
    unsettled_steps_ = state.at("unsettled_steps").get<int>();
    modified_solves_ = state.at("modified_solves").get<long>();
    linear_method_ = state.at("linear_method").get<std::string>();
    // A checkpoint written before solid_weak_nodes existed has no count: none were extended.
    extended_nodes_ = state.contains("extended_solid_nodes") ? range(state.at("extended_solid_nodes")) : Range{};
    // Nor one written before experimental.trapped_air: no pockets.
    air_pockets_ = state.contains("air_pockets") ? range(state.at("air_pockets")) : Range{};
    air_pocket_steps_ = state.value("air_pocket_steps", 0L);
    largest_air_pocket_ = state.value("largest_air_pocket", 0);
  }

  // The statistics' fields of summary.json.
  void write(Json& summary, bool has_solids) const {
    const bool any = steps_ > 0;
    summary["active_cells_max"] = active_cells_max_;
    summary["linear_solver"] = linear_method_;
    summary["linear_iterations"] = {{"min", any ? linear_.min : 0}, {"mean", linear_.mean(steps_)}, {"max", linear_.max}};
    summary["newton_iterations"] = {{"min", any && has_solids ? newton_.min : 0},
                                    {"mean", newton_.mean(steps_)},
                                    {"max", newton_.max},
                                    {"cg_per_step", any ? double(newton_cg_total_) / steps_ : 0.0}};
    summary["solid_min_J"] = solid_min_J_;
    // Weak solid nodes given by extrapolation per step (solid_weak_nodes = extended).
    summary["extended_solid_nodes"] = {{"mean", extended_nodes_.mean(steps_)}, {"max", extended_nodes_.max}};
    // Pressure solves per step: above 1 with the unilateral interface (active-set rounds);
    // factor_modified: solves done by modifying the LDL^T factor's changed rows.
    summary["pressure_solves"] = {{"mean", contact_rounds_.mean(steps_)},
                                  {"max", contact_rounds_.max},
                                  {"unsettled_steps", unsettled_steps_},
                                  {"factor_modified", modified_solves_}};
    // Pockets of trapped air held per step (experimental.trapped_air = incompressible), the steps
    // with any, and the largest pocket's dual cells.
    summary["trapped_air"] = {{"pockets_mean", air_pockets_.mean(steps_)}, {"pockets_max", air_pockets_.max},
                              {"steps", air_pocket_steps_}, {"largest_pocket_cells", largest_air_pocket_}};
    summary["wall_clamps"] = wall_clamps_;
    summary["shifted_solves"] = shifted_solves_;  // direct solves retried with a tiny diagonal shift
  }

 private:
  struct Range {
    long total = 0;
    int min = std::numeric_limits<int>::max(), max = 0;
    void add(int v) {
      total += v;
      min = std::min(min, v);
      max = std::max(max, v);
    }
    double mean(long steps) const { return steps ? double(total) / steps : 0.0; }
  };
  long steps_ = 0;
  int active_cells_max_ = 0;
  Range linear_, newton_, contact_rounds_, extended_nodes_, air_pockets_;
  long air_pocket_steps_ = 0;
  int largest_air_pocket_ = 0;
  long newton_cg_total_ = 0;
  int wall_clamps_ = 0;
  long shifted_solves_ = 0;
  double solid_min_J_ = 1;
  int unsettled_steps_ = 0;
  long modified_solves_ = 0;
  std::string linear_method_;
};

}  // namespace iqmpm
