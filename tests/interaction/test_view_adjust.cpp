#include <gtest/gtest.h>

#include <cmath>

#include "interaction/view_adjust.h"

using namespace handson;

namespace {

OrbitCamera camera(double azimuth, double elevation) {
  OrbitCamera c;
  c.target = {0, 0, 0};
  c.distance = 400;
  c.azimuth = azimuth;
  c.elevation = elevation;
  return c;
}

const Viewport kVp{640, 480};
const glm::dvec3 kLo(-50, -40, -30), kHi(50, 40, 30);

}  // namespace

TEST(ViewAdjust, TheTargetProjectsToTheCentreAndPointsBehindTheCameraToNothing) {
  const OrbitCamera c = camera(0.4, 0.3);
  const auto px = projectToPixel(c, kVp, c.target);
  ASSERT_TRUE(px.has_value());
  EXPECT_NEAR(px->x, 320.0, 1e-6);
  EXPECT_NEAR(px->y, 240.0, 1e-6);
  EXPECT_FALSE(projectToPixel(c, kVp, c.eye() - 10.0 * c.forward()).has_value());
}

TEST(ViewAdjust, AFaceDraggedAlongItsAxisStaysUnderTheFinger) {
  // Independent check: after the drag, the moved face's centre projects back under the finger
  // (to 0.3 px: the perspective is not linear over the drag), for every face not seen end-on.
  const OrbitCamera c = camera(0.5, 0.35);
  int faces = 0;
  for (int axis = 0; axis < 3; ++axis)
    for (bool high : {false, true}) {
      const BoxFace f{axis, high};
      const glm::dvec2 start = *projectToPixel(c, kVp, faceCentre(kLo, kHi, f));
      const auto grabbed = boxFaceNear(kLo, kHi, c, kVp, start + glm::dvec2(3.0, -2.0));
      // Faces near end-on are not offered; another face's handle may be nearer.
      if (!grabbed || grabbed->axis != axis || grabbed->high != high) continue;
      ++faces;
      // The finger moves 12 px along the axis' screen direction and 5 px across it.
      glm::dvec3 q = faceCentre(kLo, kHi, f);
      q[axis] += 1.0;
      const glm::dvec2 along = glm::normalize(*projectToPixel(c, kVp, q) - start), across(-along.y, along.x);
      const glm::dvec2 d = 12.0 * along + 5.0 * across;
      glm::dvec3 lo = kLo, hi = kHi;
      moveBoxFace(lo, hi, f, faceDragMm(kLo, kHi, f, c, kVp, d));
      const glm::dvec2 now = *projectToPixel(c, kVp, faceCentre(lo, hi, f));
      EXPECT_NEAR(glm::dot(now - start, along), 12.0, 0.3) << axis << high;
      EXPECT_NEAR(glm::dot(now - start, across), 0.0, 0.3) << axis << high;
      // Only that face moved.
      for (int a = 0; a < 3; ++a) {
        if (!(a == axis && !high)) {
          EXPECT_EQ(lo[a], kLo[a]);
        }
        if (!(a == axis && high)) {
          EXPECT_EQ(hi[a], kHi[a]);
        }
      }
    }
  EXPECT_GE(faces, 3);
}

TEST(ViewAdjust, FacesSeenEndOnAreNotOfferedAndABoxNeverTurnsInsideOut) {
  // From the front (azimuth 0, elevation 0) the y faces are seen end-on: their centres project to
  // the viewport's centre, where no face is offered.
  const OrbitCamera c = camera(0.0, 0.0);
  const auto f = boxFaceNear(kLo, kHi, c, kVp, kVp.center());
  EXPECT_TRUE(!f || f->axis != 1);
  EXPECT_EQ(faceDragMm(kLo, kHi, BoxFace{1, true}, c, kVp, {30.0, 30.0}), 0.0);
  // From the app's default three-quarter view (25 degrees around, 15 up) the front and back faces'
  // axis lies about 30 degrees from the line of sight: they are never offered, anywhere on the screen.
  const OrbitCamera threeQuarter = camera(glm::radians(kDefaultAzimuthDeg), glm::radians(kDefaultElevationDeg));
  int offered = 0;
  for (int y = 0; y < kVp.height; y += 6)
    for (int x = 0; x < kVp.width; x += 6)
      if (const auto g = boxFaceNear(kLo, kHi, threeQuarter, kVp, glm::dvec2(x, y))) {
        ++offered;
        EXPECT_NE(g->axis, 1);
      }
  EXPECT_GT(offered, 0);  // the side, top and bottom faces are
  glm::dvec3 lo = kLo, hi = kHi;
  moveBoxFace(lo, hi, BoxFace{0, true}, -1000.0);
  EXPECT_DOUBLE_EQ(hi.x, lo.x + kMinClipBoxMm);
  moveBoxFace(lo, hi, BoxFace{2, false}, 1e9);
  EXPECT_DOUBLE_EQ(lo.z, hi.z - kMinClipBoxMm);
  moveBoxFace(lo, hi, BoxFace{1, false}, std::nan(""));
  EXPECT_EQ(lo.y, kLo.y);
}

TEST(ViewAdjust, TheViewPlaneKeepsWhatLiesBeyondThePointAndFollowsTheFinger) {
  const OrbitCamera c = camera(-0.7, 0.2);
  const glm::dvec3 p(12, -8, 20);
  const ClipPlaneDrag plane = viewPlaneThrough(c, p);
  EXPECT_NEAR(glm::dot(plane.normal, p), plane.offset, 1e-9);
  EXPECT_LT(glm::dot(plane.normal, c.eye()), plane.offset);                        // the viewer's side is cut
  EXPECT_GT(glm::dot(plane.normal, p + 5.0 * c.forward()), plane.offset);          // beyond is kept
  // Up pushes it away, by one pixel's size at the target's depth per pixel, linearly.
  const double pix = c.pixelSizeAt(c.distance, kVp.height);
  EXPECT_NEAR(planeDragMm(c, kVp, {0.0, -10.0}), 10.0 * pix, 1e-12);
  EXPECT_NEAR(planeDragMm(c, kVp, {7.0, 25.0}), -25.0 * pix, 1e-12);
}

TEST(ViewAdjust, TheWindowGestureMapsMonotonically) {
  const WindowLevel start{1.0, 0.0, 1.0};
  const double width = 400.0;
  double lastShift = std::numeric_limits<double>::infinity(), lastScale = 0.0, lastOpacity = 0.0;
  for (int k = -10; k <= 10; ++k) {
    const WindowLevel byY = windowLevelDrag(start, {0.0, 30.0 * k}, 1.0, kVp, width);
    EXPECT_LT(byY.shift, lastShift) << k;  // down lowers the level
    lastShift = byY.shift;
    EXPECT_EQ(byY.scale, 1.0);
    const WindowLevel byX = windowLevelDrag(start, {40.0 * k, 0.0}, 1.0, kVp, width);
    EXPECT_GT(byX.scale, lastScale) << k;  // right widens the window
    lastScale = byX.scale;
    EXPECT_EQ(byX.shift, 0.0);
    const WindowLevel bySpread = windowLevelDrag(start, {0.0, 0.0}, std::pow(1.2, k), kVp, width);
    EXPECT_GT(bySpread.opacity, lastOpacity) << k;
    lastOpacity = bySpread.opacity;
  }
  // Stated rates: a full viewport height moves the level by the width; a full width is 4x.
  EXPECT_NEAR(windowLevelDrag(start, {0.0, -480.0}, 1.0, kVp, width).shift, width, 1e-9);
  EXPECT_NEAR(windowLevelDrag(start, {640.0, 0.0}, 1.0, kVp, width).scale, kWindowPerViewportWidth, 1e-9);
  // Clamped, and bad input leaves the window unchanged.
  EXPECT_EQ(windowLevelDrag(start, {1e6, 0.0}, 1.0, kVp, width).scale, kMaxWindowScale);
  EXPECT_EQ(windowLevelDrag(start, {0.0, 0.0}, 1e-9, kVp, width).opacity, kMinOpacity);
  EXPECT_EQ(windowLevelDrag(start, {std::nan(""), 3.0}, 1.0, kVp, width), start);
  EXPECT_EQ(windowLevelDrag(start, {0.0, 0.0}, std::nan(""), kVp, width), start);
}
