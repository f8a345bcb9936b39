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

TEST(OrbitCamera, FramingInPartOfTheViewCentresTheBoxThereAndFillsIt) {
  // An oblique, anisotropic grid: the projected box's centre lands on the area's centre and its
  // tighter dimension fills 92 % of it (the fixed point's stated tolerance: 1e-4 relative).
  VolumeGeometry g;
  g.dims = {100, 80, 60};
  g.spacing = {1, 1.5, 2};
  g.origin = {-50, -40, -60};
  g.direction = Eigen::AngleAxisd(0.3, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  const ScreenArea area{0.02, 0.2, 0.65, 0.85};
  const int w = 1200, h = 760;
  const OrbitCamera c = OrbitCamera::framingIn(g, 0.4, 0.25, FramingView{w, h, area});
  EXPECT_NEAR(c.azimuth, 0.4, 1e-12);
  EXPECT_NEAR(c.elevation, 0.25, 1e-12);
  const auto b = projectedVolumeBox(c, g, w, h);
  ASSERT_TRUE(b.has_value());
  EXPECT_NEAR(0.5 * ((*b)[0] + (*b)[2]), 0.5 * (area.x0 + area.x1) * w, 0.2);
  EXPECT_NEAR(0.5 * ((*b)[1] + (*b)[3]), 0.5 * (area.y0 + area.y1) * h, 0.2);
  const double fill = std::max(((*b)[2] - (*b)[0]) / ((area.x1 - area.x0) * w), ((*b)[3] - (*b)[1]) / ((area.y1 - area.y0) * h));
  EXPECT_NEAR(fill, 0.92, 1e-3);
  // The whole view, or a degenerate area, is the classic framing.
  EXPECT_EQ(OrbitCamera::framingIn(g, 0.4, 0.25, FramingView{w, h, ScreenArea{0.5, 0.5, 0.5, 0.9}}).distance, OrbitCamera::framing(g, 0.4, 0.25, double(w) / h).distance);
}

TEST(OrbitCamera, TheLargestFreeAreaAvoidsEveryPanelAndBeatsABruteForceSearch) {
  // A top bar, a right panel and a bottom-left overlay in a 1000 x 600 view.
  const std::vector<std::array<double, 4>> panels{{10, 10, 600, 150}, {780, 160, 990, 470}, {10, 520, 400, 590}};
  const int w = 1000, h = 600;
  for (double aspect : {0.5, 1.0, 1.6}) {
    const ScreenArea a = largestFreeArea(w, h, panels, aspect, 8.0);
    ASSERT_TRUE(a.valid()) << aspect;
    const double x0 = a.x0 * w, y0 = a.y0 * h, x1 = a.x1 * w, y1 = a.y1 * h;
    for (const auto& p : panels) EXPECT_FALSE(x0 < p[2] + 8 - 1e-9 && x1 > p[0] - 8 + 1e-9 && y0 < p[3] + 8 - 1e-9 && y1 > p[1] - 8 + 1e-9);
    // Independent: every rectangle on a 10 px grid that clears the panels by 8 px holds no bigger box.
    const double found = std::min(x1 - x0, (y1 - y0) * aspect);
    double grid = 0.0;
    for (int gx0 = 10; gx0 < w; gx0 += 10)
      for (int gx1 = gx0 + 10; gx1 <= w - 10; gx1 += 10)
        for (int gy0 = 10; gy0 < h; gy0 += 10)
          for (int gy1 = gy0 + 10; gy1 <= h - 10; gy1 += 10) {
            const double size = std::min(double(gx1 - gx0), (gy1 - gy0) * aspect);
            if (size <= grid) continue;
            bool clear = true;
            for (const auto& p : panels) clear &= !(gx0 < p[2] + 8 && gx1 > p[0] - 8 && gy0 < p[3] + 8 && gy1 > p[1] - 8);
            if (clear) grid = size;
          }
    EXPECT_GE(found, grid - 1e-9) << aspect;
    EXPECT_LE(found, grid + 10.0 * std::max(1.0, aspect)) << aspect;
  }
  // Nothing fits: the whole view.
  EXPECT_TRUE(largestFreeArea(w, h, {{0, 0, 1000, 600}}, 1.0).whole());
}
