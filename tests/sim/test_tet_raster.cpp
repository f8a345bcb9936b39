#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>

#include "sim/base/error.h"
#include "sim/tet_raster.h"

using namespace handson;

namespace {

// A float image with a smooth pattern, 2 mm voxels, origin off zero.
Volume pattern() {
  VolumeGeometry g;
  g.dims = {40, 36, 30};
  g.spacing = {2, 2, 2};
  g.origin = {-40, -30, -20};
  Volume v(g, ScalarType::Float32);
  for (int k = 0; k < 30; ++k)
    for (int j = 0; j < 36; ++j)
      for (int i = 0; i < 40; ++i) v.setValue(i, j, k, float(100 * std::sin(0.3 * i) + 50 * std::cos(0.2 * j) + 3 * k));
  return v;
}

}  // namespace

TEST(TetRaster, ZeroMotionReproducesTheImage) {
  const Volume src = pattern();
  const KuhnGrid grid({-30, -20, -10}, {5, 5, 5}, {8, 7, 6});
  const TetMesh m = grid.mesh();
  Volume out;
  const auto st = rasterizeDeformed(src, m, m.nodes, {{-30, -20, -10}, {10, 15, 20}, -1000.0f}, out);
  EXPECT_EQ(st.covered, st.regionVoxels);
  EXPECT_GT(st.regionVoxels, 5000u);
  double err = 0;
  for (std::size_t i = 0; i < src.voxelCount(); ++i) err = std::max(err, double(std::abs(out.value(i) - src.value(i))));
  EXPECT_LT(err, 1e-3);  // trilinear at voxel centres is exact up to float rounding
}

TEST(TetRaster, AffineMotionMatchesAnalyticWarpingAndLeavesNoCracks) {
  const Volume src = pattern();
  const KuhnGrid grid({-30, -20, -10}, {5, 5, 5}, {8, 7, 6});
  const TetMesh m = grid.mesh();
  const Eigen::Vector3d c(-10, -2.5, 5);
  const Eigen::Matrix3d A = Eigen::AngleAxisd(0.2, Eigen::Vector3d(0, 0.3, 1).normalized()).toRotationMatrix() * Eigen::Vector3d(1.05, 0.97, 1.0).asDiagonal();
  const Eigen::Vector3d t(2.5, -1.5, 1.0);
  std::vector<Eigen::Vector3d> x(m.nodes.size());
  for (std::size_t i = 0; i < x.size(); ++i) x[i] = c + A * (m.nodes[i] - c) + t;
  Volume out;
  const auto st = rasterizeDeformed(src, m, x, {{-30, -20, -10}, {10, 15, 20}, -1000.0f}, out);
  const auto& g = src.geometry();
  const Eigen::Matrix3d Ainv = A.inverse();
  std::size_t inside = 0;
  double err = 0;
  for (int k = 0; k < g.dims.z(); ++k)
    for (int j = 0; j < g.dims.y(); ++j)
      for (int i = 0; i < g.dims.x(); ++i) {
        const Eigen::Vector3d p = g.toWorld(Eigen::Vector3d(i, j, k));
        const Eigen::Vector3d rest = c + Ainv * (p - t - c);
        // Strictly inside the rest box: covered by the deformed mesh, value from the warped source
        // (where the voxel lies in the region: writes outside it are clipped).
        if ((rest.array() > Eigen::Array3d(-30, -20, -10) + 1e-6).all() && (rest.array() < Eigen::Array3d(10, 15, 20) - 1e-6).all() &&
            inRegion(p, {-30, -20, -10}, {10, 15, 20})) {
          ++inside;
          err = std::max(err, double(std::abs(out.value(i, j, k) - src.sampleLinear(g.toIndex(rest)))));
        }
      }
  EXPECT_GT(inside, 4000u);
  EXPECT_LT(err, 1e-2) << "HU: barycentric interpolation of rest positions is exact for an affine map";
  EXPECT_EQ(st.covered, inside) << "every region voxel inside the deformed mesh written once, none elsewhere";
  // Outside the region the image is untouched, even where the moved mesh went.
  for (int k = 0; k < g.dims.z(); ++k)
    for (int j = 0; j < g.dims.y(); ++j)
      for (int i = 0; i < g.dims.x(); ++i)
        if (!inRegion(g.toWorld(Eigen::Vector3d(i, j, k)), {-30, -20, -10}, {10, 15, 20})) {
          ASSERT_EQ(out.value(i, j, k), src.value(i, j, k));
        }
}

TEST(TetRaster, SmoothDeformationWithFixedBoundaryCoversTheRegionExactly) {
  const Volume src = pattern();
  const KuhnGrid grid({-30, -20, -10}, {5, 5, 5}, {8, 7, 6});
  const TetMesh m = grid.mesh();
  std::vector<Eigen::Vector3d> x = m.nodes;
  for (auto& p : x) {
    const Eigen::Vector3d u = (p - Eigen::Vector3d(-30, -20, -10)).cwiseQuotient(Eigen::Vector3d(40, 35, 30));
    const double bump = std::sin(M_PI * u.x()) * std::sin(M_PI * u.y()) * std::sin(M_PI * u.z());  // zero on the boundary
    p += Eigen::Vector3d(4, -3, 2) * bump;
  }
  Volume out;
  const auto st = rasterizeDeformed(src, m, x, {{-30, -20, -10}, {10, 15, 20}, -1000.0f}, out);
  EXPECT_EQ(st.covered, st.regionVoxels) << "no cracks: every region voxel is covered";
  for (std::size_t i = 0; i < out.voxelCount(); ++i) ASSERT_NE(out.value(i), -1000.0f);
  EXPECT_THROW(rasterizeDeformed(src, m, std::vector<Eigen::Vector3d>(3), {{-30, -20, -10}, {10, 15, 20}, 0.0f}, out), Error);
  x[5].x() = std::nan("");
  EXPECT_THROW(rasterizeDeformed(src, m, x, {{-30, -20, -10}, {10, 15, 20}, 0.0f}, out), Error);
}

namespace {

// A ball of id 5 in the pattern's mask (radius 5 voxels about voxel (16, 16, 14)).
std::vector<std::uint8_t> ballMask(const Volume& src) {
  const auto& d = src.geometry().dims;
  std::vector<std::uint8_t> mask(src.voxelCount(), 0);
  for (int k = 0; k < d.z(); ++k)
    for (int j = 0; j < d.y(); ++j)
      for (int i = 0; i < d.x(); ++i)
        if ((Eigen::Vector3d(i, j, k) - Eigen::Vector3d(16, 16, 14)).norm() <= 5.0) mask[src.linearIndex(i, j, k)] = 5;
  return mask;
}

// Brute force: the value of the voxel outside the ball nearest to voxel v (the first of equally
// near ones, z, y, x ascending), and its distance.
std::pair<float, double> nearestOutside(const Volume& src, const std::vector<std::uint8_t>& mask, const Eigen::Vector3i& v) {
  const auto& d = src.geometry().dims;
  double best = 1e30;
  float value = 0;
  for (int k = 0; k < d.z(); ++k)
    for (int j = 0; j < d.y(); ++j)
      for (int i = 0; i < d.x(); ++i) {
        const double d2 = (Eigen::Vector3i(i, j, k) - v).cast<double>().squaredNorm();
        if (d2 < best && mask[src.linearIndex(i, j, k)] == 0) {
          best = d2;
          value = src.value(i, j, k);
        }
      }
  return {value, std::sqrt(best)};
}

}  // namespace

// The tets at rest and the ball drawn rigidly 2 voxels along +x (what a sliding handle moved with
// the tissue still is): the ball is exactly where its pose puts it, the rim it left takes the
// nearest tissue outside it, and the rest of the image is unchanged.
TEST(TetRaster, AHandleDrawnRigidlyIsWhereItsPoseIsAndTheRimItLeftIsTissue) {
  const Volume src = pattern();
  const auto mask = ballMask(src);
  const KuhnGrid grid({-30, -20, -10}, {5, 5, 5}, {8, 7, 6});
  const TetMesh m = grid.mesh();
  const auto& g = src.geometry();
  RigidTransform T;
  T.t = Eigen::Vector3d(4, 0, 0);  // 2 voxels of 2 mm
  Volume out;
  std::vector<std::uint8_t> outMask;
  std::vector<std::int32_t> tetOf;
  RasterOptions o{&mask, &outMask, UINT64_MAX, &tetOf, rigidDraws(g, {5}, {T})};
  const auto st = rasterizeDeformed(src, m, m.nodes, {{-30, -20, -10}, {10, 15, 20}, -1000.0f}, out, o);
  EXPECT_EQ(st.covered, st.regionVoxels);
  std::size_t drawn = 0, rim = 0;
  for (int k = 0; k < g.dims.z(); ++k)
    for (int j = 0; j < g.dims.y(); ++j)
      for (int i = 0; i < g.dims.x(); ++i) {
        const std::size_t lin = src.linearIndex(i, j, k);
        if (tetOf[lin] == -1) continue;  // outside the region
        const bool ball = i >= 2 && mask[src.linearIndex(i - 2, j, k)] == 5;
        if (ball) {  // the ball, moved: its own voxel's value (integer shift: exact)
          ++drawn;
          ASSERT_EQ(outMask[lin], 5);
          ASSERT_EQ(tetOf[lin], kRigidVoxel);
          ASSERT_NEAR(out.value(lin), src.value(i - 2, j, k), 1e-3);
        } else if (mask[lin] == 5) {  // the rim it left: the tissue nearest to it
          ++rim;
          const auto [value, dist] = nearestOutside(src, mask, {i, j, k});
          ASSERT_LE(dist, 2.0);
          ASSERT_EQ(outMask[lin], 0);
          ASSERT_NEAR(out.value(lin), value, 1e-3);
        } else {
          ASSERT_EQ(outMask[lin], 0);
          ASSERT_NEAR(out.value(lin), src.value(lin), 1e-3);
        }
      }
  EXPECT_EQ(drawn, std::size_t(std::count(mask.begin(), mask.end(), 5)));
  EXPECT_GT(rim, 50u);
}

TEST(TetRaster, HandlesDrawnRigidlyNeedTheMaskAndAnId) {
  const Volume src = pattern();
  const KuhnGrid grid({-30, -20, -10}, {5, 5, 5}, {8, 7, 6});
  const TetMesh m = grid.mesh();
  Volume out;
  EXPECT_THROW(rasterizeDeformed(src, m, m.nodes, {{-30, -20, -10}, {10, 15, 20}, 0.0f}, out, RasterOptions{nullptr, nullptr, UINT64_MAX, nullptr, {RigidDraw{5}}}),
               Error);
  const auto mask = ballMask(src);
  EXPECT_THROW(rasterizeDeformed(src, m, m.nodes, {{-30, -20, -10}, {10, 15, 20}, 0.0f}, out, RasterOptions{&mask, nullptr, UINT64_MAX, nullptr, {RigidDraw{0}}}),
               Error);
  EXPECT_THROW(rigidDraws(src.geometry(), {5, 6}, {RigidTransform{}}), Error);
  EXPECT_THROW(rigidDraws(src.geometry(), {300}, {RigidTransform{}}), Error);
}
