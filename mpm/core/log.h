// The library's own logger ("iqmpm"). The library never prints directly; the CLI
// decides where log lines go and tests keep it quiet.
#pragma once

#include <spdlog/spdlog.h>

namespace iqmpm {

inline std::shared_ptr<spdlog::logger> logger() {
  static std::shared_ptr<spdlog::logger> instance = [] {
    auto existing = spdlog::get("iqmpm");
    if (existing) return existing;
    auto created = spdlog::default_logger()->clone("iqmpm");
    created->set_level(spdlog::level::warn);
    spdlog::register_logger(created);
    return created;
  }();
  return instance;
}

}  // namespace iqmpm
