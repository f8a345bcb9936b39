#include "app/session/frame_budget.h"

#include <algorithm>
#include <cmath>

#include "sim/base/error.h"

namespace handson {

namespace {
// Best first, each about 0.35-0.75x the cost of the one before: resolution first (upsampled, it
// blurs), then the step (longer steps band on surfaces), down to 1/256 of the full raymarch (a
// volume filling a large window on a CPU device needs the last levels).
constexpr FrameQuality kLevelTable[FrameBudget::kLevels] = {
    {1.0, 1.0}, {0.85, 1.0}, {0.7, 1.0}, {0.7, 1.5}, {0.5, 1.5}, {0.5, 2.0}, {0.35, 2.0}, {0.25, 2.0}, {0.25, 3.0}, {0.18, 3.0}, {0.125, 4.0},
};
// Each measured frame's weight in the running averages when a cost falls; a rising cost is taken
// at once (the measurements arrive a frame or two late, and a zoom that makes every ray cross the
// volume raises the cost from frame to frame: a frame over the budget is what the budget is for).
constexpr double kWeight = 0.5;

// The running average of a cost: rises at once, falls by kWeight of the difference.
void follow(double& average, double measured) { average = measured > average ? measured : average + kWeight * (measured - average); }
}  // namespace

std::vector<std::uint8_t> upscaleRgba(const std::vector<std::uint8_t>& rgba, int w, int h, int W, int H) {
  if (w <= 0 || h <= 0 || W <= 0 || H <= 0 || rgba.size() != std::size_t(w) * std::size_t(h) * 4)
    throw Error("upscale: the image's size does not match its pixels");
  std::vector<std::uint8_t> out(std::size_t(W) * std::size_t(H) * 4);
  for (int Y = 0; Y < H; ++Y) {
    const double y = std::clamp((Y + 0.5) * h / H - 0.5, 0.0, double(h - 1));
    const int y0 = int(y), y1 = std::min(y0 + 1, h - 1);
    const double fy = y - y0;
    for (int X = 0; X < W; ++X) {
      const double x = std::clamp((X + 0.5) * w / W - 0.5, 0.0, double(w - 1));
      const int x0 = int(x), x1 = std::min(x0 + 1, w - 1);
      const double fx = x - x0;
      for (int c = 0; c < 4; ++c) {
        auto at = [&](int i, int j) { return double(rgba[(std::size_t(j) * w + i) * 4 + c]); };
        const double v = (1 - fy) * ((1 - fx) * at(x0, y0) + fx * at(x1, y0)) + fy * ((1 - fx) * at(x0, y1) + fx * at(x1, y1));
        out[(std::size_t(Y) * W + X) * 4 + c] = std::uint8_t(std::lround(v));
      }
    }
  }
  return out;
}

FrameQuality FrameBudget::level(std::size_t i) { return kLevelTable[i < kLevels ? i : kLevels - 1]; }

FrameBudget::FrameBudget(double budgetMs) : budgetMs_(budgetMs) {
  if (!(budgetMs >= 0.0) || !std::isfinite(budgetMs)) throw Error("frame budget: the budget must be a finite number of milliseconds >= 0 (0: off)");
}

double FrameBudget::predictedMs(std::size_t i) const {
  if (rayFullMs_ < 0.0) return -1.0;
  return otherMs_ + rayFullMs_ * level(i).relativeCost();
}

FrameQuality FrameBudget::next(bool changing) {
  if (!enabled()) return level(level_ = 0);
  if (!changing) {
    if (level_ > 0) --level_;
    return level(level_);
  }
  if (rayFullMs_ < 0.0) return level(level_ = kLevels - 1);  // nothing measured yet: the safe guess
  std::size_t i = 0;
  while (i + 1 < kLevels && predictedMs(i) > budgetMs_) ++i;
  level_ = i;
  return level(level_);
}

void FrameBudget::measured(const FrameQuality& q, double raymarchMs, double otherMs) {
  if (!(raymarchMs >= 0.0) || !(otherMs >= 0.0) || !std::isfinite(raymarchMs) || !std::isfinite(otherMs)) return;
  const double full = raymarchMs / q.relativeCost();
  if (!std::isfinite(full)) return;
  if (rayFullMs_ < 0.0) {
    rayFullMs_ = full;
    otherMs_ = otherMs;
  } else {
    follow(rayFullMs_, full);
    follow(otherMs_, otherMs);
  }
}

}  // namespace handson
