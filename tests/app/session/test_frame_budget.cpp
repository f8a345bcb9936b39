// The frame budget's decisions from given pass times, with no GPU (app/session/frame_budget.h):
// off means full quality always; a changing picture takes the best level predicted to fit; a still
// one refines a level a frame back to full quality; the levels get cheaper monotonically.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "app/session/frame_budget.h"
#include "sim/base/error.h"

using namespace handson;

TEST(FrameBudget, TheLevelsStartAtFullQualityAndGetCheaper) {
  EXPECT_TRUE(FrameBudget::level(0).full());
  for (std::size_t i = 1; i < FrameBudget::kLevels; ++i) {
    const FrameQuality a = FrameBudget::level(i - 1), b = FrameBudget::level(i);
    EXPECT_FALSE(b.full());
    EXPECT_LT(b.relativeCost(), a.relativeCost()) << i;
    EXPECT_LE(b.scale, a.scale);
    EXPECT_GE(b.stepScale, a.stepScale);
    EXPECT_GT(b.scale, 0.0);
  }
}

TEST(FrameBudget, OffDrawsEveryFrameAtFullQuality) {
  FrameBudget b(0.0);
  EXPECT_FALSE(b.enabled());
  b.measured(FrameQuality{}, 2000.0, 500.0);
  for (int i = 0; i < 5; ++i) EXPECT_TRUE(b.next(true).full());
  EXPECT_THROW(FrameBudget(-1.0), Error);
  EXPECT_THROW(FrameBudget{std::numeric_limits<double>::quiet_NaN()}, Error);
  EXPECT_THROW(FrameBudget{std::numeric_limits<double>::infinity()}, Error);
}

TEST(FrameBudget, AChangingPictureTakesTheBestLevelThatFits) {
  FrameBudget b(100.0);
  // Nothing measured yet: the cheapest level (the safe guess); still frames refine from there.
  b.next(true);
  EXPECT_EQ(b.currentLevel(), FrameBudget::kLevels - 1);
  b.next(false);
  EXPECT_EQ(b.currentLevel(), FrameBudget::kLevels - 2);
  // A full-quality raymarch of 1600 ms and 20 ms of other passes: the level must cost <= 80/1600.
  b.measured(FrameQuality{}, 1600.0, 20.0);
  const FrameQuality q = b.next(true);
  const std::size_t i = b.currentLevel();
  EXPECT_LE(20.0 + 1600.0 * q.relativeCost(), 100.0);
  ASSERT_GT(i, 0u);
  EXPECT_GT(20.0 + 1600.0 * FrameBudget::level(i - 1).relativeCost(), 100.0) << "the best level that fits, not a cheaper one";
  EXPECT_NEAR(b.predictedMs(i), 20.0 + 1600.0 * q.relativeCost(), 1e-9);
  // The raymarch measured at that level, at the cost the model predicts: the same choice.
  b.measured(q, 1600.0 * q.relativeCost(), 20.0);
  b.next(true);
  EXPECT_EQ(b.currentLevel(), i);
  // A budget nothing fits (the other passes alone take longer): the cheapest level.
  FrameBudget tight(10.0);
  tight.measured(FrameQuality{}, 1600.0, 50.0);
  tight.next(true);
  EXPECT_EQ(tight.currentLevel(), FrameBudget::kLevels - 1);
  // A cheap scene fits at full quality.
  FrameBudget roomy(100.0);
  roomy.measured(FrameQuality{}, 30.0, 5.0);
  EXPECT_TRUE(roomy.next(true).full());
}

TEST(FrameBudget, AStillPictureRefinesALevelAFrameToFullQuality) {
  FrameBudget b(50.0);
  b.measured(FrameQuality{}, 5000.0, 0.0);
  b.next(true);
  const std::size_t moving = b.currentLevel();
  ASSERT_EQ(moving, FrameBudget::kLevels - 1);
  for (std::size_t k = 1; k <= moving; ++k) {
    const FrameQuality q = b.next(false);
    EXPECT_EQ(b.currentLevel(), moving - k);
    EXPECT_EQ(q.full(), k == moving);
  }
  EXPECT_TRUE(b.next(false).full());  // and stays there
  // Motion again drops back at once.
  b.next(true);
  EXPECT_EQ(b.currentLevel(), moving);
}

TEST(FrameBudget, TheAveragesFollowRecentFramesAndIgnoreBadTimes) {
  FrameBudget b(100.0);
  b.measured(FrameQuality{}, 400.0, 0.0);
  EXPECT_NEAR(b.predictedMs(0), 400.0, 1e-9);
  // A falling cost moves half way to each new frame's (the raymarch's time taken back to full
  // quality); a rising one is taken at once (the other passes: 0 -> 10 ms).
  b.measured(FrameBudget::level(4), 200.0 * FrameBudget::level(4).relativeCost(), 10.0);
  EXPECT_NEAR(b.predictedMs(0), 0.5 * 400.0 + 0.5 * 200.0 + 10.0, 1e-9);
  b.measured(FrameBudget::level(2), 900.0 * FrameBudget::level(2).relativeCost(), 0.0);
  EXPECT_NEAR(b.predictedMs(0), 900.0 + 5.0, 1e-9) << "a zoom made every ray longer: the next frame knows at once";
  const double before = b.predictedMs(0);
  b.measured(FrameQuality{}, std::numeric_limits<double>::quiet_NaN(), 1.0);
  b.measured(FrameQuality{}, -3.0, 1.0);
  b.measured(FrameQuality{}, 1.0, std::numeric_limits<double>::infinity());
  EXPECT_EQ(b.predictedMs(0), before);
}

// The replay's upscale of a reduced frame: the same size is the identity, a constant stays constant,
// a 2x2 ramp doubled interpolates between pixel centres and clamps at the edges; bad sizes refused.
TEST(FrameBudget, UpscaleIsBilinearBetweenPixelCentres) {
  const std::vector<std::uint8_t> img = {0, 10, 20, 255, 100, 110, 120, 255, 200, 0, 40, 255, 40, 80, 160, 255};
  EXPECT_EQ(upscaleRgba(img, 2, 2, 2, 2), img);
  const std::vector<std::uint8_t> flat(4 * 4, 77);
  EXPECT_EQ(upscaleRgba(flat, 2, 2, 5, 3), std::vector<std::uint8_t>(5 * 3 * 4, 77));
  // Row 0 of a 2x1 image (0 and 100 in red) at 4x1: centres at -0.25, 0.25, 0.75, 1.25 of the source.
  const std::vector<std::uint8_t> ramp = {0, 0, 0, 255, 100, 0, 0, 255};
  const auto up = upscaleRgba(ramp, 2, 1, 4, 1);
  EXPECT_EQ(up[0], 0);
  EXPECT_EQ(up[4], 25);
  EXPECT_EQ(up[8], 75);
  EXPECT_EQ(up[12], 100);
  EXPECT_THROW(upscaleRgba(ramp, 3, 1, 4, 1), Error);
  EXPECT_THROW(upscaleRgba(ramp, 2, 1, 0, 1), Error);
}
