#include <gtest/gtest.h>

#include <Eigen/Geometry>

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
