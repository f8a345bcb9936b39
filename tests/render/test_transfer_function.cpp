#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>

#include "render/render_params.h"
#include "render/transfer_function.h"
#include "render/volume_texture.h"
#include "shaders/shared.h"
#include "sim/base/error.h"

using namespace handson;

namespace {
Volume ramp() {
  VolumeGeometry g;
  g.dims = {20, 17, 9};
  Volume v(g, ScalarType::Int16);
  for (std::size_t i = 0; i < v.voxelCount(); ++i) v.setValue(i, float(int(i % 3000) - 1000));
  return v;
}
}  // namespace

TEST(TransferFunction, EvaluatesPiecewiseLinearWithConstantEnds) {
  TransferFunction tf;
  tf.points = {{0, {0, 0, 0, 0}}, {100, {1, 0.5f, 0, 0.2f}}, {200, {1, 1, 1, 1}}};
  EXPECT_EQ(tf.evaluate(-50), glm::vec4(0));
  EXPECT_NEAR(tf.evaluate(50).a, 0.1f, 1e-6f);
  EXPECT_NEAR(tf.evaluate(150).g, 0.75f, 1e-6f);
  EXPECT_EQ(tf.evaluate(500), glm::vec4(1));
}

TEST(TransferFunction, LookupTableSpansTheVolumeWindow) {
  const Volume v = ramp();
  const QuantizedVolume q = quantizeVolume(v);
  EXPECT_EQ(q.lo, -1000.0f);
  EXPECT_EQ(q.hi, 1999.0f);
  const TransferFunction tf = transferFunctionPreset("ct-bone");
  const auto lut = tf.lookupTable(q);
  ASSERT_EQ(lut.entries.size(), gpu::kTfEntries);
  EXPECT_EQ(lut.rows, 1u);
  EXPECT_EQ(lut.gradientTop, 0.0f);
  EXPECT_TRUE(lut.valid());
  for (std::uint32_t i = 0; i < gpu::kTfEntries; i += 97) {
    const float value = q.toValue(float(i) / float(gpu::kTfEntries - 1));
    EXPECT_NEAR(lut.entries[i].a, tf.evaluate(value).a, 1e-6f);
  }
  EXPECT_THROW(transferFunctionPreset("nope"), Error);
}

TEST(TransferFunction, TheGradientAxisScalesOpacityAndTintsBoundaries) {
  // By hand: value 50 HU (rgb 0.5, 0.5, 0.5, a 0.2), gradient points (0: x0.5, no tint), (40: x2,
  // black at weight 0.5): at g = 20 the factor is 1.25 and the tint black at weight 0.25.
  TransferFunction tf;
  tf.points = {{0, {0.5f, 0.5f, 0.5f, 0.2f}}, {100, {0.5f, 0.5f, 0.5f, 0.2f}}};
  tf.gradient = {{0.0f, 0.5f, {0, 0, 0, 0}}, {40.0f, 2.0f, {0, 0, 0, 0.5f}}};
  EXPECT_NEAR(tf.evaluate(50, 20).a, 0.25f, 1e-6f);
  EXPECT_NEAR(tf.evaluate(50, 20).r, 0.5f * 0.75f, 1e-6f);
  EXPECT_NEAR(tf.evaluate(50, 0).a, 0.1f, 1e-6f);
  EXPECT_NEAR(tf.evaluate(50, 400).a, 0.4f, 1e-6f);  // constant beyond the last point
  EXPECT_NEAR(tf.evaluate(50, 400).g, 0.25f, 1e-6f);
  // The table: kTfGradientRows rows, row r at r / (rows - 1) of the last magnitude (40 HU/mm), in
  // normalized value per mm over the volume's window.
  const QuantizedVolume q = quantizeVolume(ramp());
  const TfTable t = tf.lookupTable(q);
  ASSERT_TRUE(t.valid());
  ASSERT_EQ(t.rows, gpu::kTfGradientRows);
  EXPECT_NEAR(t.gradientTop, 40.0f / (q.hi - q.lo), 1e-9f);
  for (std::uint32_t r = 0; r < t.rows; r += 5)
    for (std::uint32_t i = 0; i < gpu::kTfEntries; i += 331) {
      const glm::vec4 want = tf.evaluate(q.toValue(float(i) / float(gpu::kTfEntries - 1)), 40.0f * float(r) / float(t.rows - 1));
      const glm::vec4 got = t.entries[std::size_t(r) * gpu::kTfEntries + i];
      for (int c = 0; c < 4; ++c) EXPECT_NEAR(got[c], want[c], 1e-6f) << r << " " << i;
    }
  const std::uint32_t inside = std::uint32_t(std::lround(q.toNormalized(50.0f) * float(gpu::kTfEntries - 1)));
  EXPECT_NEAR(t.maxAlpha()[inside], 0.4f, 1e-6f);  // the last row's (0.2 x 2), at a value of about 50 HU
  // The envelope row after the rows: each value's largest entry over them, channel by channel.
  ASSERT_EQ(t.entries.size(), std::size_t(gpu::kTfGradientRows + 1) * gpu::kTfEntries);
  for (std::uint32_t i = 0; i < gpu::kTfEntries; i += 173) {
    glm::vec4 m(0.0f);
    for (std::uint32_t r = 0; r < t.rows; ++r) m = glm::max(m, t.entries[std::size_t(r) * gpu::kTfEntries + i]);
    EXPECT_EQ(t.entries[std::size_t(t.rows) * gpu::kTfEntries + i], m) << i;
  }
  // Windowing stretches the gradient axis with the values: exact, as for the values.
  const double s = 1.6, shift = 30.0;
  const TransferFunction w = tf.windowed(s, shift, 1.0);
  const float a = tf.visibleFrom();
  for (float g : {0.0f, 7.0f, 25.0f, 90.0f}) {
    const glm::vec4 want = tf.evaluate(50, g), got = w.evaluate(float(a + (50 - a) * s + shift), float(g * s));
    for (int c = 0; c < 4; ++c) EXPECT_NEAR(got[c], want[c], 1e-5f) << g;
  }
  // ct-organs has the axis; the other presets do not (their tables keep one row).
  EXPECT_FALSE(transferFunctionPreset("ct-organs").gradient.empty());
  EXPECT_EQ(transferFunctionPreset("ct-abdomen").lookupTable(q).rows, 1u);
}

TEST(TransferFunction, QuantizationIsExactForInt16) {
  const Volume v = ramp();
  const QuantizedVolume q = quantizeVolume(v);
  for (std::size_t i = 0; i < v.voxelCount(); i += 13) EXPECT_NEAR(q.toValue(q.data[i] / 65535.0f), v.value(i), 0.03f);
}

TEST(BrickGrid, OccupancyMatchesBruteForce) {
  const Volume v = ramp();
  const QuantizedVolume q = quantizeVolume(v);
  const BrickGrid g = computeBrickGrid(q);
  EXPECT_EQ(g.bx, 3);
  EXPECT_EQ(g.by, 3);
  EXPECT_EQ(g.bz, 2);
  // Brute force for the ranges: every voxel a sample inside the brick can touch.
  for (int b = 0; b < int(g.count()); ++b) {
    const int x = b % g.bx, y = (b / g.bx) % g.by, z = b / (g.bx * g.by);
    std::uint32_t mn = 65535, mx = 0;
    for (int k = std::max(0, z * 8 - 1); k <= std::min(8, z * 8 + 8); ++k)
      for (int j = std::max(0, y * 8 - 1); j <= std::min(16, y * 8 + 8); ++j)
        for (int i = std::max(0, x * 8 - 1); i <= std::min(19, x * 8 + 8); ++i) {
          const std::uint32_t u = q.data[std::size_t(i) + 20u * (std::size_t(j) + 17u * std::size_t(k))];
          mn = std::min(mn, u);
          mx = std::max(mx, u);
        }
    EXPECT_EQ(g.ranges[2 * b], mn);
    EXPECT_EQ(g.ranges[2 * b + 1], mx);
  }
  // A table opaque only above 1500 HU: occupied bricks are exactly those whose max reaches it.
  const auto lut = thresholdTransferFunction(1500.0f).lookupTable(q);
  const std::vector<float> alpha = lut.maxAlpha();
  const auto occ = brickOccupancy(g, alpha);
  for (std::size_t b = 0; b < g.count(); ++b) {
    bool any = false;
    for (std::uint32_t u = g.ranges[2 * b]; u <= g.ranges[2 * b + 1] && !any; u += 1) {
      const double x = u / 65535.0 * (gpu::kTfEntries - 1);
      any = alpha[std::size_t(std::floor(x))] > 0 || alpha[std::min<std::size_t>(std::size_t(std::ceil(x)), gpu::kTfEntries - 1)] > 0;
    }
    EXPECT_EQ(occ[b] != 0, any) << "brick " << b;
  }
}

TEST(TransferFunction, FileFormatAndErrors) {
  const auto dir = std::filesystem::temp_directory_path() / "handson_tf_test";
  std::filesystem::create_directories(dir);
  const auto good = dir / "good.tf";
  std::ofstream(good) << "# kidney\n-100 0 0 0 0\n150 1 0.2 0.2 0.3  # cortex\n";
  const TransferFunction tf = loadTransferFunction(good.string());
  ASSERT_EQ(tf.points.size(), 2u);
  EXPECT_NEAR(tf.points[1].rgba.a, 0.3f, 1e-6f);
  const auto bad = dir / "bad.tf";
  std::ofstream(bad) << "100 1 1 1 1\n50 0 0 0 0\n";
  EXPECT_THROW(loadTransferFunction(bad.string()), Error);
  std::ofstream(bad) << "abc\n";
  EXPECT_THROW(loadTransferFunction(bad.string()), Error);
  EXPECT_THROW(loadTransferFunction((dir / "missing.tf").string()), Error);
  // Gradient lines: "gradient magnitude opacity r g b w", increasing, magnitude and opacity >= 0.
  std::ofstream(good) << "-100 0 0 0 0\n150 1 0.2 0.2 0.3\ngradient 0 0.5 0 0 0 0\ngradient 40 2 0.1 0.1 0.1 0.4\n";
  const TransferFunction twoD = loadTransferFunction(good.string());
  ASSERT_EQ(twoD.gradient.size(), 2u);
  EXPECT_NEAR(twoD.gradient[1].tint.a, 0.4f, 1e-6f);
  for (const char* text : {"0 0 0 0 0\ngradient 10 1 0 0 0 0\ngradient 5 1 0 0 0 0\n", "0 0 0 0 0\ngradient -1 1 0 0 0 0\n",
                           "0 0 0 0 0\ngradient 1 nan 0 0 0 0\n", "0 0 0 0 0\ngradient 1 1 0 0\n", "0 0 0 0 0\ngradient 1e36 1 0 0 0 0\n"}) {
    std::ofstream(bad) << text;
    EXPECT_THROW(loadTransferFunction(bad.string()), Error) << text;
  }
  std::filesystem::remove_all(dir);
}

TEST(RenderParams, RejectsBadSizesAndEncodesTheCamera) {
  VolumeGeometry g;
  g.dims = {10, 10, 10};
  RenderSettings s;
  s.width = 0;
  EXPECT_THROW(makeRenderParams(g, glm::mat4(1), glm::mat4(1), glm::vec3(0), s), Error);
  s.width = 64;
  s.height = 32;
  const auto p = makeRenderParams(g, glm::mat4(1), glm::mat4(1), glm::vec3(1, 2, 3), s, 5);
  EXPECT_EQ(p.outputWidth, 64);
  EXPECT_EQ(p.outputHeight, 32);
  EXPECT_EQ(p.pickCount, 5u);
  EXPECT_EQ(p.eye, glm::vec3(1, 2, 3));
  EXPECT_FLOAT_EQ(p.stepMm, 0.5f);
}

TEST(TransferFunction, WindowingMovesAndScalesThePointsAboutWhereTheyBecomeVisible) {
  const TransferFunction tf = transferFunctionPreset("ct-abdomen");
  EXPECT_FLOAT_EQ(tf.visibleFrom(), -120.0f);  // the last clear point before fat shows
  // Half the largest opacity (0.95) is reached between 300 HU (0.4) and 500 HU (0.8).
  EXPECT_NEAR(tf.width(), 300.0f + 200.0f * (0.475f - 0.4f) / 0.4f + 120.0f, 1e-3f);
  const TransferFunction same = tf.windowed(1.0, 0.0, 1.0);
  for (float v = -1100.0f; v < 3200.0f; v += 7.3f) EXPECT_EQ(same.evaluate(v), tf.evaluate(v));
  // Exact: the windowed function at a + (v - a) s + shift is the preset at v, opacity scaled.
  const double s = 1.7, shift = -85.0, opacity = 2.5;
  const TransferFunction w = tf.windowed(s, shift, opacity);
  const float a = tf.visibleFrom();
  for (float v = -1000.0f; v < 3000.0f; v += 11.1f) {
    const glm::vec4 want = tf.evaluate(v), got = w.evaluate(float(a + (v - a) * s + shift));
    EXPECT_NEAR(got.r, want.r, 1e-4f) << v;
    EXPECT_NEAR(got.a, std::min(1.0f, want.a * float(opacity)), 1e-4f) << v;
  }
  // Bad adjustments leave it as it was.
  EXPECT_EQ(tf.windowed(0.0, 0.0, 1.0).points.front().value, tf.points.front().value);
  EXPECT_EQ(tf.windowed(1.0, std::nan(""), 1.0).points[3].value, tf.points[3].value);
  // Relative presets window in their own units (fractions of the percentile range).
  const TransferFunction mri = transferFunctionPreset("mri");
  EXPECT_FLOAT_EQ(mri.visibleFrom(), 0.12f);
  EXPECT_GT(mri.width(), 0.1f);
  EXPECT_LT(mri.width(), 1.0f);
}

TEST(TransferFunction, TheSoftTissuePresetShowsUnenhancedOrgansAndClearsFat) {
  // Unenhanced kidney ~30 HU, spleen ~45, liver ~60: visible in ct-soft-tissue (a 10 mm organ
  // reaches >= 30 % opacity), nearly clear in ct-abdomen (built for contrast); fat stays clear and
  // bone does not hide what lies behind it (a 5 mm cortex keeps its opacity below 60 %).
  const TransferFunction soft = transferFunctionPreset("ct-soft-tissue"), abdomen = transferFunctionPreset("ct-abdomen");
  auto through = [](const TransferFunction& tf, float hu, float mm) { return 1.0f - std::pow(1.0f - tf.evaluate(hu).a, mm); };
  for (float organ : {30.0f, 45.0f, 60.0f}) {
    EXPECT_GE(through(soft, organ, 10.0f), 0.30f) << organ;
    EXPECT_GE(through(soft, organ, 10.0f), 5.0f * through(abdomen, organ, 10.0f)) << organ;
  }
  EXPECT_EQ(soft.evaluate(-100.0f).a, 0.0f);
  EXPECT_LT(through(soft, 1000.0f, 5.0f), 0.6f);
  // Organs of different density get different colours (liver darker and redder than kidney).
  EXPECT_LT(soft.evaluate(60.0f).g, soft.evaluate(30.0f).g - 0.1f);
}

TEST(RenderParams, ClipTextParsesRoundTripsAndRefusesMalformedValues) {
  ClipRegion c;
  EXPECT_EQ(parseClipBox("-40.5,-120,-200,40,-30,200.25", c), "");
  EXPECT_TRUE(c.box);
  EXPECT_EQ(c.lo, glm::vec3(-40.5f, -120.0f, -200.0f));
  EXPECT_EQ(parseClipPlane("0.1,-2,0.3,-17.125", c), "");
  ClipRegion back;
  EXPECT_EQ(parseClipBox(formatClipBox(c), back), "");
  EXPECT_EQ(parseClipPlane(formatClipPlane(c), back), "");
  EXPECT_EQ(back, c);
  const ClipRegion before = c;
  for (const char* bad : {"", "1,2,3", "1,2,3,4,5,6,7", "10,0,0,0,1,1", "0,0,0,1,1,nan", "0,0,0,1,1,1e39", "0,0,0,1,1,x", "0,0,0,1,1,1,"})
    EXPECT_NE(parseClipBox(bad, c), "") << bad;
  for (const char* bad : {"0,0,0,5", "1,0,0", "1,0,0,inf", "1,,0,2"}) EXPECT_NE(parseClipPlane(bad, c), "") << bad;
  EXPECT_EQ(c, before);  // refused values change nothing
}

TEST(TransferFunction, DefaultPresetIsCtForHounsfieldValuesElseMri) {
  VolumeGeometry g;
  g.dims = {4, 1, 1};
  Volume v(g, ScalarType::Int16);
  const auto fill = [&](float a, float b, float c, float d) {
    const float x[4] = {a, b, c, d};
    for (int i = 0; i < 4; ++i) v.setValue(i, 0, 0, x[i]);
  };
  fill(-1000, -50, 40, 1200);  // air, fat, soft tissue, bone
  EXPECT_EQ(defaultPresetFor(v), "ct-abdomen");
  fill(-899, -50, 40, 1200);  // no air: not recognised as CT
  EXPECT_EQ(defaultPresetFor(v), "mri");
  fill(0, 120, 800, 2400);  // MRI intensities: unsigned
  EXPECT_EQ(defaultPresetFor(v), "mri");
  fill(-1024, -1000, -990, -950);  // air only, no signed range above 0
  EXPECT_EQ(defaultPresetFor(v), "mri");
}
