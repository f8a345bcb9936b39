// Framing a clipped region: the region's vertices against brute force, the camera that shows them
// filling the view, and the animated move between two cameras.
#include <gtest/gtest.h>

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <limits>

#include "interaction/camera_framing.h"

using namespace handson;

namespace {

VolumeGeometry obliqueGrid() {
  VolumeGeometry g;
  g.dims = {40, 30, 20};
  g.spacing = {1.0, 1.5, 2.5};
  g.origin = {-20, -25, -30};
  g.direction = Eigen::AngleAxisd(0.4, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  return g;
}

bool insideAll(const glm::dvec3& p, const std::vector<HalfSpace>& cuts, double tol) {
  return std::all_of(cuts.begin(), cuts.end(), [&](const HalfSpace& h) { return glm::dot(h.normal, p) >= h.offset - tol; });
}

// The index-space point's world position.
glm::dvec3 world(const VolumeGeometry& g, double i, double j, double k) {
  const Eigen::Vector3d p = g.toWorld(Eigen::Vector3d(i, j, k));
  return {p.x(), p.y(), p.z()};
}

}  // namespace

TEST(CameraFraming, WithoutCutsTheRegionIsTheVolumesBox) {
  const VolumeGeometry g = obliqueGrid();
  const std::vector<glm::dvec3> v = clippedVolumeCorners(g, {});
  ASSERT_EQ(v.size(), 8u);
  for (const glm::dvec3& c : volumeBoxCorners(g))
    EXPECT_TRUE(std::any_of(v.begin(), v.end(), [&](const glm::dvec3& p) { return glm::length(p - c) < 1e-9; })) << c.x << "," << c.y << "," << c.z;
}

TEST(CameraFraming, TheClippedRegionsVerticesAreTightAgainstBruteForce) {
  // An oblique grid cut by a box and an oblique plane: every vertex lies in every half-space and in
  // the volume, and the vertices' bounding box is that of the region sampled densely (index steps
  // of 0.25 voxel: the samples reach each extreme within a quarter voxel's diagonal, 0.8 mm here).
  const VolumeGeometry g = obliqueGrid();
  std::vector<HalfSpace> cuts = boxHalfSpaces({-10, -12, -14}, {12, 9, 40});
  cuts.push_back({glm::normalize(glm::dvec3(1, -1, 0.5)), -3.0});
  const std::vector<glm::dvec3> v = clippedVolumeCorners(g, cuts);
  ASSERT_GE(v.size(), 4u);
  glm::dvec3 lo(std::numeric_limits<double>::infinity()), hi(-std::numeric_limits<double>::infinity());
  for (const glm::dvec3& p : v) {
    EXPECT_TRUE(insideAll(p, cuts, 1e-7));
    const Eigen::Vector3d idx = g.toIndex(Eigen::Vector3d(p.x, p.y, p.z));
    for (int a = 0; a < 3; ++a) {
      EXPECT_GE(idx[a], -0.5 - 1e-7);
      EXPECT_LE(idx[a], g.dims[a] - 0.5 + 1e-7);
    }
    lo = glm::min(lo, p);
    hi = glm::max(hi, p);
  }
  glm::dvec3 slo(std::numeric_limits<double>::infinity()), shi(-std::numeric_limits<double>::infinity());
  for (double i = -0.5; i <= g.dims.x() - 0.5; i += 0.25)
    for (double j = -0.5; j <= g.dims.y() - 0.5; j += 0.25)
      for (double k = -0.5; k <= g.dims.z() - 0.5; k += 0.25) {
        const glm::dvec3 p = world(g, i, j, k);
        if (!insideAll(p, cuts, 0.0)) continue;
        slo = glm::min(slo, p);
        shi = glm::max(shi, p);
      }
  for (int a = 0; a < 3; ++a) {
    EXPECT_LE(lo[a], slo[a] + 1e-9);  // no sample outside the vertices' box
    EXPECT_GE(hi[a], shi[a] - 1e-9);
    EXPECT_NEAR(lo[a], slo[a], 0.8);  // and the box is tight
    EXPECT_NEAR(hi[a], shi[a], 0.8);
  }
}

TEST(CameraFraming, ACutThatLeavesNothingGivesNoRegionAndABadCutIsIgnored) {
  const VolumeGeometry g = obliqueGrid();
  EXPECT_TRUE(clippedVolumeCorners(g, {{glm::dvec3(0, 0, 1), 1e4}}).empty());
  EXPECT_TRUE(clippedVolumeCorners(g, boxHalfSpaces({500, 500, 500}, {600, 600, 600})).empty());
  EXPECT_EQ(clippedVolumeCorners(g, {{glm::dvec3(0.0), 5.0}, {glm::dvec3(std::nan(""), 0, 0), 0.0}}).size(), 8u);
}

TEST(CameraFraming, TheFramedRegionIsCentredAndFillsTheViewFromTheSameDirection) {
  // A small clip box in a large volume, seen from a three-quarter view in a wide window with a
  // panel on the left: the box's projection is centred in the free area and fills 92 % of its
  // tighter dimension (the fixed point's tolerance, 1e-4 relative), so at least 60 % of the
  // view's shorter side; the camera's direction and roll are kept.
  VolumeGeometry g;
  g.dims = {256, 256, 120};
  g.spacing = {0.8, 0.8, 2.0};
  g.origin = {-102, -102, -120};
  OrbitCamera from = OrbitCamera::framing(g, 0.7, 0.3, 1.6);
  from.roll = 0.2;
  const std::vector<glm::dvec3> v = clippedVolumeCorners(g, boxHalfSpaces({20, -40, -60}, {60, 0, -20}));
  ASSERT_EQ(v.size(), 8u);
  const FramingView view{1280, 800, ScreenArea{0.2, 0.0, 1.0, 1.0}, 0.92, g.diagonalMm()};
  const OrbitCamera c = framePoints(from, v, view);
  EXPECT_DOUBLE_EQ(c.azimuth, from.azimuth);
  EXPECT_DOUBLE_EQ(c.elevation, from.elevation);
  EXPECT_DOUBLE_EQ(c.roll, from.roll);
  const auto b = projectedPointsBox(c, v, 1280, 800);
  ASSERT_TRUE(b.has_value());
  EXPECT_NEAR(0.5 * ((*b)[0] + (*b)[2]), 0.6 * 1280, 0.2);
  EXPECT_NEAR(0.5 * ((*b)[1] + (*b)[3]), 400.0, 0.2);
  const double fill = std::max(((*b)[2] - (*b)[0]) / (0.8 * 1280), ((*b)[3] - (*b)[1]) / 800.0);
  EXPECT_NEAR(fill, 0.92, 1e-3);
  EXPECT_GE(std::max((*b)[2] - (*b)[0], (*b)[3] - (*b)[1]), 0.6 * 800);
  // The region lies between the near and far planes.
  for (const glm::dvec3& p : v) {
    const double depth = glm::dot(p - c.eye(), c.forward());
    EXPECT_GT(depth, c.nearPlane);
    EXPECT_LT(depth, c.farPlane);
  }
  // Nothing to frame: the camera as it was.
  EXPECT_EQ(framePoints(from, {}, view).distance, from.distance);
}

TEST(CameraFraming, TheCameraMoveEasesFromOneFramingToTheOtherTheShortWayRound) {
  OrbitCamera a, b;
  a.target = {0, 0, 0};
  b.target = {10, -20, 30};
  a.distance = 400.0;
  b.distance = 100.0;
  a.azimuth = glm::radians(170.0);
  b.azimuth = glm::radians(-170.0);
  a.elevation = 0.1;
  b.elevation = 0.5;
  const CameraMove move{a, b, 2.0, 0.4};
  EXPECT_EQ(move.at(1.0).distance, a.distance);
  EXPECT_EQ(move.at(2.0).distance, a.distance);
  EXPECT_EQ(move.at(2.4).target, b.target);  // exactly the end once the time is up
  EXPECT_EQ(move.at(9.0).azimuth, b.azimuth);
  EXPECT_FALSE(move.done(2.39));
  EXPECT_TRUE(move.done(2.4));
  const OrbitCamera mid = move.at(2.2);  // smoothstep(0.5) = 0.5
  EXPECT_NEAR(mid.distance, 200.0, 1e-9);  // the geometric mean: a steady zoom
  EXPECT_NEAR(std::abs(mid.azimuth), glm::radians(180.0), 1e-9);  // through 180 degrees, not 0
  EXPECT_NEAR(mid.elevation, 0.3, 1e-12);
  EXPECT_NEAR(glm::length(mid.target - glm::dvec3(5, -10, 15)), 0.0, 1e-9);
  // Monotone in between: the distance only falls.
  double last = a.distance;
  for (double t = 2.0; t <= 2.4; t += 0.01) {
    EXPECT_LE(move.at(t).distance, last + 1e-9);
    last = move.at(t).distance;
  }
}
