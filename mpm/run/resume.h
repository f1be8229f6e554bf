// `iqmpm resume OUT_DIR [--set key=value ...]` (docs/method.md#checkpoints): the scene a
// checkpoint continues, read from the checkpoint itself. Only keys that do not change what
// the saved particles mean may be set again: the end time, the time-step limits, the
// checkpoint schedule and the solvers' settings. With end_time alone changed, and the
// earlier end a frame time, the continued run is the uninterrupted one bit for bit.
#pragma once

#include <fmt/format.h>

#include <memory>
#include <string>
#include <vector>

#include "core/errors.h"
#include "io/state_archive.h"
#include "scene/json_reader.h"
#include "scene/scene.h"

namespace iqmpm {

inline bool may_change_on_resume(const std::string& key) {
  for (const char* exact : {"end_time", "cfl", "spray_cfl", "dt_min", "dt_max", "write_pressure_fields"})
    if (key == exact) return true;
  for (const char* section : {"checkpoint.", "solver.", "newton."})
    if (key.rfind(section, 0) == 0) return true;
  return false;
}

// The checkpoint of the run in `out_dir`; InputError if there is none or it is not one.
inline std::shared_ptr<const StateArchive> read_checkpoint(const std::string& out_dir) {
  auto archive = std::make_shared<StateArchive>(StateArchive::read(out_dir + "/checkpoint.h5"));
  if (archive->record.value("format", "") != "iqmpm checkpoint" || archive->record.value("format_version", 0) != 1 ||
      !archive->record.contains("scene") || !archive->record.contains("run"))
    throw InputError(fmt::format("'{}/checkpoint.h5' is not a checkpoint this version of iqmpm reads (format version 1)", out_dir));
  return archive;
}

// The checkpoint's scene with `overrides` applied and validated.
inline SceneSpec scene_to_resume(const StateArchive& checkpoint, const std::vector<std::string>& overrides) {
  Json document = checkpoint.record.at("scene");
  for (const auto& assignment : overrides) {
    const std::string key = assignment.substr(0, assignment.find('='));
    if (!may_change_on_resume(key))
      throw InputError(fmt::format("--set '{}': a resumed run continues the checkpoint's particles, so '{}' cannot change; "
                                   "accepted: end_time, cfl, spray_cfl, dt_min, dt_max, write_pressure_fields, checkpoint.*, "
                                   "solver.*, newton.*", assignment, key));
    apply_override(document, assignment);
  }
  return read_scene(document);
}

}  // namespace iqmpm
