#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <queue>
#include <string>

#include "interaction/region_grow.h"
#include "sim/base/error.h"
#include "sim/phantom.h"

using namespace handson;

namespace {

// A volume on a grid of `dims` voxels of `spacing` mm whose voxel (i, j, k) holds value(i, j, k).
template <class Value>
QuantizedVolume filledVolume(const Eigen::Vector3i& dims, const Eigen::Vector3d& spacing, Value value) {
  VolumeGeometry g;
  g.dims = dims;
  g.spacing = spacing;
  Volume v(g, ScalarType::Int16);
  for (int k = 0; k < dims.z(); ++k)
    for (int j = 0; j < dims.y(); ++j)
      for (int i = 0; i < dims.x(); ++i) v.setValue(i, j, k, value(i, j, k));
  return quantizeVolume(v);
}

// The 26-neighbour chamfer distance on a 1 mm grid in path units: with the offsets' magnitudes
// sorted a >= b >= c, c corner steps (443), b - c edge steps (362) and a - b face steps (256).
std::uint32_t chamferUnits(int di, int dj, int dk) {
  int m[3] = {std::abs(di), std::abs(dj), std::abs(dk)};
  std::sort(m, m + 3);
  return std::uint32_t(m[0]) * 443u + std::uint32_t(m[1] - m[0]) * 362u + std::uint32_t(m[2] - m[1]) * 256u;
}

QuantizedVolume blockVolume() {
  // Two halves: 1000 (x < 10) and 3000 (x >= 10), on a 20x16x12 grid of 1 x 1 x 2 mm voxels.
  return filledVolume({20, 16, 12}, {1, 1, 2}, [](int i, int, int) { return i < 10 ? 1000.f : 3000.f; });
}

// Voxels a 6-neighbour flood fill reaches from the seed within the ball of radius r (mm, the
// shader's float distance): it steps into voxels `enters` accepts, out of voxels `leaves` accepts.
template <class Enters, class Leaves>
std::size_t floodFill(const QuantizedVolume& q, const Eigen::Vector3i& seed, double r, Enters enters, Leaves leaves) {
  const auto& d = q.geometry.dims;
  const auto lin = [&](const Eigen::Vector3i& v) { return std::size_t(v.x()) + std::size_t(d.x()) * (std::size_t(v.y()) + std::size_t(d.y()) * std::size_t(v.z())); };
  std::vector<char> seen(q.data.size(), 0);
  std::queue<Eigen::Vector3i> queue;
  queue.push(seed);
  seen[lin(seed)] = 1;
  std::size_t n = 0;
  while (!queue.empty()) {
    const Eigen::Vector3i v = queue.front();
    queue.pop();
    ++n;
    if (!leaves(v)) continue;
    for (int a = 0; a < 3; ++a)
      for (int s : {-1, 1}) {
        Eigen::Vector3i u = v;
        u[a] += s;
        if (!q.geometry.contains(u) || seen[lin(u)]) continue;
        if (growDistance2(u, seed, q.geometry.spacing.cast<float>()) > float(r) * float(r) || !enters(u)) continue;
        seen[lin(u)] = 1;
        queue.push(u);
      }
  }
  return n;
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
  // Under the ball bound (the path bound's keys are tested below).
  const QuantizedVolume q = blockVolume();
  for (GrowCriterion c : {GrowCriterion::Smoothed, GrowCriterion::Core}) {
  GrowParams p;
  p.criterion = c;
  p.bound = GrowBound::Ball;
  RegionGrower g(q, {4, 8, 6}, p);
  EXPECT_EQ(g.setup().criterion, c);
  g.growTo(4.0);
  for (int k = 0; k < 12; ++k)
    for (int j = 0; j < 16; ++j)
      for (int i = 0; i < 20; ++i) {
        const double d2 = (i - 4) * (i - 4) + (j - 8) * (j - 8) + 4.0 * (k - 6) * (k - 6);
        // 3x3x3 means next to the border between halves are mixed: not homogeneous.
        const bool expected = d2 <= 16.0 && i <= 8;
        EXPECT_EQ(g.keys()[std::size_t(i + 20 * (j + 16 * k))] <= g.bound(4.0), expected) << growCriterionName(c) << " " << i << "," << j << "," << k;
      }
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
  p.criterion = GrowCriterion::Smoothed;
  p.refinements = 0;
  p.bound = GrowBound::Ball;
  RegionGrower g(q, seed, p);
  g.growTo(60.0);
  const auto& d = q.geometry.dims;
  const auto accepted = [&](const Eigen::Vector3i& u) { return g.accepts(std::size_t(u.x()) + std::size_t(d.x()) * (std::size_t(u.y()) + std::size_t(d.y()) * std::size_t(u.z()))); };
  for (double r : {12.0, 24.0, 37.0, 60.0}) {
    // Flood fill within the ball of radius r through accepted voxels.
    const std::size_t n = floodFill(q, seed, r, accepted, [](const Eigen::Vector3i&) { return true; });
    EXPECT_EQ(g.count(r), n) << "radius " << r;
  }
}

TEST(RegionGrow, PathKeysInAUniformRegionAreTheChamferDistance) {
  // Every voxel is homogeneous and passes growth on, so a voxel's key is the 26-neighbour chamfer
  // distance: with the offsets' magnitudes sorted a >= b >= c, c corner steps, b - c edge steps and
  // a - b face steps (1 mm voxels: 256, 362 and 443 units, the rounded 256, 256 sqrt 2, 256 sqrt 3).
  const QuantizedVolume q = filledVolume({21, 21, 21}, {1, 1, 1}, [](int, int, int) { return 2000.f; });
  const auto cost = growStepCosts({1, 1, 1});
  EXPECT_EQ(cost[1], 256u);
  EXPECT_EQ(cost[3], 362u);
  EXPECT_EQ(cost[7], 443u);
  for (GrowCriterion c : {GrowCriterion::Smoothed, GrowCriterion::Core}) {
    GrowParams p;
    p.criterion = c;
    p.bound = GrowBound::Path;
    RegionGrower g(q, {10, 10, 10}, p);
    ASSERT_EQ(g.setup().criterion, c);
    g.growTo(12.0);
    std::size_t within = 0;
    for (int k = 0; k < 21; ++k)
      for (int j = 0; j < 21; ++j)
        for (int i = 0; i < 21; ++i) {
          const std::uint32_t chamfer = chamferUnits(i - 10, j - 10, k - 10);
          const std::uint32_t key = g.keys()[std::size_t(i + 21 * (j + 21 * k))];
          if (chamfer <= g.bound(12.0)) {
            EXPECT_EQ(key, chamfer) << growCriterionName(c) << " " << i << "," << j << "," << k;
            ++within;
          } else {
            EXPECT_GT(key, g.bound(12.0)) << growCriterionName(c) << " " << i << "," << j << "," << k;
          }
          // Never beyond the straight line's length (the ball of the same extent holds the selection).
          if (key <= g.bound(12.0)) {
            EXPECT_LE((i - 10) * (i - 10) + (j - 10) * (j - 10) + (k - 10) * (k - 10), 144) << i << "," << j << "," << k;
          }
        }
    EXPECT_EQ(g.count(12.0), within);
    // Within the grid (10 voxels each way) the 12 mm ball holds 6,733 voxel centres and the chamfer
    // ball 5,581 of them (its length is up to 8 % above the straight line's, so it reaches less far
    // off the axes; counted separately by brute force over the offsets).
    EXPECT_EQ(within, 5581u);
  }
}

TEST(RegionGrow, PathKeysAreShortestPathLengthsThroughTheRegion) {
  // A U: two bars along x (y 4-11 and 18-25) joined at x 26-33, 1 x 1 x 2 mm voxels. The seed lies
  // near the free end of one bar; the other bar's free end is 14 mm away in a straight line and
  // over 40 mm along the U.
  const QuantizedVolume q = filledVolume({40, 30, 12}, {1, 1, 2}, [](int i, int j, int k) {
    const bool slab = k >= 2 && k <= 9 && i >= 4 && i <= 33;
    const bool bars = (j >= 4 && j <= 11) || (j >= 18 && j <= 25) || (i >= 26 && j >= 4 && j <= 25);
    return slab && bars ? 3000.f : 1000.f;
  });
  const Eigen::Vector3i seed(7, 7, 5), far(7, 21, 5);
  const auto& d = q.geometry.dims;
  const auto lin = [&](const Eigen::Vector3i& x) { return std::size_t(x.x()) + std::size_t(d.x()) * (std::size_t(x.y()) + std::size_t(d.y()) * std::size_t(x.z())); };
  // Step lengths by axis mask on this grid: sqrt of 1, 1, 2, 4, 5, 5, 6 mm^2, times 256, rounded.
  const auto cost = growStepCosts({1, 1, 2});
  EXPECT_EQ(std::vector<std::uint32_t>(cost.begin() + 1, cost.end()), (std::vector<std::uint32_t>{256, 256, 362, 512, 572, 572, 627}));
  EXPECT_EQ(growStepCosts({0.001f, 0.001f, 0.001f})[7], 1u);  // never a free step
  for (GrowCriterion c : {GrowCriterion::Smoothed, GrowCriterion::Core}) {
    GrowParams p;
    p.criterion = c;
    p.bound = GrowBound::Path;
    RegionGrower g(q, seed, p);
    ASSERT_EQ(g.setup().criterion, c);
    ASSERT_EQ(g.setup().bound, GrowBound::Path);
    g.growTo(60.0);
    // Independent answer: Bellman-Ford over the whole grid (relax every voxel until nothing
    // changes) with the straight-line step lengths in double, rounded per step, into accepted
    // voxels, out of voxels that pass growth on; a step across an edge or corner only where face
    // steps through such voxels join the two (tried over every order of its axes).
    const auto through = [&](const Eigen::Vector3i& w) { return q.geometry.contains(w) && (w == seed || (g.accepts(lin(w)) && g.passesOn(lin(w)))); };
    std::vector<std::uint64_t> ref(q.data.size(), ~0ull);
    ref[lin(seed)] = 0;
    for (bool changed = true; changed;) {
      changed = false;
      for (std::size_t x = 0; x < ref.size(); ++x) {
        const Eigen::Vector3i vx = q.geometry.voxelOf(x);
        if (ref[x] == ~0ull || !through(vx)) continue;
        for (int dz = -1; dz <= 1; ++dz)
          for (int dy = -1; dy <= 1; ++dy)
            for (int dx = -1; dx <= 1; ++dx) {
              const Eigen::Vector3i st(dx, dy, dz), u = vx + st;
              if (st == Eigen::Vector3i::Zero() || !q.geometry.contains(u) || !g.accepts(lin(u))) continue;
              std::vector<int> axes;
              for (int a = 0; a < 3; ++a)
                if (st[a] != 0) axes.push_back(a);
              bool joined = false;
              do {
                Eigen::Vector3i w = vx;
                bool ok = true;
                for (std::size_t t = 0; t + 1 < axes.size() && ok; ++t) {
                  w[axes[t]] += st[axes[t]];
                  ok = through(w);
                }
                joined = ok;
              } while (!joined && std::next_permutation(axes.begin(), axes.end()));
              if (!joined) continue;
              const double mm = std::sqrt(double(dx * dx) + double(dy * dy) + 4.0 * double(dz * dz));
              const std::uint64_t k = ref[x] + std::uint64_t(std::llround(mm * 256.0));
              if (k < ref[lin(u)]) {
                ref[lin(u)] = k;
                changed = true;
              }
            }
      }
    }
    const std::uint32_t bound60 = g.bound(60.0);
    EXPECT_EQ(bound60, 60u * 256u);
    std::size_t reached = 0;
    for (std::size_t x = 0; x < ref.size(); ++x) {
      const bool in = ref[x] <= bound60;
      reached += in;
      EXPECT_EQ(g.keys()[x] <= bound60, in) << growCriterionName(c) << " voxel " << x;
      if (in) {
        EXPECT_EQ(g.keys()[x], ref[x]) << growCriterionName(c) << " voxel " << x;
      }
    }
    EXPECT_GT(reached, 1000u);
    // The far end lies beyond 30 mm of path, though the U's bend lies in the ball of 30 mm within
    // which the ball bound selects it.
    const std::uint32_t farKey = g.keys()[lin(far)];
    EXPECT_GT(farKey, g.bound(40.0)) << growCriterionName(c);
    EXPECT_LE(farKey, g.bound(60.0)) << growCriterionName(c);
    GrowParams pb = p;
    pb.bound = GrowBound::Ball;
    RegionGrower ball(q, seed, pb);
    ball.growTo(30.0);
    EXPECT_LE(ball.keys()[lin(far)], ball.bound(30.0)) << growCriterionName(c);
    // Shrinking is a threshold on the stored keys, and growing resumes: the same keys.
    RegionGrower resumed(q, seed, p);
    for (double e : {5.0, 20.0, 12.0, 60.0}) resumed.growTo(e);
    for (std::size_t x = 0; x < ref.size(); ++x)
      if (ref[x] <= bound60) {
        EXPECT_EQ(resumed.keys()[x], ref[x]);
      }
  }
  // The reach of a path bound: whole steps along each axis within d.
  EXPECT_EQ(growReach(GrowCriterion::Core, GrowBound::Path, 10.0, {1, 1, 2}), Eigen::Vector3i(10, 10, 5));
  EXPECT_EQ(growReach(GrowCriterion::Core, GrowBound::Path, 10.0, {0.57, 0.57, 1.6}), Eigen::Vector3i(17, 17, 6));
  GrowBound b;
  EXPECT_TRUE(parseGrowBound("path", b) && b == GrowBound::Path);
  EXPECT_TRUE(parseGrowBound("ball", b) && b == GrowBound::Ball);
  EXPECT_FALSE(parseGrowBound("geodesic", b));
}

TEST(RegionGrow, RobustStatisticsIgnoreAMinorityOfOtherTissueNearTheSeed) {
  // A 24^3 grid of 1 mm voxels: raw values 1000 + r (r pseudo-random in 0..199), and about one
  // voxel in seven 'other tissue' at 1600 + r. Every 3x3x3 mean lies well within every tolerance
  // below (the seed's is 400 from the floor; the refined ones 10x the spread), so the region grown
  // within the 10 mm probe is the whole ball both times, and the refined statistics are exactly
  // those of the ball's raw values: robust -> the median and 1.4826 x the median absolute
  // deviation; moments -> the mean and the standard deviation, which the minority pulls up.
  QuantizedVolume q;
  q.geometry.dims = {24, 24, 24};
  q.geometry.spacing = {1, 1, 1};
  q.data.resize(24 * 24 * 24);
  std::uint32_t state = 12345;
  for (auto& u : q.data) {
    state = state * 1664525u + 1013904223u;
    const std::uint32_t r = (state >> 8) % 200;
    u = std::uint16_t(((state >> 20) % 7 == 0 ? 1600 : 1000) + r);
  }
  const Eigen::Vector3i seed(12, 12, 12);
  std::vector<std::uint32_t> ball;
  for (int k = 0; k < 24; ++k)
    for (int j = 0; j < 24; ++j)
      for (int i = 0; i < 24; ++i)
        if (growDistance2({i, j, k}, seed, q.geometry.spacing.cast<float>()) <= 100.0f) ball.push_back(q.data[std::size_t(i + 24 * (j + 24 * k))]);
  std::vector<std::uint32_t> sorted = ball;
  std::sort(sorted.begin(), sorted.end());
  const std::uint32_t median = sorted[sorted.size() / 2];
  std::vector<std::uint32_t> dev;
  for (std::uint32_t x : ball) dev.push_back(x > median ? x - median : median - x);
  std::sort(dev.begin(), dev.end());
  const double mad = dev[dev.size() / 2];
  double s1 = 0, s2 = 0;
  for (std::uint32_t x : ball) {
    s1 += x;
    s2 += double(x) * x;
  }
  const double mean = s1 / double(ball.size()), sd = std::sqrt(s2 / double(ball.size()) - mean * mean);

  GrowParams p;
  p.criterion = GrowCriterion::Smoothed;
  p.hMax = 1.0;
  p.sigmaFloor = 400.0 / 65535.0;
  p.hRegion = 10.0;
  p.statistics = RegionStatistics::Robust;
  const RegionGrower robust(q, seed, p);
  EXPECT_FLOAT_EQ(robust.setup().seedValue, float(27.0 * median));
  EXPECT_FLOAT_EQ(robust.setup().tolerance, float(27.0 * 10.0 * 1.4826 * mad));
  p.statistics = RegionStatistics::Moments;
  const RegionGrower moments(q, seed, p);
  EXPECT_FLOAT_EQ(moments.setup().seedValue, float(27.0 * mean));
  EXPECT_FLOAT_EQ(moments.setup().tolerance, float(27.0 * 10.0 * sd));
  // The point of the rule: the median stays within the majority's values (1000-1199), the mean
  // does not; the robust spread stays near the majority's own (uniform over 200: MAD 50, x 1.4826
  // = 74; the minority shifts the median, measured 86), the standard deviation is over twice it
  // (measured 212: the minority's 600 offset dominates it).
  EXPECT_LT(median, 1200u);
  EXPECT_GT(mean, 1150.0);
  EXPECT_LT(1.4826 * mad, 1.25 * 74.0);
  EXPECT_GT(sd, 2.0 * 1.4826 * mad);
  EXPECT_EQ(std::string(regionStatisticsName(RegionStatistics::Robust)), "robust");
  RegionStatistics parsed = RegionStatistics::Robust;
  EXPECT_TRUE(parseRegionStatistics("moments", parsed));
  EXPECT_EQ(parsed, RegionStatistics::Moments);
  EXPECT_FALSE(parseRegionStatistics("median", parsed));
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
  p = {};
  p.coreFraction = 0.0;
  EXPECT_THROW(RegionGrower(q, {1, 1, 1}, p), Error);
  p.coreFraction = std::nan("");
  EXPECT_THROW(RegionGrower(q, {1, 1, 1}, p), Error);
  p = {};
  p.thinShare = 1.5;
  EXPECT_THROW(RegionGrower(q, {1, 1, 1}, p), Error);
  p = {};
  p.statistics = RegionStatistics(7);
  EXPECT_THROW(RegionGrower(q, {1, 1, 1}, p), Error);
  p = {};
  p.bound = GrowBound(9);
  EXPECT_THROW(RegionGrower(q, {1, 1, 1}, p), Error);
  {
    // Path keys on absurd spacings (a step's length would overflow the keys) are refused.
    const QuantizedVolume hq = filledVolume({4, 4, 4}, {1, 1, 2e5}, [](int, int, int) { return 0.f; });
    EXPECT_THROW(RegionGrower(hq, {1, 1, 1}), Error);
    p = {};
    p.bound = GrowBound::Ball;
    EXPECT_NO_THROW(RegionGrower(hq, {1, 1, 1}, p));
  }
  RegionGrower g(q, {1, 1, 1});
  EXPECT_THROW(g.growTo(std::nan("")), Error);
  EXPECT_THROW(g.growTo(-2.0), Error);
  GrowCriterion c;
  EXPECT_TRUE(parseGrowCriterion("paper", c));
  EXPECT_TRUE(parseGrowCriterion("core", c));
  EXPECT_EQ(c, GrowCriterion::Core);
  EXPECT_FALSE(parseGrowCriterion("magic", c));
}

namespace {

// Two 14^3 boxes of equal intensity (1 mm voxels, 1000 on 0), joined along x by a bridge of
// width x width voxels. Smoothed values of voxels less than one voxel from the boundary are mixed,
// so the smoothed criterion accepts voxels with a one-voxel margin, the core criterion's core needs
// a two-voxel margin: it cuts bridges up to four voxels wide (exact, noise-free).
QuantizedVolume twoOrgans(int width) {
  VolumeGeometry g;
  g.dims = {40, 20, 20};
  Volume v(g, ScalarType::Int16);
  auto organ = [&](int i, int j, int k) {
    const bool box = j >= 3 && j <= 16 && k >= 3 && k <= 16 && ((i >= 2 && i <= 15) || (i >= 22 && i <= 35));
    const int lo = 10 - width / 2;
    const bool bridge = i > 15 && i < 22 && j >= lo && j < lo + width && k >= lo && k < lo + width;
    return box || bridge;
  };
  for (int k = 0; k < 20; ++k)
    for (int j = 0; j < 20; ++j)
      for (int i = 0; i < 40; ++i) v.setValue(i, j, k, organ(i, j, k) ? 1000.f : 0.f);
  return quantizeVolume(v);
}

bool reachesTheOtherOrgan(const QuantizedVolume& q, GrowCriterion c) {
  GrowParams p;
  p.criterion = c;
  RegionGrower g(q, {8, 10, 10}, p);
  g.growTo(60.0);
  return g.keys()[std::size_t(28 + 40 * (10 + 20 * 10))] != kUnreached;
}

}  // namespace

TEST(RegionGrow, TheCoreCriterionDoesNotMergeOrgansJoinedByABridge) {
  for (int width : {1, 2, 3, 4}) EXPECT_FALSE(reachesTheOtherOrgan(twoOrgans(width), GrowCriterion::Core)) << "width " << width;
  // What it is measured against: the paper's criterion crosses any bridge, the smoothed one any
  // three voxels wide, and a five-voxel bridge has a core of its own (the stated limit, exact).
  EXPECT_TRUE(reachesTheOtherOrgan(twoOrgans(1), GrowCriterion::Paper));
  EXPECT_FALSE(reachesTheOtherOrgan(twoOrgans(2), GrowCriterion::Smoothed));
  EXPECT_TRUE(reachesTheOtherOrgan(twoOrgans(3), GrowCriterion::Smoothed));
  EXPECT_TRUE(reachesTheOtherOrgan(twoOrgans(4), GrowCriterion::Smoothed));
  EXPECT_TRUE(reachesTheOtherOrgan(twoOrgans(5), GrowCriterion::Core));
}

TEST(RegionGrow, AnOrganLargerThanTheExtentIsCutAtTheExtent) {
  // The ball of 4 mm about the box's centre lies at least two voxels inside it: the selection is
  // exactly that ball (ball bound) or the chamfer ball of 4 mm of path (path bound: c corner,
  // b - c edge and a - b face steps of 443, 362 and 256 units for sorted offsets a >= b >= c); at
  // 30 mm it is exactly the organ's accepted voxels and nothing else, under either bound.
  const QuantizedVolume q = twoOrgans(1);
  for (GrowBound b : {GrowBound::Ball, GrowBound::Path}) {
    GrowParams p;
    p.bound = b;
    RegionGrower g(q, {8, 10, 10}, p);
    ASSERT_EQ(g.setup().criterion, GrowCriterion::Core);
    g.growTo(30.0);
    std::size_t inFour = 0;
    for (int k = 0; k < 20; ++k)
      for (int j = 0; j < 20; ++j)
        for (int i = 0; i < 40; ++i) {
          const std::size_t v = std::size_t(i + 40 * (j + 20 * k));
          const int d2 = (i - 8) * (i - 8) + (j - 10) * (j - 10) + (k - 10) * (k - 10);
          const bool within = b == GrowBound::Ball ? d2 <= 16 : chamferUnits(i - 8, j - 10, k - 10) <= 4u * 256u;
          inFour += within;
          EXPECT_EQ(g.keys()[v] <= g.bound(4.0), within) << growBoundName(b) << " " << i << "," << j << "," << k;
          // The first box's voxels whose 3x3x3 neighbourhood is all organ, less its twelve edge lines
          // (they touch no core voxel: both neighbours inward lie on a face layer).
          const int mi = std::min(i - 2, 15 - i), mj = std::min(j - 3, 16 - j), mk = std::min(k - 3, 16 - k);
          const bool accepted = mi >= 1 && mj >= 1 && mk >= 1;
          const int onFaceLayer = (mi == 1) + (mj == 1) + (mk == 1);
          EXPECT_EQ(g.keys()[v] <= g.bound(30.0), accepted && onFaceLayer < 2) << growBoundName(b) << " " << i << "," << j << "," << k;
        }
    EXPECT_EQ(g.count(4.0), inFour) << growBoundName(b);
  }
}

TEST(RegionGrow, CoreKeysMatchABruteForceSearch) {
  // On the 3 mm phantom with noise: a flood fill within each ball that steps only out of core
  // voxels (the seed always), the core decided here from the 3x3x3 sums, independently.
  PhantomOptions o;
  o.spacingMm = 3.0;
  const Phantom ph = makePhantom(o);
  const QuantizedVolume q = quantizeVolume(ph.ct);
  const Eigen::Vector3i seed = ph.ct.geometry().toIndex(ph.geometry.liverCenter).array().round().cast<int>();
  GrowParams cp;
  cp.bound = GrowBound::Ball;  // the flood fill is bounded by the ball (path keys: PathKeysAreShortestPathLengths...)
  RegionGrower g(q, seed, cp);
  ASSERT_EQ(g.setup().criterion, GrowCriterion::Core);
  GrowParams sp;
  sp.bound = GrowBound::Ball;
  sp.criterion = GrowCriterion::Smoothed;
  RegionGrower smoothed(q, seed, sp);
  const auto& d = q.geometry.dims;
  const auto lin = [&](const Eigen::Vector3i& v) { return std::size_t(v.x()) + std::size_t(d.x()) * (std::size_t(v.y()) + std::size_t(d.y()) * std::size_t(v.z())); };
  const auto sum27 = [&](Eigen::Vector3i v) {
    double s = 0;
    for (int z = -1; z <= 1; ++z)
      for (int y = -1; y <= 1; ++y)
        for (int x = -1; x <= 1; ++x) s += q.data[lin((v + Eigen::Vector3i(x, y, z)).cwiseMax(0).cwiseMin(d - Eigen::Vector3i::Ones()))];
    return s;
  };
  const GrowSetup& st = g.setup();
  const auto homogeneous = [&](const Eigen::Vector3i& v) { return std::abs(sum27(v) - st.seedValue) < st.tolerance; };
  const auto core = [&](const Eigen::Vector3i& v) {
    if (v == seed) return true;
    if (!(std::abs(sum27(v) - st.seedValue) < st.coreTolerance) || !homogeneous(v)) return false;
    for (int a = 0; a < 3; ++a)
      for (int s : {-1, 1}) {
        Eigen::Vector3i u = v;
        u[a] = std::clamp(u[a] + s, 0, d[a] - 1);
        if (!homogeneous(u)) return false;
      }
    return true;
  };
  std::size_t differs = 0;
  for (double r : {10.0, 20.0, 35.0, 60.0}) {
    g.growTo(r);
    smoothed.growTo(r);
    const std::size_t n = floodFill(q, seed, r, homogeneous, core);
    EXPECT_EQ(g.count(r), n) << "radius " << r;
    differs += smoothed.count(r) != n;
  }
  EXPECT_GT(differs, 0u) << "the core criterion selects what the smoothed one does: the test would not see it";
}

TEST(RegionGrow, ASeedInAStructureTooThinForACoreGrowsSmoothed) {
  // A rod four voxels across: its accepted voxels are a 2x2 line with no core, so the smoothed
  // criterion runs and selects them all within the ball.
  VolumeGeometry geo;
  geo.dims = {40, 9, 9};
  Volume v(geo, ScalarType::Int16);
  for (int k = 0; k < 9; ++k)
    for (int j = 0; j < 9; ++j)
      for (int i = 0; i < 40; ++i) v.setValue(i, j, k, (j >= 2 && j <= 5 && k >= 2 && k <= 5) ? 1000.f : 0.f);
  const QuantizedVolume q = quantizeVolume(v);
  RegionGrower g(q, {20, 4, 4});
  EXPECT_EQ(g.setup().criterion, GrowCriterion::Smoothed);
  g.growTo(8.0);
  std::size_t expect = 0;
  for (int k = 3; k <= 4; ++k)
    for (int j = 3; j <= 4; ++j)
      for (int i = 1; i < 39; ++i) expect += (i - 20) * (i - 20) + (j - 4) * (j - 4) + (k - 4) * (k - 4) <= 64;
  EXPECT_EQ(g.count(8.0), expect);
}

// Growers that reuse one workspace give the keys fresh growers give, each criterion and seed in
// turn, and leave the workspace cleared; a grower refused for bad input leaves it usable.
TEST(RegionGrow, GrowersSharingAWorkspaceGiveTheKeysOfFreshOnesAndLeaveItCleared) {
  PhantomOptions o;
  o.spacingMm = 4.0;
  const Phantom ph = makePhantom(o);
  const QuantizedVolume q = quantizeVolume(ph.ct);
  const Eigen::Vector3i kidney = ph.ct.geometry().toIndex(ph.geometry.kidneyRightCenter).array().round().cast<int>();
  const Eigen::Vector3i liver = ph.ct.geometry().toIndex(ph.geometry.liverCenter).array().round().cast<int>();
  const auto workspace = std::make_shared<GrowWorkspace>();
  GrowWorkspace& ws = *workspace;
  ws.reserve(q.data.size());
  for (GrowCriterion c : {GrowCriterion::Core, GrowCriterion::Paper, GrowCriterion::Smoothed, GrowCriterion::Core})
    for (const Eigen::Vector3i& seed : {kidney, liver}) {
      GrowParams p;
      p.criterion = c;
      RegionGrower fresh(q, seed, p);
      fresh.growTo(40.0);
      {
        RegionGrower reused(q, seed, p, workspace);
        EXPECT_TRUE(ws.keys.empty()) << "the grower holds the arrays";
        reused.growTo(25.0);
        reused.growTo(40.0);
        EXPECT_EQ(reused.keys(), fresh.keys()) << growCriterionName(c);
        EXPECT_EQ(reused.count(40.0), fresh.count(40.0));
      }
      ASSERT_EQ(ws.keys.size(), q.data.size());
      EXPECT_EQ(std::count(ws.keys.begin(), ws.keys.end(), kUnreached), std::ptrdiff_t(q.data.size()));
      EXPECT_EQ(std::count(ws.tests.begin(), ws.tests.end(), std::uint8_t(0)), std::ptrdiff_t(q.data.size()));
    }
  GrowParams bad;
  bad.refinements = -1;
  EXPECT_THROW(RegionGrower(q, kidney, bad, workspace), Error);
  EXPECT_THROW(RegionGrower(q, Eigen::Vector3i(-1, 0, 0), GrowParams{}, workspace), Error);
  EXPECT_EQ(ws.keys.size(), q.data.size()) << "a refused grower never took the arrays";
  // One grower at a time: a second waits for the arrays, and is refused once the wait runs out
  // (as it would wait for ever for a grower its own thread holds).
  ws.lendWait = std::chrono::milliseconds(50);
  {
    RegionGrower holder(q, kidney, GrowParams{}, workspace);
    EXPECT_THROW(RegionGrower(q, liver, GrowParams{}, workspace), Error);
  }
  RegionGrower after(q, liver, GrowParams{}, workspace);
  after.growTo(20.0);
  EXPECT_GT(after.count(20.0), 27u) << "given back, the arrays lend again";
}
