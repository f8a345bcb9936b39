// The skeleton told from contrast-enhanced tissue (sim/skeleton.h): exact voxel answers on synthetic
// CTs at 1 mm spacing with the default CT table (compact bone "yes" >= 700 HU, spongy bone "joined"
// 150-700 HU).
#include <gtest/gtest.h>

#include "sim/base/error.h"
#include "sim/skeleton.h"

namespace handson {
namespace {

// 60 x 30 x 30 voxels of 1 mm at 30 HU (soft tissue); `fill` sets a box of voxels [a, b] to v.
struct Ct {
  Volume v;
  Ct() {
    VolumeGeometry g;
    g.dims = {60, 30, 30};
    g.spacing = {1, 1, 1};
    v = Volume(g, ScalarType::Int16);
    for (std::size_t i = 0; i < v.voxelCount(); ++i) v.setValue(i, 30.0f);
  }
  void fill(Eigen::Vector3i a, Eigen::Vector3i b, float value) {
    for (int k = a.z(); k <= b.z(); ++k)
      for (int j = a.y(); j <= b.y(); ++j)
        for (int i = a.x(); i <= b.x(); ++i) v.setValue(i, j, k, value);
  }
  Eigen::Vector3d at(int i, int j, int k) const { return v.geometry().toWorld(Eigen::Vector3d(i, j, k)); }
};

int bandNamed(const MaterialTable& t, const std::string& name) {
  for (std::size_t i = 0; i < t.bands().size(); ++i)
    if (t.band(int(i)).name == name) return int(i);
  return -1;
}

TEST(Skeleton, SpongyValuesAreBoneOnlyWithinTheReachOfCompactBone) {
  // A compact-bone block (x 0..4) with a spongy rod along x (x 5..40), and a separate 200 HU blob
  // (contrast-enhanced tissue) at x 50..55: the rod is skeleton up to 15 mm of path from the block
  // (x = 4 + 15 = 19), the blob nowhere.
  Ct ct;
  ct.fill({0, 10, 10}, {4, 20, 20}, 900);
  ct.fill({5, 14, 14}, {40, 16, 16}, 300);
  ct.fill({50, 12, 12}, {55, 18, 18}, 200);
  const MaterialTable table = MaterialTable::ctDefault();
  const TissueMap map(ct.v, table, ct.at(0, 0, 0), ct.at(59, 29, 29), 15.0);
  EXPECT_TRUE(map.skeletonAt(ct.at(2, 15, 15)));
  EXPECT_TRUE(map.skeletonAt(ct.at(19, 15, 15)));
  EXPECT_FALSE(map.skeletonAt(ct.at(20, 15, 15)));
  EXPECT_FALSE(map.skeletonAt(ct.at(52, 15, 15)));
  EXPECT_FALSE(map.skeletonAt(ct.at(30, 5, 5)));  // soft tissue
  // Block 5x11x11 + rod x 5..19 (15 x 3 x 3).
  EXPECT_EQ(map.skeletonVoxelCount(), std::size_t(5 * 11 * 11 + 15 * 9));
  // Materials: spongy on the skeleton, the band below off it; compact bone stays compact.
  const int spongy = bandNamed(table, "spongy-bone"), below = bandNamed(table, "enhanced-organ-and-blood");
  EXPECT_EQ(map.bandAt(ct.at(10, 15, 15)), spongy);
  EXPECT_EQ(map.bandAt(ct.at(30, 15, 15)), below);
  EXPECT_EQ(map.bandAt(ct.at(52, 15, 15)), below);
  EXPECT_EQ(map.bandAt(ct.at(2, 15, 15)), bandNamed(table, "compact-bone"));
  // By value alone (the earlier rule): no skeleton, spongy wherever the values are.
  const TissueMap byValue(ct.v, table, ct.at(0, 0, 0), ct.at(59, 29, 29), 15.0, false);
  EXPECT_EQ(byValue.skeletonVoxelCount(), 0u);
  EXPECT_EQ(byValue.bandAt(ct.at(52, 15, 15)), spongy);
}

TEST(Skeleton, PathLengthsFollowTheSpacingAndTheBoxIsGrownByTheReach) {
  // 2 mm voxels along x: a rod joined to the block is skeleton for 15 mm = 7 voxels (14 mm). The
  // box asked for lies 10 mm away from the block: the block is still found (the box grows by the reach).
  Ct ct;
  VolumeGeometry g = ct.v.geometry();
  g.spacing = {2, 1, 1};
  Volume v(g, ScalarType::Int16);
  for (std::size_t i = 0; i < v.voxelCount(); ++i) v.setValue(i, ct.v.value(i));
  ct.v = std::move(v);
  ct.fill({0, 10, 10}, {4, 20, 20}, 900);
  ct.fill({5, 15, 15}, {30, 15, 15}, 300);
  const TissueMap map(ct.v, MaterialTable::ctDefault(), ct.at(10, 0, 0), ct.at(59, 29, 29), 15.0);
  EXPECT_TRUE(map.skeletonAt(ct.at(11, 15, 15)));
  EXPECT_FALSE(map.skeletonAt(ct.at(12, 15, 15)));
}

TEST(Skeleton, ATableWithoutSkeletonBandsHasNoneAndBadReachIsRefused) {
  Ct ct;
  ct.fill({0, 10, 10}, {4, 20, 20}, 900);
  const MaterialTable plain = MaterialTable::parse("units,hu\nname,lower,upper,youngs_kpa,poisson,strain_limit\nsoft,-inf,500,6,0.45,0.22\nbone,500,inf,1e6,0.3,0.02\n");
  EXPECT_EQ(plain.band(1).skeleton, SkeletonRole::No);
  EXPECT_EQ(TissueMap(ct.v, plain, ct.at(0, 0, 0), ct.at(59, 29, 29), 15.0).skeletonVoxelCount(), 0u);
  EXPECT_THROW(TissueMap(ct.v, plain, ct.at(0, 0, 0), ct.at(59, 29, 29), -1.0), Error);
  EXPECT_THROW(TissueMap(ct.v, plain, ct.at(0, 0, 0), ct.at(59, 29, 29), std::nan("")), Error);
  EXPECT_THROW(MaterialTable::parse("units,hu\nname,lower,upper,youngs_kpa,poisson,strain_limit,skeleton\nbone,500,inf,1e6,0.3,0.02,maybe\n"), Error);
  const MaterialTable t = MaterialTable::parse("units,hu\nname,lower,upper,youngs_kpa,poisson,strain_limit,skeleton\nsoft,-inf,150,6,0.45,0.22,no\nspongy,150,700,3e5,0.3,0.0078,joined\ncompact,700,inf,1.5e7,0.3,0.027,yes\n");
  EXPECT_EQ(t.band(1).skeleton, SkeletonRole::Joined);
  EXPECT_EQ(t.band(2).skeleton, SkeletonRole::Yes);
}

}  // namespace
}  // namespace handson
