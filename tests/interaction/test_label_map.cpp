// Label maps as handles: labels put on the image's grid (as they are, or by nearest neighbour) and
// the connected component of the label under a seed, against brute force and exact answers.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>

#include "interaction/label_map.h"
#include "sim/base/error.h"

namespace handson {
namespace {

VolumeGeometry grid(Eigen::Vector3i dims, Eigen::Vector3d spacing, Eigen::Vector3d origin = Eigen::Vector3d::Zero()) {
  VolumeGeometry g;
  g.dims = dims;
  g.spacing = spacing;
  g.origin = origin;
  return g;
}

TEST(LabelMap, OnTheSameGridTheLabelsAreTakenAsTheyAre) {
  Volume v(grid({5, 4, 3}, {1, 1, 2}), ScalarType::Int16);
  for (std::size_t i = 0; i < v.voxelCount(); ++i) v.setValue(i, float(i % 7));
  const LabelMap m = labelsOnGrid(v, v.geometry());
  EXPECT_FALSE(m.resampled);
  EXPECT_TRUE(m.note.empty());
  for (std::size_t i = 0; i < v.voxelCount(); ++i) ASSERT_EQ(m.labels[i], std::uint16_t(i % 7));
}

TEST(LabelMap, AnotherGridIsResampledByTheNearestVoxelInSpace) {
  // Labels on a coarse, shifted and rotated grid; the image's voxels each take the label whose
  // voxel centre is nearest, checked by brute force over all label voxels (ties excluded: the
  // grids are offset so no image centre lies halfway).
  VolumeGeometry lg = grid({7, 6, 5}, {2.0, 2.5, 3.0}, {-1.3, 0.4, -2.1});
  lg.direction = Eigen::AngleAxisd(0.3, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  Volume labels(lg, ScalarType::UInt8);
  std::mt19937 rng(3);
  for (std::size_t i = 0; i < labels.voxelCount(); ++i) labels.setValue(i, float(rng() % 4));
  const VolumeGeometry ig = grid({12, 11, 10}, {1.1, 1.2, 1.3}, {-3.0, -2.0, -4.0});
  const LabelMap m = labelsOnGrid(labels, ig);
  EXPECT_TRUE(m.resampled);
  EXPECT_NE(m.note.find("nearest neighbour"), std::string::npos);
  std::size_t checked = 0;
  for (std::size_t o = 0; o < ig.voxelCount(); ++o) {
    const Eigen::Vector3d world = ig.toWorld(ig.voxelOf(o).cast<double>());
    const Eigen::Vector3d idx = lg.toIndex(world);
    const bool inside = (idx.array() >= -0.5).all() && (idx.array() < lg.dims.cast<double>().array() - 0.5).all();
    if (!inside) {
      ASSERT_EQ(m.labels[o], 0) << o;
      continue;
    }
    double best = 1e300;
    float want = 0;
    for (std::size_t l = 0; l < labels.voxelCount(); ++l) {
      const double d = (lg.voxelOf(l).cast<double>() - idx).squaredNorm();  // the nearest centre in index space
      if (d < best) best = d, want = labels.value(l);
    }
    ASSERT_EQ(m.labels[o], std::uint16_t(want)) << o;
    ++checked;
  }
  EXPECT_GT(checked, 100u);
}

TEST(LabelMap, RefusesNonIntegerNegativeNanAndOutOfRangeLabels) {
  for (float bad : {1.5f, -1.0f, 70000.0f, std::numeric_limits<float>::quiet_NaN()}) {
    Volume v(grid({3, 3, 3}, {1, 1, 1}), ScalarType::Float32);
    v.setValue(4, 2.0f);
    v.setValue(13, bad);
    try {
      labelsOnGrid(v, v.geometry());
      FAIL() << bad;
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find("whole numbers"), std::string::npos) << e.what();
    }
  }
}

TEST(LabelMap, RefusesAMapThatMissesTheImageOrHoldsNoLabelInIt) {
  Volume far(grid({4, 4, 4}, {1, 1, 1}, {500, 0, 0}), ScalarType::UInt8);
  far.setValue(0, 3);
  const VolumeGeometry image = grid({8, 8, 8}, {1, 1, 1});
  EXPECT_THROW(labelsOnGrid(far, image), Error);
  Volume empty(image, ScalarType::UInt8);
  try {
    labelsOnGrid(empty, image);
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("no label"), std::string::npos) << e.what();
  }
}

TEST(LabelMap, TheComponentIsTheLabelsConnectedPartUnderTheSeed) {
  // Label 2 in two blocks joined only at a corner (26-connected: one component), a third block of
  // label 2 apart, and label 5 touching the first block face to face (never taken).
  Volume v(grid({12, 8, 8}, {1, 1, 1}), ScalarType::UInt8);
  auto fill = [&](Eigen::Vector3i lo, Eigen::Vector3i hi, float l) {
    for (int k = lo.z(); k <= hi.z(); ++k)
      for (int j = lo.y(); j <= hi.y(); ++j)
        for (int i = lo.x(); i <= hi.x(); ++i) v.setValue(i, j, k, l);
  };
  fill({0, 0, 0}, {2, 2, 2}, 2);
  fill({3, 3, 3}, {4, 4, 4}, 2);   // meets the first only at voxel corners (2,2,2)-(3,3,3)
  fill({8, 0, 0}, {9, 1, 1}, 2);   // apart
  fill({0, 3, 0}, {2, 5, 2}, 5);   // face neighbour of another label
  const LabelMap m = labelsOnGrid(v, v.geometry());
  const auto c = labelComponent(m, {1, 1, 1});
  EXPECT_EQ(c.size(), 27u + 8u);
  EXPECT_TRUE(std::is_sorted(c.begin(), c.end()));
  for (std::uint32_t i : c) EXPECT_EQ(v.value(i), 2.0f);
  EXPECT_TRUE(std::binary_search(c.begin(), c.end(), std::uint32_t(v.linearIndex(4, 4, 4))));
  EXPECT_FALSE(std::binary_search(c.begin(), c.end(), std::uint32_t(v.linearIndex(8, 0, 0))));
  EXPECT_EQ(labelComponent(m, {9, 1, 1}).size(), 8u);
  EXPECT_EQ(labelComponent(m, {0, 4, 0}).size(), 27u);
  EXPECT_THROW(labelComponent(m, {6, 6, 6}), Error);   // background
  EXPECT_THROW(labelComponent(m, {12, 0, 0}), Error);  // outside
  EXPECT_THROW(labelComponent(m, {0, -1, 0}), Error);
}

TEST(LabelMap, TheOrganUnderAFingerIsTheOneBehindThePickedSurface) {
  // Along +x: background, a 2-voxel skin of label 1, then label 7 from x = 6 on. A hit on the skin's
  // front face sees the skin; a hit on the 7's front face (x = 5.5, between voxels 5 and 6) sees 7,
  // though the nearest voxel centre on one side is skin.
  Volume v(grid({16, 3, 3}, {1, 1, 1}), ScalarType::UInt8);
  for (int k = 0; k < 3; ++k)
    for (int j = 0; j < 3; ++j)
      for (int i = 4; i < 16; ++i) v.setValue(i, j, k, i < 6 ? 1.0f : 7.0f);
  const LabelMap m = labelsOnGrid(v, v.geometry());
  const Eigen::Vector3d dx(1, 0, 0);
  auto at = [&](double x, double depth) { return labelledVoxelBehind(m, {x, 1, 1}, dx, depth); };
  ASSERT_TRUE(at(5.5, 4.0));
  EXPECT_EQ(m.at(*at(5.5, 4.0)), 7);
  EXPECT_EQ(*at(5.5, 4.0), Eigen::Vector3i(6, 1, 1));
  EXPECT_EQ(m.at(*at(3.5, 1.5)), 1);   // a thin organ in front is not skipped when the ray stays in it
  EXPECT_EQ(m.at(*at(3.5, 4.0)), 7);   // ... but loses to what holds most of the ray behind it
  EXPECT_FALSE(at(0.0, 2.0));          // only background
  EXPECT_FALSE(labelledVoxelBehind(m, {5.5, 1, 1}, Eigen::Vector3d::Zero(), 4.0));
  EXPECT_FALSE(labelledVoxelBehind(m, {std::nan(""), 1, 1}, dx, 4.0));
}

}  // namespace
}  // namespace handson
