#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <fstream>

#include "render/render_params.h"
#include "render/transfer_function.h"
#include "render/volume_texture.h"
#include "shaders/shared.h"
#include "sim/error.h"

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
  ASSERT_EQ(lut.size(), gpu::kTfEntries);
  for (std::uint32_t i = 0; i < gpu::kTfEntries; i += 97) {
    const float value = q.toValue(float(i) / float(gpu::kTfEntries - 1));
    EXPECT_NEAR(lut[i].a, tf.evaluate(value).a, 1e-6f);
  }
  EXPECT_THROW(transferFunctionPreset("nope"), Error);
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
  std::vector<float> alpha(lut.size());
  for (std::size_t i = 0; i < lut.size(); ++i) alpha[i] = lut[i].a;
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
  EXPECT_EQ(p.dims.w, 64);
  EXPECT_EQ(p.brickDims.w, 32);
  EXPECT_EQ(p.control.y, 5u);
  EXPECT_EQ(p.cameraPos, glm::vec4(1, 2, 3, 1));
  EXPECT_FLOAT_EQ(p.march.x, 0.5f);
}
