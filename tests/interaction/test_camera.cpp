#include <gtest/gtest.h>

#include <cmath>
#include <glm/gtc/matrix_transform.hpp>

#include "interaction/camera.h"

using namespace handson;

TEST(OrbitCamera, AzimuthZeroLooksFromTheFrontWithSuperiorUp) {
  OrbitCamera c;
  c.target = {10, 20, 30};
  c.distance = 100;
  EXPECT_NEAR(glm::distance(c.eye(), glm::dvec3(10, 120, 30)), 0.0, 1e-9);
  EXPECT_NEAR(glm::distance(c.up(), glm::dvec3(0, 0, 1)), 0.0, 1e-9);
  // Radiological convention: the patient's right (+x) appears on the viewer's left.
  EXPECT_NEAR(glm::distance(c.right(), glm::dvec3(-1, 0, 0)), 0.0, 1e-9);
}

TEST(OrbitCamera, ProjectionFollowsVulkanConventions) {
  OrbitCamera c;
  c.distance = 100;
  const glm::mat4 vp = c.projection(1.0) * c.view();
  auto ndc = [&](glm::vec3 p) {
    const glm::vec4 h = vp * glm::vec4(p, 1.0f);
    return glm::vec3(h) / h.w;
  };
  EXPECT_NEAR(glm::length(glm::vec2(ndc({0, 0, 0}))), 0.0f, 1e-5f);  // target at the centre
  EXPECT_LT(ndc({0, 0, 10}).y, 0.0f);   // superior is up: NDC y is down
  EXPECT_GT(ndc({-10, 0, 0}).x, 0.0f);  // patient's left (-x) on the viewer's right
  const float z = ndc({0, 0, 0}).z;
  EXPECT_GT(z, 0.0f);
  EXPECT_LT(z, 1.0f);
}

TEST(OrbitCamera, OrbitPanZoomRollAndBadInput) {
  OrbitCamera c;
  c.distance = 200;
  c.orbit(glm::radians(90.0), glm::radians(200.0));
  EXPECT_NEAR(c.elevation, glm::radians(89.0), 1e-9);  // clamped
  EXPECT_NEAR(glm::length(c.eye() - c.target), 200.0, 1e-9);
  const glm::dvec3 before = c.target;
  c.pan(5, -3);
  EXPECT_NEAR(glm::length(c.target - before), std::sqrt(34.0), 1e-9);
  c.zoom(2.0);
  EXPECT_NEAR(c.distance, 100.0, 1e-9);
  c.zoom(-1.0);
  c.zoom(std::nan(""));
  c.orbit(std::nan(""), 0.0);
  c.pan(INFINITY, 0.0);
  EXPECT_NEAR(c.distance, 100.0, 1e-9);
  EXPECT_TRUE(std::isfinite(c.azimuth) && std::isfinite(c.target.x));
  const glm::dvec3 upBefore = c.up();
  c.rotateRoll(glm::radians(90.0));
  EXPECT_NEAR(glm::dot(c.up(), upBefore), 0.0, 1e-9);
  EXPECT_NEAR(glm::dot(c.up(), c.forward()), 0.0, 1e-9);
}

TEST(OrbitCamera, PixelSizeMatchesTheFrustum) {
  OrbitCamera c;
  c.fovY = glm::radians(60.0);
  // At depth d the view is 2 d tan(30 deg) high.
  EXPECT_NEAR(c.pixelSizeAt(100.0, 500), 2.0 * 100.0 * std::tan(glm::radians(30.0)) / 500.0, 1e-12);
}

TEST(OrbitCamera, FramingFitsTheVolume) {
  VolumeGeometry g;
  g.dims = {100, 80, 60};
  g.spacing = {1, 1, 2};
  g.origin = {-50, -40, -60};
  const OrbitCamera c = OrbitCamera::framing(g, 0.3, 0.2);
  const Eigen::Vector3d ctr = g.center();
  EXPECT_NEAR(c.target.x, ctr.x(), 1e-9);
  // The bounding sphere fits in the vertical field of view.
  EXPECT_GE(c.distance * std::sin(0.5 * c.fovY), 0.5 * g.diagonalMm());
  EXPECT_LT(c.nearPlane, c.distance - 0.5 * g.diagonalMm());
  EXPECT_GT(c.farPlane, c.distance + 0.5 * g.diagonalMm());
}
