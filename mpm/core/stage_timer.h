// Accumulates wall-clock seconds per named stage of the time step, in first-use order.
#pragma once

#include <chrono>
#include <string>
#include <utility>
#include <vector>

namespace iqmpm {

class StageTimer {
 public:
  class Scope {
   public:
    Scope(StageTimer& timer, const char* stage)
        : timer_(timer), stage_(stage), start_(std::chrono::steady_clock::now()) {}
    ~Scope() {
      timer_.add(stage_, std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count());
    }
    Scope(const Scope&) = delete;
    Scope& operator=(const Scope&) = delete;

   private:
    StageTimer& timer_;
    const char* stage_;
    std::chrono::steady_clock::time_point start_;
  };

  Scope scope(const char* stage) { return Scope(*this, stage); }

  void add(const std::string& stage, double seconds) {
    for (auto& entry : stages_)
      if (entry.first == stage) {
        entry.second += seconds;
        return;
      }
    stages_.emplace_back(stage, seconds);
  }

  const std::vector<std::pair<std::string, double>>& stages() const { return stages_; }

  // Seconds of one stage so far (0 if it never ran).
  double seconds(const std::string& stage) const {
    for (const auto& entry : stages_)
      if (entry.first == stage) return entry.second;
    return 0;
  }

  double total() const {
    double sum = 0;
    for (const auto& entry : stages_) sum += entry.second;
    return sum;
  }

 private:
  std::vector<std::pair<std::string, double>> stages_;
};

}  // namespace iqmpm
