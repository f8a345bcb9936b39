#include <gtest/gtest.h>

#include <cmath>
#include <queue>

#include "interaction/region_grow.h"
#include "sim/error.h"
#include "sim/phantom.h"

using namespace handson;

namespace {

QuantizedVolume blockVolume() {
  // Two halves: 1000 (x < 10) and 3000 (x >= 10), on a 20x16x12 grid of 1 x 1 x 2 mm voxels.
  VolumeGeometry g;
  g.dims = {20, 16, 12};
  g.spacing = {1, 1, 2};
  Volume v(g, ScalarType::Int16);
  for (int k = 0; k < 12; ++k)
    for (int j = 0; j < 16; ++j)
      for (int i = 0; i < 20; ++i) v.setValue(i, j, k, i < 10 ? 1000.f : 3000.f);
  return quantizeVolume(v);
}

}  // namespace

TEST(RegionGrow, PaperCriterionIsBreadthFirstPassesInAHomogeneousRegion) {
  const QuantizedVolume q = blockVolume();
  GrowParams p;
  p.criterion = GrowCriterion::Paper;
  RegionGrower g(q, {4, 8, 6}, p);
  g.growTo(3.0);  // extent 3 mm = 3 passes of the 1 mm grid
  // Brute force: every voxel of the left half within 3 six-neighbour steps (a diamond).
  std::size_t expect = 0;
  for (int k = 0; k < 12; ++k)
    for (int j = 0; j < 16; ++j)
      for (int i = 0; i < 10; ++i) {
        const int steps = std::abs(i - 4) + std::abs(j - 8) + std::abs(k - 6);
        const bool in = steps <= 3;
        expect += in;
        EXPECT_EQ(g.keys()[std::size_t(i + 20 * (j + 16 * k))] <= g.bound(3.0), in) << i << "," << j << "," << k;
        if (in) {
          EXPECT_EQ(g.keys()[std::size_t(i + 20 * (j + 16 * k))], std::uint32_t(steps));
        }
      }
  EXPECT_EQ(g.count(3.0), expect);
  // Shrinking is a threshold: the 2-pass selection is the 2-step diamond.
  EXPECT_EQ(g.count(2.0), 25u);
  // Growing resumes; the other half never joins (3000 vs 1000 with a floor-sized sigma).
  g.growTo(30.0);
  for (int k = 0; k < 12; ++k)
    for (int j = 0; j < 16; ++j)
      for (int i = 10; i < 20; ++i) EXPECT_EQ(g.keys()[std::size_t(i + 20 * (j + 16 * k))], kUnreached);
  EXPECT_EQ(g.count(30.0), 10u * 16u * 12u);
}

TEST(RegionGrow, SmoothedCriterionIsABallInMillimetres) {
  const QuantizedVolume q = blockVolume();
  RegionGrower g(q, {4, 8, 6});
  g.growTo(4.0);
  for (int k = 0; k < 12; ++k)
    for (int j = 0; j < 16; ++j)
      for (int i = 0; i < 20; ++i) {
        const double d2 = (i - 4) * (i - 4) + (j - 8) * (j - 8) + 4.0 * (k - 6) * (k - 6);
        // 3x3x3 means next to the border between halves are mixed: not homogeneous.
        const bool expected = d2 <= 16.0 && i <= 8;
        EXPECT_EQ(g.keys()[std::size_t(i + 20 * (j + 16 * k))] <= g.bound(4.0), expected) << i << "," << j << "," << k;
      }
}

TEST(RegionGrow, MinimaxKeysMatchABruteForceSearch) {
  // On the phantom with noise: the smoothed criterion's key of each voxel is the smallest radius
  // at which it joins the seed; compare with repeated flood fills at increasing radii.
  PhantomOptions o;
  o.spacingMm = 6.0;
  const Phantom ph = makePhantom(o);
  const QuantizedVolume q = quantizeVolume(ph.ct);
  const Eigen::Vector3i seed = ph.ct.geometry().toIndex(ph.geometry.liverCenter).array().round().cast<int>();
  GrowParams p;
  p.refinements = 0;
  RegionGrower g(q, seed, p);
  g.growTo(60.0);
  for (double r : {12.0, 24.0, 37.0, 60.0}) {
    // Flood fill within the ball of radius r through accepted voxels.
    const auto& d = q.geometry.dims;
    std::vector<char> seen(q.data.size(), 0);
    std::queue<Eigen::Vector3i> queue;
    const auto lin = [&](const Eigen::Vector3i& v) { return std::size_t(v.x()) + std::size_t(d.x()) * (std::size_t(v.y()) + std::size_t(d.y()) * std::size_t(v.z())); };
    queue.push(seed);
    seen[lin(seed)] = 1;
    std::size_t n = 0;
    while (!queue.empty()) {
      const Eigen::Vector3i v = queue.front();
      queue.pop();
      ++n;
      for (int a = 0; a < 3; ++a)
        for (int s : {-1, 1}) {
          Eigen::Vector3i u = v;
          u[a] += s;
          if (!q.geometry.contains(u) || seen[lin(u)]) continue;
          if (growDistance2(u, seed, q.geometry.spacing.cast<float>()) > float(r) * float(r) || !g.accepts(lin(u))) continue;
          seen[lin(u)] = 1;
          queue.push(u);
        }
    }
    EXPECT_EQ(g.count(r), n) << "radius " << r;
  }
}

TEST(RegionGrow, BadInputIsRefused) {
  const QuantizedVolume q = blockVolume();
  EXPECT_THROW(RegionGrower(q, {20, 0, 0}), Error);
  EXPECT_THROW(RegionGrower(q, {-1, 0, 0}), Error);
  GrowParams p;
  p.hMax = std::nan("");
  EXPECT_THROW(RegionGrower(q, {1, 1, 1}, p), Error);
  p.hMax = -1;
  EXPECT_THROW(RegionGrower(q, {1, 1, 1}, p), Error);
  RegionGrower g(q, {1, 1, 1});
  EXPECT_THROW(g.growTo(std::nan("")), Error);
  EXPECT_THROW(g.growTo(-2.0), Error);
  GrowCriterion c;
  EXPECT_TRUE(parseGrowCriterion("paper", c));
  EXPECT_FALSE(parseGrowCriterion("magic", c));
}
