#include <gtest/gtest.h>

#include <Eigen/Geometry>

#include <cmath>
#include <vector>

#include "interaction/manipulation.h"

using namespace handson;

namespace {

// NDC (x right, y down) of a world point for the camera.
glm::dvec2 ndc(const OrbitCamera& c, double aspect, const Eigen::Vector3d& x) {
  const glm::dmat4 m = glm::dmat4(c.projection(aspect)) * glm::dmat4(c.view());
  const glm::dvec4 h = m * glm::dvec4(x.x(), x.y(), x.z(), 1.0);
  return glm::dvec2(h) / h.w;
}

OrbitCamera camera() {
  OrbitCamera c;
  c.target = {10, -5, 20};
  c.distance = 450;
  c.azimuth = 0.4;
  c.elevation = 0.25;
  c.roll = 0.1;
  return c;
}

}  // namespace

TEST(HandleManipulator, PointsFollowTheFingersAndPosesCompose) {
  const OrbitCamera cam = camera();
  const double aspect = 1.4;
  // A handle already moved once; its rest-frame points.
  RigidTransform pose;
  pose.R = Eigen::AngleAxisd(0.2, Eigen::Vector3d(0, 0, 1)).toRotationMatrix();
  pose.t = Eigen::Vector3d(3, -2, 1);
  const std::vector<Eigen::Vector3d> rest = {{0, 0, 0}, {40, 0, 10}, {0, 35, -10}};
  for (std::size_t n : {1u, 2u, 3u}) {
    HandleManipulator m;
    std::vector<FingerAnchor> anchors;
    for (std::size_t i = 0; i < n; ++i) anchors.push_back({std::int64_t(i), pose.apply(rest[i])});
    m.anchor(anchors, pose);
    EXPECT_EQ(m.fingerCount(), n);
    // The fingers slide by a few pixels; the handle's anchored points must end up under them.
    std::vector<std::pair<std::int64_t, glm::dvec2>> fingers;
    for (std::size_t i = 0; i < n; ++i) fingers.push_back({std::int64_t(i), ndc(cam, aspect, pose.apply(rest[i])) + glm::dvec2(0.01, -0.006 * double(i))});
    std::string why;
    const auto next = m.move(fingers, pose, cam, aspect, kLockNone, &why);
    ASSERT_TRUE(next.has_value()) << why;
    for (std::size_t i = 0; i < n; ++i)
      EXPECT_LT(glm::length(ndc(cam, aspect, next->apply(rest[i])) - fingers[i].second), 2e-4) << n << " fingers";  // 0.05 px at 500 px
    EXPECT_LT((next->R * next->R.transpose() - Eigen::Matrix3d::Identity()).norm(), 1e-12);
    if (n == 1) {
      // One finger: a translation parallel to the screen, no rotation, no depth change.
      EXPECT_LT((next->R - pose.R).norm(), 1e-12);
      const glm::dvec3 f = cam.forward();
      EXPECT_NEAR((next->t - pose.t).dot(Eigen::Vector3d(f.x, f.y, f.z)), 0.0, 1e-9);
    }
  }
}

TEST(HandleManipulator, RefusesWithoutAnchorsOrWithAMissingFinger) {
  const OrbitCamera cam = camera();
  HandleManipulator m;
  std::string why;
  EXPECT_FALSE(m.move({{0, {0, 0}}}, RigidTransform{}, cam, 1.0, kLockNone, &why));
  EXPECT_NE(why.find("anchored"), std::string::npos);
  m.anchor({{7, Eigen::Vector3d(0, 0, 0)}}, RigidTransform{});
  EXPECT_FALSE(m.move({{8, {0, 0}}}, RigidTransform{}, cam, 1.0, kLockNone, &why));
  EXPECT_FALSE(m.move({{7, {std::nan(""), 0}}}, RigidTransform{}, cam, 1.0, kLockNone, &why));
  m.release();
  EXPECT_FALSE(m.active());
}

TEST(HandleManipulator, AFingerAnchorsOnTheHandlesOwnVoxelsNearThePickedSurface) {
  // A ball handle (id 3, radius 6 mm about (20, 20, 20) on a 40^3 grid of 1 mm voxels) moved by a
  // turn and a translation. A ray through the moved ball's centre meets its surface 6 mm before the
  // centre (to within a voxel's rounding); a pick up to the window off that surface, in front
  // (blur) or behind it, anchors there; outside the window, or on a ray that misses the ball, it
  // does not.
  VolumeGeometry g;
  g.dims = {40, 40, 40};
  g.spacing = {1, 1, 1};
  std::vector<std::uint8_t> mask(g.voxelCount(), 0);
  const Eigen::Vector3d centre(20, 20, 20);
  for (int k = 0; k < 40; ++k)
    for (int j = 0; j < 40; ++j)
      for (int i = 0; i < 40; ++i)
        if ((Eigen::Vector3d(i, j, k) - centre).norm() <= 6.0) mask[std::size_t(i + 40 * (j + 40 * k))] = 3;
  const RigidTransform pose = RigidTransform::about(centre, Eigen::Vector3d(0.3, -0.2, 0.5), Eigen::Vector3d(4, -3, 2));
  const Eigen::Vector3d moved = pose.apply(centre);
  const Eigen::Vector3d dir = Eigen::Vector3d(1, 2, -0.5).normalized();
  const Eigen::Vector3d eye = moved - 300.0 * dir, surface = moved - 6.0 * dir;
  for (double off : {-4.0, -1.0, 0.0, 2.5, 4.0}) {
    const auto c = contactOnHandle(g, mask, 3, pose, {eye, surface + off * dir, 5.0});
    ASSERT_TRUE(c.has_value()) << off;
    // The first sample whose nearest voxel is in the ball: within a voxel's half-diagonal (0.87)
    // plus a half step of the true surface, and never behind it by more than that.
    EXPECT_NEAR((*c - eye).dot(dir), (surface - eye).dot(dir), 0.87 + 0.5) << off;
    EXPECT_LT((*c - moved).cross(dir).norm(), 1e-9) << "on the finger's ray";
  }
  EXPECT_FALSE(contactOnHandle(g, mask, 3, pose, {eye, surface - 8.0 * dir, 5.0})) << "the handle lies beyond the window";
  EXPECT_FALSE(contactOnHandle(g, mask, 4, pose, {eye, surface, 5.0})) << "another handle's id";
  const Eigen::Vector3d side = moved + 10.0 * dir.cross(Eigen::Vector3d::UnitZ()).normalized();
  EXPECT_FALSE(contactOnHandle(g, mask, 3, pose, {side - 300.0 * dir, side, 5.0})) << "a ray beside the ball";
  EXPECT_FALSE(contactOnHandle(g, mask, 3, pose, {surface, surface, 5.0})) << "eye on the pick";
  EXPECT_FALSE(contactOnHandle(g, mask, 3, pose, {eye, Eigen::Vector3d(std::nan(""), 0, 0), 5.0}));
  EXPECT_FALSE(contactOnHandle(g, mask, 3, pose, {eye, surface, -1.0}));
  EXPECT_FALSE(contactOnHandle(g, std::vector<std::uint8_t>(10, 3), 3, pose, {eye, surface, 5.0})) << "a mask that does not fit the grid";
}
