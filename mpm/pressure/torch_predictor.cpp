// The learned warm start's TorchScript side (pressure/learned_warm_start.h), built as a
// plugin that the solver loads only when a scene asks for it: libtorch costs about a
// second of start-up and some 240 shared libraries, which no other run should pay.
#include <ATen/Parallel.h>
#include <fmt/format.h>
#include <fmt/ranges.h>
#include <omp.h>
#include <torch/script.h>

#include <filesystem>

#include "core/errors.h"
#include "pressure/learned_warm_start.h"
#include "scene/json_reader.h"

namespace iqmpm {

namespace {

constexpr const char* field_names[] = {"fluid_pressure", "ghost_pressure", "interface"};

class TorchPredictor final : public LearnedPredictor {
 public:
  TorchPredictor(torch::jit::script::Module module, int sequence_length, std::vector<int> cells)
      : module_(std::move(module)), sequence_length_(sequence_length), cells_(std::move(cells)) {
    for (int n : cells_) cell_count_ *= n;
  }
  int sequence_length() const override { return sequence_length_; }

  GridSolution predict(const std::deque<GridSolution>& history, const UnknownLocations& where) const override {
    const int T = sequence_length_, C = int(fields.size());
    const auto frame_shape = tensor_shape({C});
    torch::Tensor values = torch::zeros(tensor_shape({T, C}), torch::kFloat32);
    torch::Tensor active = torch::zeros(tensor_shape({T, C}), torch::kFloat32);
    torch::Tensor next_active = torch::zeros(frame_shape, torch::kFloat32);
    float* v = values.data_ptr<float>();
    float* a = active.data_ptr<float>();
    for (int t = 0; t < T; ++t) {
      // The last T solutions; the oldest stands in for steps before the first.
      const int back = std::min<int>(T - 1 - t, int(history.size()) - 1);
      const GridSolution& solution = history[history.size() - 1 - std::size_t(back)];
      for (int c = 0; c < C; ++c) {
        const std::vector<Real>& field = solution.value[fields[c]];
        const std::vector<std::uint8_t>& mask = solution.active[fields[c]];
        if (field.size() != std::size_t(cell_count_)) continue;
        const std::size_t base = (std::size_t(t) * C + c) * cell_count_;
        for (int k = 0; k < cell_count_; ++k) {
          v[base + k] = mpmnet_value(field[k]);
          a[base + k] = mask[k];
        }
      }
    }
    float* n = next_active.data_ptr<float>();
    for (int c = 0; c < C; ++c)
      if (where.offset[fields[c]] >= 0)
        for (int l : where.location[fields[c]]) n[std::size_t(c) * cell_count_ + l] = 1;

    torch::NoGradGuard no_grad;
    const torch::Tensor out = const_cast<torch::jit::script::Module&>(module_)
                                  .forward({values, active, next_active})
                                  .toTensor()
                                  .to(torch::kFloat32)
                                  .contiguous();
    if (out.sizes() != torch::IntArrayRef(frame_shape))
      throw std::runtime_error(fmt::format("the model returned a tensor of shape [{}], expected [{}]",
                                           fmt::join(out.sizes(), ", "), fmt::join(frame_shape, ", ")));
    const float* p = out.data_ptr<float>();
    GridSolution prediction;
    for (int c = 0; c < C; ++c) {
      prediction.value[fields[c]].assign(p + std::size_t(c) * cell_count_, p + std::size_t(c + 1) * cell_count_);
      prediction.active[fields[c]].assign(n + std::size_t(c) * cell_count_, n + std::size_t(c + 1) * cell_count_);
    }
    return prediction;
  }

  std::vector<int64_t> tensor_shape(std::vector<int64_t> leading) const {
    for (int n : cells_) leading.push_back(n);
    return leading;
  }

 private:
  torch::jit::script::Module module_;
  int sequence_length_;
  std::vector<int> cells_;
  int cell_count_ = 1;
};

}  // namespace

std::unique_ptr<LearnedPredictor> load_torch_predictor(const std::string& path, int dim, const std::vector<int>& cells) {
  const auto refuse = [&](const std::string& why) {
    return InputError(fmt::format("scene key 'solver.model' = \"{}\": {} (an MPMNet TorchScript file, mpmnet/README.md)", path, why));
  };
  if (path.empty()) throw InputError("scene key 'solver.model': required with solver.warm_start = \"learned\" (an MPMNet TorchScript file, mpmnet/README.md)");
  if (!std::filesystem::is_regular_file(path)) throw refuse("no such file");
  at::set_num_threads(std::max(1, omp_get_max_threads()));
  torch::jit::ExtraFilesMap extra{{"mpmnet.json", ""}};
  torch::jit::script::Module module;
  try {
    module = torch::jit::load(path, torch::kCPU, extra);
  } catch (const std::exception& error) {
    const std::string what = error.what();
    throw refuse("not a TorchScript model: " + what.substr(0, what.find('\n')));
  }
  module.eval();
  Json meta;
  try {
    meta = Json::parse(extra["mpmnet.json"]);
  } catch (const std::exception&) {
    throw refuse("it carries no readable mpmnet.json");
  }
  if (meta.value("format", "") != "iqmpm-mpmnet" || meta.value("format_version", 0) != 1)
    throw refuse("mpmnet.json is not format iqmpm-mpmnet version 1");
  const int model_dim = meta.value("dim", 0);
  if (model_dim != dim) throw refuse(fmt::format("the model is for {}-D scenes, this scene is {}-D", model_dim, dim));
  const std::vector<std::string> expected(std::begin(field_names), std::end(field_names));
  const auto model_fields = meta.value("fields", std::vector<std::string>{});
  if (model_fields != expected)
    throw refuse(fmt::format("the model's fields are [{}], accepted: [{}]", fmt::join(model_fields, ", "), fmt::join(expected, ", ")));
  const int T = meta.value("sequence_length", 0);
  if (T < 1) throw refuse("mpmnet.json has no sequence_length >= 1");
  auto predictor = std::make_unique<TorchPredictor>(std::move(module), T, cells);
  // One dry prediction on this grid: a model that cannot read it fails now, not mid-run.
  try {
    UnknownLocations none;
    GridSolution zero;
    int count = 1;
    for (int n : cells) count *= n;
    for (SolutionBlock b : LearnedPredictor::fields) {
      zero.value[b].assign(count, 0);
      zero.active[b].assign(count, 0);
    }
    const GridSolution out = predictor->predict({zero}, none);
    for (SolutionBlock b : LearnedPredictor::fields)
      if (out.value[b].size() != std::size_t(count)) throw refuse("its output does not have the grid's shape");
  } catch (const InputError&) {
    throw;
  } catch (const std::exception& error) {
    const std::string what = error.what();
    throw refuse("it cannot predict on this grid: " + what.substr(0, what.find('\n')));
  }
  return predictor;
}

}  // namespace iqmpm

// The plugin's entry point (a C name that dlsym finds); throws InputError.
extern "C" iqmpm::LearnedPredictor* iqmpm_load_learned_predictor(const std::string& path, int dim, const std::vector<int>& cells) {
  return iqmpm::load_torch_predictor(path, dim, cells).release();
}
