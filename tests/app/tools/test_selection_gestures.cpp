// The simulated user's gestures (app/tools/selection_gestures.h): the error regions and their
// targets against brute force, and the protocol through the app's pinch and handle edits.
#include "app/tools/selection_gestures.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "interaction/region_grow.h"

namespace handson {
namespace {

VolumeGeometry grid(const Eigen::Vector3i& dims, const Eigen::Vector3d& spacing) {
  VolumeGeometry g;
  g.dims = dims;
  g.spacing = spacing;
  return g;
}

// Voxels of the box [lo, hi] (inclusive) set to `value` in `mask`.
void fill(std::vector<std::uint8_t>& mask, const VolumeGeometry& g, const Eigen::Vector3i& lo, const Eigen::Vector3i& hi, std::uint8_t value) {
  for (int k = lo.z(); k <= hi.z(); ++k)
    for (int j = lo.y(); j <= hi.y(); ++j)
      for (int i = lo.x(); i <= hi.x(); ++i) mask[linearIndex(g, {i, j, k})] = value;
}

// The deepest voxel of a region by brute force: the largest distance (mm) to the nearest voxel
// not in it (the grid's outside counting as not in it), the lowest index on ties.
Eigen::Vector3i bruteForceDeepest(const std::vector<std::uint32_t>& region, const VolumeGeometry& g) {
  std::vector<Eigen::Vector3i> outside;
  std::vector<std::uint8_t> in(std::size_t(g.dims.prod()), 0);
  for (std::uint32_t v : region) in[v] = 1;
  for (int k = -1; k <= g.dims.z(); ++k)
    for (int j = -1; j <= g.dims.y(); ++j)
      for (int i = -1; i <= g.dims.x(); ++i) {
        const Eigen::Vector3i p(i, j, k);
        if (!g.contains(p) || !in[linearIndex(g, p)]) outside.push_back(p);
      }
  double best = -1;
  Eigen::Vector3i at(-1, -1, -1);
  for (std::uint32_t v : region) {  // ascending
    double d = 1e30;
    for (const auto& o : outside) d = std::min(d, (o - g.voxelOf(v)).cast<double>().cwiseProduct(g.spacing).norm());
    if (d > best) {
      best = d;
      at = g.voxelOf(v);
    }
  }
  return at;
}

TEST(SelectionGestures, TheLargestErrorRegionAndItsDeepestVoxelMatchBruteForce) {
  // An organ box; the selection misses a 3x3x3 pocket of it and leaks into a 7x7x3 slab beside it
  // (1 x 1 x 2 mm voxels) and, corner to corner with the slab, a 2x2x2 cube: one 26-connected
  // leaked region of 147 + 8 voxels, the largest error.
  const VolumeGeometry g = grid({24, 20, 12}, {1.0, 1.0, 2.0});
  std::vector<std::uint8_t> organ(std::size_t(g.dims.prod()), 0);
  fill(organ, g, {2, 2, 2}, {10, 17, 9}, 1);
  std::vector<std::uint8_t> selected = organ;
  fill(selected, g, {4, 4, 4}, {6, 6, 6}, 0);
  fill(selected, g, {11, 3, 3}, {17, 9, 5}, 1);
  fill(selected, g, {18, 10, 6}, {19, 11, 7}, 1);
  const ErrorRegion e = largestErrorRegion(organ, selected, g);
  EXPECT_FALSE(e.missed);
  ASSERT_EQ(e.target.voxels.size(), 147u + 8u);
  EXPECT_EQ(e.target.deepest, bruteForceDeepest(e.target.voxels, g));
  // Its spread: the 95th percentile of the region's distances from that voxel, by sorting.
  std::vector<double> d;
  for (std::uint32_t v : e.target.voxels) d.push_back((g.voxelOf(v) - e.target.deepest).cast<double>().cwiseProduct(g.spacing).norm());
  std::sort(d.begin(), d.end());
  EXPECT_DOUBLE_EQ(e.target.spreadMm, d[std::size_t(std::ceil(0.95 * double(d.size()))) - 1]);
  // With the leak gone the missed pocket is the largest error; its deepest voxel is 2 mm from
  // the outside at its centre and one slice below (2 mm slices), the lower index.
  fill(selected, g, {11, 3, 3}, {19, 11, 7}, 0);
  const ErrorRegion m = largestErrorRegion(organ, selected, g);
  EXPECT_TRUE(m.missed);
  EXPECT_EQ(m.target.voxels.size(), 27u);
  EXPECT_EQ(m.target.deepest, Eigen::Vector3i(5, 5, 4));
  EXPECT_EQ(m.target.deepest, bruteForceDeepest(m.target.voxels, g));
  // No error: no region.
  EXPECT_TRUE(largestErrorRegion(organ, organ, g).target.voxels.empty());
}

// A CT of a ball organ (60 HU, radius 9 mm) joined by a bridge (radius 4 mm) to a neighbour of the
// same value (radius 8 mm) in fat (-100 HU); labels: the organ 1, the neighbour 2.
struct TwoBalls {
  VolumeGeometry g = grid({56, 40, 40}, {1.0, 1.0, 1.0});
  Volume ct{g, ScalarType::Int16}, labels{g, ScalarType::UInt8};
  TwoBalls() {
    for (int k = 0; k < 40; ++k)
      for (int j = 0; j < 40; ++j)
        for (int i = 0; i < 56; ++i) {
          const Eigen::Vector3d p(i, j, k);
          const bool organ = (p - Eigen::Vector3d(16, 20, 20)).norm() <= 9.0;
          const bool other = (p - Eigen::Vector3d(38, 20, 20)).norm() <= 8.0 || (i > 16 && i < 38 && std::hypot(j - 20.0, k - 20.0) <= 4.0);
          ct.setValue(i, j, k, organ || other ? 60.0f : -100.0f);
          labels.setValue(i, j, k, organ ? 1.0f : other ? 2.0f : 0.0f);
        }
  }
};

TEST(SelectionGestures, TheProtocolRunsTheAppsPinchAndEditsAndScoresTheirSelection) {
  TwoBalls s;
  const QuantizedVolume q = quantizeVolume(s.ct);
  GestureProtocol protocol;
  protocol.gestures = 6;
  const OrganGestures o = runGestureProtocol("two balls", s.ct, q, s.labels, {1, "organ"}, protocol);
  for (const GestureStep& st : o.steps)
    std::printf("gesture %d %s at (%d, %d, %d) spread %.1f mm, region %zu, pinch %zu%s: Dice %.3f\n", st.gesture, gestureKindName(st.kind), st.target.x(),
                st.target.y(), st.target.z(), st.spreadMm, st.regionVoxels, st.pinchVoxels, st.refused ? " (refused)" : "", st.dice);
  ASSERT_FALSE(o.steps.empty());
  // The first pinch is the app's: from the organ's deepest voxel to its radius, with the rim.
  const Eigen::Vector3i centre(16, 20, 20);
  EXPECT_EQ(o.steps[0].target, centre);
  RegionGrower grower(q, mostHomogeneousNear(q, centre, 2), protocol.params);
  grower.growTo(o.steps[0].spreadMm);
  std::vector<std::uint32_t> voxels;
  for (std::size_t v : grower.touched())
    if (grower.keys()[v] <= grower.bound(o.steps[0].spreadMm)) voxels.push_back(std::uint32_t(v));
  std::sort(voxels.begin(), voxels.end());
  voxels = withBoundaryRim(grower, voxels);
  EXPECT_EQ(o.steps[0].pinchVoxels, voxels.size());
  EXPECT_EQ(o.steps[0].selected, voxels.size());
  std::size_t hit = 0;
  for (std::uint32_t v : voxels) hit += s.labels.value(v) == 1.0f;
  EXPECT_DOUBLE_EQ(o.steps[0].dice, 2.0 * double(hit) / double(voxels.size() + o.organVoxels));
  // Then corrections (the first pinch misses the organ's outer voxels, whose 3x3x3 means the fat
  // beside them pulls outside the tolerance): a union never shrinks the selection, a difference
  // never grows it.
  ASSERT_GE(o.steps.size(), 2u);
  for (std::size_t i = 1; i < o.steps.size(); ++i) {
    EXPECT_NE(o.steps[i].kind, GestureKind::First);
    if (o.steps[i].kind == GestureKind::Add) EXPECT_GE(o.steps[i].selected, o.steps[i - 1].selected);
    else EXPECT_LE(o.steps[i].selected, o.steps[i - 1].selected);
  }
}

}  // namespace
}  // namespace handson
