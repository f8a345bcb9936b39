#pragma once
// The frame-time budget (docs/frame.md, "Frame budget"): while the picture changes (fingers, the
// camera, a handle, the clip or the transfer function), the raymarch's resolution and sample step
// are chosen so that the frame's predicted GPU time fits the budget; when it stops changing the
// frames refine one level at a time back to the full-quality frame, which is then exactly the
// frame drawn without a budget (the same parameters). Picking is never degraded: it does not use
// the raymarch's resolution, and the step it takes is the full one (RenderParams.stepMm; the
// raymarch alone scales it, RenderParams.stepScale).
//
// The prediction: a frame's GPU time = the other passes' time (deformation, growth: what the
// budget cannot scale) + the raymarch at full quality x the level's relative cost, scale² / step
// scale (pixels x samples per ray). Both follow the measured frames, the raymarch's time divided
// by the relative cost it was drawn at: a rising cost at once, a falling one by half the
// difference each frame.
#include <cstddef>
#include <cstdint>
#include <vector>

namespace handson {

struct FrameQuality {
  double scale = 1.0;      ///< raymarch resolution relative to the full-quality frame's (<= 1)
  double stepScale = 1.0;  ///< raymarch sample step relative to the full-quality step (>= 1)
  bool full() const { return scale == 1.0 && stepScale == 1.0; }
  /// The raymarch's cost relative to full quality (pixels x samples).
  double relativeCost() const { return scale * scale / stepScale; }
};

/// An RGBA8 frame drawn at w x h shown at W x H, as the window's linear blit shows it: bilinear
/// between pixel centres, clamped at the edges (replay writes reduced frames at full size with it).
std::vector<std::uint8_t> upscaleRgba(const std::vector<std::uint8_t>& rgba, int w, int h, int W, int H);

class FrameBudget {
 public:
  /// The quality levels, best first; level 0 is full quality.
  static constexpr std::size_t kLevels = 11;
  static FrameQuality level(std::size_t i);

  /// budgetMs: the GPU time a changing frame may take; 0 turns the budget off (every frame full
  /// quality). Negative or non-finite: handson::Error.
  explicit FrameBudget(double budgetMs);
  bool enabled() const { return budgetMs_ > 0.0; }
  double budgetMs() const { return budgetMs_; }

  /// The next frame's quality. `changing`: its picture differs from the last frame's (input, camera,
  /// handles, clip, transfer function, a new simulation state). Changing: the best level predicted
  /// to fit the budget (the cheapest when none does, or before any frame was measured: the first
  /// frames' times arrive a frame or two late, and a full-quality guess may take seconds).
  /// Not changing: one level better than the last frame's, until full quality.
  FrameQuality next(bool changing);
  /// The level of the quality next() last returned (0: full).
  std::size_t currentLevel() const { return level_; }

  /// A finished frame's GPU times: the raymarch, drawn at quality q, and every other pass.
  /// Non-finite or negative times are ignored.
  void measured(const FrameQuality& q, double raymarchMs, double otherMs);
  /// The predicted GPU time of a frame at level i (negative before any measurement).
  double predictedMs(std::size_t i) const;

 private:
  double budgetMs_ = 0.0;
  std::size_t level_ = 0;
  double rayFullMs_ = -1.0, otherMs_ = 0.0;
};

}  // namespace handson
