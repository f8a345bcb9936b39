#pragma once
// The per-frame timing log for latency studies: the input events a frame consumed, CPU frame start
// and end, each GPU pass's time, submit and present times, when the frame was shown on screen
// where the driver can say (VK_KHR_present_wait), and input-to-present and input-to-display
// latency. Times are seconds on one steady clock; durations in milliseconds. CSV: first "# " lines
// that say where the times come from (notes), then the column names; summary() gives median, p95
// and p99.
#include <cstddef>
#include <cstdint>
#include <deque>
#include <string>
#include <vector>

#include "sim/handle_reaction.h"

namespace handson {

struct FrameTiming {
  std::uint64_t frame = 0;
  int inputCount = 0;
  double inputFirst = -1.0, inputLast = -1.0;  ///< clock times of the consumed input events (-1: none)
  double cpuStart = 0.0, cpuEnd = 0.0;         ///< frame loop start and end of recording
  double submit = 0.0, present = 0.0;          ///< queue submit and present (or readback) times
  double displayed = -1.0;                     ///< when the frame was shown on screen (-1: not known)
  double waitMs = 0.0;                         ///< time the CPU spent blocked (fences, acquire, vsync)
  std::vector<std::pair<std::string, double>> gpuMs;  ///< per pass
  std::vector<std::pair<std::string, double>> cpuMs;  ///< per CPU stage (app/session/stage_times.h)
  std::string simState;     ///< the simulation state the frame shows (DeformationController::modelState)
  double simStateS = -1.0;  ///< how long after its pose that state landed (s; -1: none)
  /// The shown state's reaction on each simulated handle, by the app's handle id (N, N mm; RAS).
  std::vector<std::pair<int, HandleReaction>> reactions;
  /// The frame budget's quality (app/session/frame_budget.h): raymarch resolution and step scale.
  double qualityScale = 1.0, qualityStep = 1.0;
  /// Jitter phases in the still frame shown (FrameDriver::stillPhases; 0: not a still frame's sum).
  int stillPhases = 0;

  double frameMs() const { return (present - cpuStart) * 1e3; }
  /// Input-to-present latency (ms) from the oldest consumed event; negative without input.
  double latencyMs() const { return inputFirst < 0.0 ? -1.0 : (present - inputFirst) * 1e3; }
  /// Input-to-submit latency (ms): until the frame's work was queued; negative without input.
  double submitLatencyMs() const { return inputFirst < 0.0 ? -1.0 : (submit - inputFirst) * 1e3; }
  /// Input-to-display latency (ms); negative without input or without a display time.
  double displayLatencyMs() const { return inputFirst < 0.0 || displayed < 0.0 ? -1.0 : (displayed - inputFirst) * 1e3; }
};

class LatencyLog {
 public:
  /// `keepLast` > 0 keeps only the newest frames (a long session without a timing log to write:
  /// summary() then describes them, and memory stays bounded); 0 keeps every frame.
  explicit LatencyLog(std::size_t keepLast = 0) : keepLast_(keepLast) {}
  void add(FrameTiming t) {
    frames_.push_back(std::move(t));
    if (keepLast_ > 0 && frames_.size() > keepLast_) frames_.pop_front();
  }
  /// GPU times arrive a frame or two later (non-blocking readback): attach them afterwards.
  void setGpuTimes(std::uint64_t frame, const std::vector<std::pair<std::string, double>>& passes);
  /// Display times arrive later still (render/present_timer.h). Returns the frame's
  /// input-to-display latency (ms; negative without input or for a frame no longer kept).
  double setDisplayed(std::uint64_t frame, double t);
  /// Lines for the CSV's header: where the input, present and display times come from.
  void setNotes(std::vector<std::string> notes) { notes_ = std::move(notes); }
  const std::deque<FrameTiming>& frames() const { return frames_; }

  void writeCsv(const std::string& path) const;
  /// Median, p95, p99 of frame time and input-to-present latency, and the share of the frame spent
  /// waiting rather than working.
  std::string summary() const;

 private:
  std::deque<FrameTiming> frames_;
  std::size_t keepLast_ = 0;
  std::vector<std::string> notes_;
};

/// Frames a session keeps for its summary when no timing log is written.
constexpr std::size_t kSummaryFrames = 4096;

/// Percentile (0..1) by nearest rank of a copy of v; 0 for an empty v.
double percentile(std::vector<double> v, double p);

}  // namespace handson
