// The automatic window (render/auto_window.h): the soft-tissue peak of the clipped region against
// the distribution the volume was drawn from, and the window that puts a preset's reference there.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>

#include "render/auto_window.h"

using namespace handson;

namespace {

// 64^3 voxels of 2 mm: fat N(-100, 10) in half the voxels, soft tissue N(40, 10) in 35 %, bone
// (800) in 15 %; where x >= 48 (the last quarter of the grid) the soft tissue is enhanced,
// N(130, 10), as a contrast CT's organs.
Volume mixture() {
  VolumeGeometry g;
  g.dims = {64, 64, 64};
  g.spacing = {2, 2, 2};
  g.origin = {-63, -63, -63};
  Volume v(g, ScalarType::Int16);
  std::mt19937 rng(7);
  std::normal_distribution<double> noise(0.0, 10.0);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  for (int k = 0; k < 64; ++k)
    for (int j = 0; j < 64; ++j)
      for (int i = 0; i < 64; ++i) {
        const double r = u(rng), n = noise(rng);
        const double soft = i >= 48 ? 130.0 : 40.0;
        v.setValue(v.linearIndex(i, j, k), float(std::lround(r < 0.5 ? -100.0 + n : r < 0.85 ? soft + n : 800.0)));
      }
  return v;
}

}  // namespace

TEST(AutoWindow, TheSoftTissuePeakIsTheDistributionsWithTheSmoothingsWidth) {
  // The peak within a bin (2 HU) of the drawn mean; the half width at half maximum that of the
  // drawn Gaussian widened by the 5 HU smoothing, sqrt(10^2 + 5^2) * 1.1774 = 13.2 HU, within a bin.
  const Volume v = mixture();
  const auto whole = softTissuePeak(v, ClipRegion{});
  ASSERT_TRUE(whole.has_value());
  EXPECT_NEAR(whole->value, 40.0, 2.0);
  EXPECT_NEAR(whole->halfWidth, std::sqrt(125.0) * 1.1774, 2.0);
  // A clip box over the enhanced quarter: its own peak. A plane keeping x >= 35 mm: the same voxels.
  ClipRegion box;
  box.box = true;
  box.lo = {34, -70, -70};
  box.hi = {70, 70, 70};
  const auto enhanced = softTissuePeak(v, box);
  ASSERT_TRUE(enhanced.has_value());
  EXPECT_NEAR(enhanced->value, 130.0, 2.0);
  EXPECT_LT(enhanced->samples, whole->samples / 3);
  ClipRegion plane;
  plane.plane = true;
  plane.normal = {1, 0, 0};
  plane.offset = 34.0f;
  const auto cut = softTissuePeak(v, plane);
  ASSERT_TRUE(cut.has_value());
  EXPECT_EQ(cut->value, enhanced->value);
  EXPECT_EQ(cut->samples, enhanced->samples);
}

TEST(AutoWindow, ARegionWithoutSoftTissueHasNoPeak) {
  VolumeGeometry g;
  g.dims = {32, 32, 32};
  Volume air(g, ScalarType::Int16);
  for (std::size_t i = 0; i < air.voxelCount(); ++i) air.setValue(i, i % 2 ? -1000.0f : 1200.0f);
  EXPECT_FALSE(softTissuePeak(air, ClipRegion{}).has_value());
  // A clip box outside the volume leaves nothing.
  const Volume v = mixture();
  ClipRegion away;
  away.box = true;
  away.lo = {500, 500, 500};
  away.hi = {600, 600, 600};
  EXPECT_FALSE(softTissuePeak(v, away).has_value());
}

TEST(AutoWindow, ThePresetsReferencePeakLandsOnTheRegionsPeak) {
  // v' = v + shift maps the preset's tissuePeak onto the region's peak exactly.
  for (const char* name : {"ct-abdomen", "ct-soft-tissue"}) {
    const TransferFunction tf = transferFunctionPreset(name);
    for (const TissuePeak peak : {TissuePeak{35.0, 14.0, 1000}, TissuePeak{120.0, 30.0, 1000}, TissuePeak{60.0, 200.0, 1000}}) {
      const auto shift = autoWindowShift(tf, peak);
      ASSERT_TRUE(shift.has_value()) << name;
      EXPECT_NEAR(tf.tissuePeak + *shift, peak.value, 1e-4) << name;
      // The windowed preset: its opacity at the region's peak is its own at the reference.
      const TransferFunction moved = tf.windowed(1.0, *shift, 1.0);
      EXPECT_NEAR(moved.evaluate(float(peak.value)).a, tf.evaluate(tf.tissuePeak).a, 1e-4f) << name;
    }
  }
  // No reference: the MRI preset (relative), the bone preset, a function from a file.
  EXPECT_FALSE(autoWindowShift(transferFunctionPreset("mri"), TissuePeak{40.0, 10.0, 1000}).has_value());
  EXPECT_FALSE(autoWindowShift(transferFunctionPreset("ct-bone"), TissuePeak{40.0, 10.0, 1000}).has_value());
  EXPECT_FALSE(autoWindowShift(thresholdTransferFunction(100.0f), TissuePeak{40.0, 10.0, 1000}).has_value());
}
