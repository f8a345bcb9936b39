#pragma once
// CPU stage times of one frame (selection update, gesture solve, the worker's coarse solve...):
// added up per stage name while the frame is prepared, taken by the frame loop into its timing log
// (app/session/latency_log.h, columns cpu_<stage>_ms).
#include <chrono>
#include <string>
#include <utility>
#include <vector>

namespace handson {

class StageTimes {
 public:
  /// Adds `ms` to `stage` (a stage seen twice in a frame sums).
  void add(const std::string& stage, double ms) {
    for (auto& [name, v] : stages_)
      if (name == stage) {
        v += ms;
        return;
      }
    stages_.emplace_back(stage, ms);
  }
  /// The stages since the last take, in first-seen order; clears them.
  std::vector<std::pair<std::string, double>> take() { return std::exchange(stages_, {}); }

  /// Times the scope into `stage`.
  class Scope {
   public:
    Scope(StageTimes& times, const char* stage) : times_(times), stage_(stage), t0_(std::chrono::steady_clock::now()) {}
    ~Scope() { times_.add(stage_, std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0_).count()); }
    Scope(const Scope&) = delete;
    Scope& operator=(const Scope&) = delete;

   private:
    StageTimes& times_;
    const char* stage_;
    std::chrono::steady_clock::time_point t0_;
  };

 private:
  std::vector<std::pair<std::string, double>> stages_;
};

}  // namespace handson
