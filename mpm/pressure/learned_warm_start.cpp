#include "pressure/learned_warm_start.h"

#include <dlfcn.h>
#include <fmt/format.h>

#include <cstdlib>
#include <filesystem>

#include "core/errors.h"

namespace iqmpm {
namespace {

// The plugin built beside the solver (mpm/CMakeLists.txt), or IQMPM_MPMNET_PLUGIN's.
std::string plugin_path() {
  if (const char* path = std::getenv("IQMPM_MPMNET_PLUGIN")) return path;
#ifdef IQMPM_MPMNET_PLUGIN_PATH
  return IQMPM_MPMNET_PLUGIN_PATH;
#else
  return "";
#endif
}

}  // namespace

bool learned_warm_start_available() {
  const std::string path = plugin_path();
  return !path.empty() && std::filesystem::is_regular_file(path);
}

std::unique_ptr<LearnedPredictor> LearnedPredictor::load(const std::string& path, int dim, const std::vector<int>& cells) {
  if (!learned_warm_start_available())
    throw InputError(
        "scene key 'solver.warm_start' = \"learned\": this iqmpm was built without libtorch; accepted here: none, previous, "
        "extrapolate, projection (install libtorch-dev and rebuild: bash .ci/setup.sh)");
  // Loaded once and never closed: predictors made by it live until the process ends.
  static void* plugin = dlopen(plugin_path().c_str(), RTLD_NOW | RTLD_LOCAL);
  if (!plugin) throw InputError(fmt::format("scene key 'solver.warm_start' = \"learned\": cannot load the MPMNet plugin: {}", dlerror()));
  using Loader = LearnedPredictor* (*)(const std::string&, int, const std::vector<int>&);
  const auto loader = reinterpret_cast<Loader>(dlsym(plugin, "iqmpm_load_learned_predictor"));
  if (!loader) throw InputError(fmt::format("the MPMNet plugin '{}' has no entry point", plugin_path()));
  return std::unique_ptr<LearnedPredictor>(loader(path, dim, cells));
}

}  // namespace iqmpm
