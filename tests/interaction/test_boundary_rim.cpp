// The selection's boundary rim (withBoundaryRim, interaction/region_grow.h) against a brute-force
// reading of its rule and an organ with a partial-volume shell whose answer is known.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>

#include "interaction/region_grow.h"
#include "sim/base/error.h"

using namespace handson;

namespace {

QuantizedVolume volumeOf(const Eigen::Vector3i& dims, const std::vector<std::uint16_t>& data) {
  QuantizedVolume q;
  q.geometry.dims = dims;
  q.geometry.spacing = {1, 1, 2};
  q.data = data;
  return q;
}

// Every voxel outside the selection tested from its side: unless homogeneous with the seed, for each
// axis direction a with the voxel before it (c - a) selected and the one after it (c + a) inside the
// volume, it joins when its value is nearer the mean than that of c + a.
std::vector<std::uint32_t> bruteForceRim(const RegionGrower& g, double mean, const std::vector<std::uint32_t>& sel) {
  const QuantizedVolume& q = g.volume();
  const Eigen::Vector3i d = q.geometry.dims;
  std::vector<char> in(q.data.size(), 0);
  for (auto v : sel) in[v] = 1;
  auto at = [&](const Eigen::Vector3i& p) { return std::size_t(p.x()) + std::size_t(d.x()) * (std::size_t(p.y()) + std::size_t(d.y()) * std::size_t(p.z())); };
  auto inside = [&](const Eigen::Vector3i& p) { return (p.array() >= 0).all() && (p.array() < d.array()).all(); };
  std::vector<std::uint32_t> out;
  for (int k = 0; k < d.z(); ++k)
    for (int j = 0; j < d.y(); ++j)
      for (int i = 0; i < d.x(); ++i) {
        const Eigen::Vector3i c(i, j, k);
        bool take = in[at(c)] != 0;
        for (int axis = 0; axis < 3 && !take && !g.accepts(at(c)); ++axis)
          for (int s = -1; s <= 1 && !take; s += 2) {
            Eigen::Vector3i a = Eigen::Vector3i::Zero();
            a[axis] = s;
            if (!inside(c - a) || !inside(c + a) || !in[at(c - a)]) continue;
            const double x = q.data[at(c)];
            take = std::abs(x - mean) < std::abs(x - double(q.data[at(c + a)]));
          }
        if (take) out.push_back(std::uint32_t(at(c)));
      }
  return out;
}

}  // namespace

// An organ (a 6x6x6 block at 1000) in background 0, wrapped in a one-voxel partial-volume shell:
// 600 on its -x, -y and -z sides (more organ than background: on the organ's side of half-way),
// 400 on its +x, +y, +z sides. Selecting the block but its top layer, the rim is the 600 faces'
// voxels face-adjacent to a selected one: not the 400 faces, not the shell's edges and corners
// (diagonal to the block), and not the block's own top layer (homogeneous: the extent left it out).
TEST(BoundaryRim, TakesThePartialVolumeShellOnTheOrgansSideOfHalfWay) {
  const Eigen::Vector3i d(12, 12, 12);
  std::vector<std::uint16_t> data(std::size_t(d.prod()), 0);
  auto at = [&](int i, int j, int k) { return std::uint32_t(i + 12 * (j + 12 * k)); };
  auto inBlock = [](int i, int j, int k) { return i >= 3 && i <= 8 && j >= 3 && j <= 8 && k >= 3 && k <= 8; };
  for (int k = 2; k <= 9; ++k)
    for (int j = 2; j <= 9; ++j)
      for (int i = 2; i <= 9; ++i) data[at(i, j, k)] = inBlock(i, j, k) ? 1000 : (i == 2 || j == 2 || k == 2) ? 600 : 400;
  const QuantizedVolume q = volumeOf(d, data);
  std::vector<std::uint32_t> selected, expected;
  for (int k = 0; k < 12; ++k)
    for (int j = 0; j < 12; ++j)
      for (int i = 0; i < 12; ++i) {
        const bool sel = inBlock(i, j, k) && k <= 7;
        if (sel) selected.push_back(at(i, j, k));
        // A 600 voxel whose step toward the block (+x, +y or +z) lands on a selected voxel.
        const bool rim = data[at(i, j, k)] == 600 && ((i == 2 && inBlock(3, j, k) && k <= 7) || (j == 2 && inBlock(i, 3, k) && k <= 7) ||
                                                      (k == 2 && inBlock(i, j, 3)));
        if (sel || rim) expected.push_back(at(i, j, k));
      }
  GrowParams p;
  p.criterion = GrowCriterion::Paper;  // the test is the voxel's own value
  const RegionGrower paper(q, {5, 5, 5}, p);
  ASSERT_TRUE(paper.accepts(at(5, 5, 8)));
  EXPECT_EQ(withBoundaryRim(paper, selected), expected);
  EXPECT_TRUE(withBoundaryRim(paper, {}).empty());
  // Under the core criterion (3x3x3 means, the same mean of 1000) the block's top layer touches the
  // 400 shell: its means fail the test as partial-volume voxels do, and it joins too.
  const RegionGrower core(q, {5, 5, 5}, GrowParams{});
  ASSERT_FALSE(core.accepts(at(5, 5, 8)));
  for (int j = 3; j <= 8; ++j)
    for (int i = 3; i <= 8; ++i) expected.push_back(at(i, j, 8));
  std::sort(expected.begin(), expected.end());
  EXPECT_EQ(withBoundaryRim(core, selected), expected);
}

// Noise, an irregular selection and the volume's border: the rule as the brute force reads it.
TEST(BoundaryRim, AgreesWithABruteForceReadingOfTheRuleOnNoise) {
  const Eigen::Vector3i d(9, 7, 5);
  std::mt19937 rng(7);
  std::uniform_int_distribution<int> value(0, 4000);
  std::vector<std::uint16_t> data(std::size_t(d.prod()));
  for (auto& v : data) v = std::uint16_t(value(rng));
  const QuantizedVolume q = volumeOf(d, data);
  std::vector<std::uint32_t> sel;
  for (std::uint32_t v = 0; v < data.size(); ++v)
    if (rng() % 3 == 0) sel.push_back(v);  // touches every face of the volume
  GrowParams p;
  p.criterion = GrowCriterion::Paper;
  p.hMax = 0.5;  // some voxels homogeneous with the seed (about a third), most not
  const RegionGrower g(q, {4, 3, 2}, p);
  const auto rim = withBoundaryRim(g, sel);
  EXPECT_EQ(rim, bruteForceRim(g, g.setup().seedValue, sel));
  EXPECT_GT(rim.size(), sel.size());
  EXPECT_TRUE(std::includes(rim.begin(), rim.end(), sel.begin(), sel.end()));
}

TEST(BoundaryRim, RefusesVoxelsOutsideTheVolumeOrOutOfOrder) {
  const QuantizedVolume q = volumeOf({4, 4, 4}, std::vector<std::uint16_t>(64, 100));
  const RegionGrower g(q, {1, 1, 1}, GrowParams{});
  EXPECT_THROW(withBoundaryRim(g, {64}), Error);
  EXPECT_THROW(withBoundaryRim(g, {5, 3}), Error);
}
