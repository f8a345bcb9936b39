#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>

#include "sim/base/error.h"
#include "sim/resample.h"

using namespace handson;

namespace {
Volume linearRamp(ScalarType type) {
  VolumeGeometry g;
  g.dims = {40, 30, 20};
  g.spacing = {0.8, 1.1, 2.0};
  g.origin = {5, -3, 10};
  g.direction = Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  Volume v(g, type);
  for (int k = 0; k < 20; ++k)
    for (int j = 0; j < 30; ++j)
      for (int i = 0; i < 40; ++i) {
        const Eigen::Vector3d w = g.toWorld(Eigen::Vector3d(i, j, k));
        v.setValue(i, j, k, float(0.5 * w.x() + 0.25 * w.y() - w.z()));
      }
  return v;
}
}  // namespace

TEST(Resample, GeometryKeepsTheBoxAndHitsTheTarget) {
  const Volume v = linearRamp(ScalarType::Float32);
  const VolumeGeometry r = resampledGeometry(v.geometry(), 3000);
  EXPECT_NEAR(double(r.voxelCount()), 3000.0, 3000.0 * 0.15);
  for (int a = 0; a < 3; ++a) EXPECT_NEAR(r.dims[a] * r.spacing[a], v.dims()[a] * v.geometry().spacing[a], 1e-9);
  // Same box corner.
  const Eigen::Vector3d c0 = v.geometry().toWorld(Eigen::Vector3d::Constant(-0.5));
  const Eigen::Vector3d c1 = r.toWorld(Eigen::Vector3d::Constant(-0.5));
  EXPECT_LT((c0 - c1).norm(), 1e-9);
  EXPECT_THROW(resampledGeometry(v.geometry(), 0), Error);
}

TEST(Resample, LinearFieldsSurviveDownAndUpsampling) {
  // Trilinear interpolation and box averaging both reproduce a linear field exactly away from
  // the clamped border, so the resampled value equals the field at the new voxel centre.
  const Volume v = linearRamp(ScalarType::Float32);
  for (std::size_t target : {std::size_t(3000), std::size_t(60000)}) {
    const Volume r = resampleToVoxelCount(v, target);
    const auto& g = r.geometry();
    int checked = 0;
    for (int k = 1; k < g.dims.z() - 1; ++k)
      for (int j = 1; j < g.dims.y() - 1; ++j)
        for (int i = 1; i < g.dims.x() - 1; ++i) {
          const Eigen::Vector3d w = g.toWorld(Eigen::Vector3d(i, j, k));
          const Eigen::Vector3d src = v.geometry().toIndex(w);
          // Skip voxels whose footprint reaches the clamped edge of the input.
          const Eigen::Vector3d margin = (g.spacing.array() / v.geometry().spacing.array()).matrix() * 0.5 + Eigen::Vector3d::Ones();
          if ((src.array() < margin.array()).any() || (src.array() > (v.dims().cast<double>() - Eigen::Vector3d::Ones() - margin).array()).any())
            continue;
          EXPECT_NEAR(r.value(i, j, k), 0.5 * w.x() + 0.25 * w.y() - w.z(), 1e-3);
          ++checked;
        }
    EXPECT_GT(checked, 10) << target;
  }
}

TEST(Resample, LabelsUseNearestNeighbourAndKeepTheirType) {
  VolumeGeometry g;
  g.dims = {16, 16, 16};
  Volume labels(g, ScalarType::UInt8);
  for (int k = 0; k < 16; ++k)
    for (int j = 0; j < 16; ++j)
      for (int i = 0; i < 16; ++i) labels.setValue(i, j, k, i < 8 ? 3.0f : 11.0f);
  const Volume r = resampleToVoxelCount(labels, 512);
  EXPECT_EQ(r.type(), ScalarType::UInt8);
  for (std::size_t n = 0; n < r.voxelCount(); ++n) {
    const float l = r.value(n);
    EXPECT_TRUE(l == 3.0f || l == 11.0f);
  }
}
