#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <limits>

#include "sim/base/error.h"
#include "sim/volume.h"

using namespace handson;

namespace {
VolumeGeometry oblique() {
  VolumeGeometry g;
  g.dims = {7, 5, 4};
  g.spacing = {0.7, 1.3, 2.5};
  g.origin = {-12.0, 40.5, 3.25};
  g.direction = Eigen::AngleAxisd(0.4, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  return g;
}
}  // namespace

TEST(VolumeGeometry, IndexToWorldMatchesDefinitionAndInverts) {
  const VolumeGeometry g = oblique();
  const Eigen::Vector3d idx(2.5, -1.0, 3.75);
  const Eigen::Vector3d expect = g.origin + g.direction * Eigen::Vector3d(2.5 * 0.7, -1.0 * 1.3, 3.75 * 2.5);
  EXPECT_LT((g.toWorld(idx) - expect).norm(), 1e-12);
  EXPECT_LT((g.toIndex(g.toWorld(idx)) - idx).norm(), 1e-12);
  const Eigen::Matrix4d m = g.worldToIndex() * g.indexToWorld();
  EXPECT_LT((m - Eigen::Matrix4d::Identity()).norm(), 1e-12);
  // The 4x4 form agrees with the vector form.
  const Eigen::Vector4d h = g.indexToWorld() * idx.homogeneous();
  EXPECT_LT((h.head<3>() - expect).norm(), 1e-12);
}

TEST(VolumeGeometry, ValidateRejectsBadGeometry) {
  VolumeGeometry g = oblique();
  EXPECT_NO_THROW(g.validate());
  g.dims = {0, 5, 4};
  EXPECT_THROW(g.validate(), Error);
  g = oblique();
  g.spacing.x() = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW(g.validate(), Error);
  g = oblique();
  g.spacing.y() = -1.0;
  EXPECT_THROW(g.validate(), Error);
  g = oblique();
  g.direction.col(2) = g.direction.col(1);
  EXPECT_THROW(g.validate(), Error);
  g = oblique();
  g.dims = {100000, 100000, 100000};
  EXPECT_THROW(g.validate(), Error);
}

TEST(Volume, AbsurdAllocationIsRefusedBeforeAllocating) {
  VolumeGeometry g;
  g.dims = {4000, 2000, 500};  // 4e9 voxels: beyond kMaxVoxels
  EXPECT_THROW(Volume(g, ScalarType::Float32), Error);
  // More bytes than any machine's memory.
  EXPECT_THROW(checkAllocation(1000, std::size_t{1} << 50, "test"), Error);
  EXPECT_NO_THROW(checkAllocation(1000, 4000, "test"));
}

TEST(Volume, TypedStorageAndConversions) {
  VolumeGeometry g;
  g.dims = {3, 2, 2};
  Volume v(g, ScalarType::Int16);
  v.setValue(1, 1, 1, -1024.4f);
  EXPECT_EQ(v.value(1, 1, 1), -1024.0f);
  v.setValue(0, 0, 0, 1e9f);  // clamps to int16
  EXPECT_EQ(v.value(0, 0, 0), 32767.0f);
  v.setValue(2, 0, 0, std::nanf(""));
  EXPECT_EQ(v.value(2, 0, 0), 0.0f);
  EXPECT_EQ(v.data<std::int16_t>()[v.linearIndex(1, 1, 1)], -1024);
  EXPECT_THROW(v.data<float>(), Error);
  const auto [lo, hi] = v.valueRange();
  EXPECT_EQ(lo, -1024.0f);
  EXPECT_EQ(hi, 32767.0f);
}

TEST(Volume, TrilinearSampleIsExactForLinearFunctions) {
  VolumeGeometry g;
  g.dims = {5, 6, 7};
  Volume v(g, ScalarType::Float32);
  auto f = [](double x, double y, double z) { return 2.0 * x - 3.0 * y + 0.5 * z + 7.0; };
  for (int k = 0; k < 7; ++k)
    for (int j = 0; j < 6; ++j)
      for (int i = 0; i < 5; ++i) v.setValue(i, j, k, float(f(i, j, k)));
  for (const Eigen::Vector3d& p : {Eigen::Vector3d(0.3, 4.9, 2.2), Eigen::Vector3d(3.5, 0.5, 5.99), Eigen::Vector3d(4, 5, 6)})
    EXPECT_NEAR(v.sampleLinear(p), f(p.x(), p.y(), p.z()), 1e-4);
  // Outside the grid: clamped to the edge.
  EXPECT_NEAR(v.sampleLinear(Eigen::Vector3d(-3, 0, 0)), f(0, 0, 0), 1e-5);
}
