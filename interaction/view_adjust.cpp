#include "view_adjust.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace handson {

void volumeWorldBox(const VolumeGeometry& g, glm::dvec3& lo, glm::dvec3& hi) {
  lo = glm::dvec3(std::numeric_limits<double>::infinity());
  hi = -lo;
  for (const glm::dvec3& c : volumeBoxCorners(g)) {
    lo = glm::min(lo, c);
    hi = glm::max(hi, c);
  }
}

std::optional<glm::dvec2> projectToPixel(const OrbitCamera& camera, const Viewport& vp, const glm::dvec3& world) {
  const glm::dmat4 pv = glm::dmat4(camera.projection(double(vp.width) / double(vp.height))) * glm::dmat4(camera.view());
  const glm::dvec4 clip = pv * glm::dvec4(world, 1.0);
  if (!(clip.w > 1e-9)) return std::nullopt;
  const glm::dvec2 ndc(clip.x / clip.w, clip.y / clip.w);
  return glm::dvec2((ndc.x + 1.0) * 0.5 * vp.width, (ndc.y + 1.0) * 0.5 * vp.height);
}

glm::dvec3 faceCentre(const glm::dvec3& lo, const glm::dvec3& hi, BoxFace f) {
  glm::dvec3 c = 0.5 * (lo + hi);
  c[f.axis] = f.high ? hi[f.axis] : lo[f.axis];
  return c;
}

namespace {

/// Pixels per millimetre along the face's axis at its centre; nullopt behind the camera or when the
/// axis lies within 35 degrees of the line of sight (the face is seen nearly end-on).
std::optional<glm::dvec2> axisOnScreen(const glm::dvec3& lo, const glm::dvec3& hi, BoxFace f, const OrbitCamera& camera, const Viewport& vp) {
  const glm::dvec3 p = faceCentre(lo, hi, f);
  glm::dvec3 axis(0.0);
  axis[f.axis] = 1.0;
  const glm::dvec3 sight = glm::normalize(p - camera.eye());
  if (!(glm::length(glm::cross(axis, sight)) >= kMinFaceAxisSine)) return std::nullopt;
  const auto a = projectToPixel(camera, vp, p), b = projectToPixel(camera, vp, p + axis);
  if (!a || !b) return std::nullopt;
  return *b - *a;
}

}  // namespace

double faceGrabRadiusPx(const Viewport& vp) { return kFaceGrabFraction * double(std::min(vp.width, vp.height)); }

std::optional<BoxFace> boxFaceNear(const glm::dvec3& lo, const glm::dvec3& hi, const OrbitCamera& camera, const Viewport& vp,
                                   glm::dvec2 px, double radiusPx) {
  std::optional<BoxFace> best;
  double bestDist = radiusPx > 0.0 ? radiusPx : faceGrabRadiusPx(vp);
  for (int axis = 0; axis < 3; ++axis)
    for (bool high : {false, true}) {
      const BoxFace f{axis, high};
      const auto s = axisOnScreen(lo, hi, f, camera, vp);
      const auto c = projectToPixel(camera, vp, faceCentre(lo, hi, f));
      if (!s || !c) continue;
      const double d = glm::length(*c - px);
      if (d <= bestDist) {
        bestDist = d;
        best = f;
      }
    }
  return best;
}

double faceDragMm(const glm::dvec3& lo, const glm::dvec3& hi, BoxFace f, const OrbitCamera& camera, const Viewport& vp, glm::dvec2 deltaPx) {
  const auto s = axisOnScreen(lo, hi, f, camera, vp);
  if (!s) return 0.0;
  const double s2 = glm::dot(*s, *s);
  if (!(s2 > 0.0)) return 0.0;
  const double mm = glm::dot(deltaPx, *s) / s2;
  return std::isfinite(mm) ? mm : 0.0;
}

void moveBoxFace(glm::dvec3& lo, glm::dvec3& hi, BoxFace f, double mm) {
  if (!std::isfinite(mm)) return;
  const int a = f.axis;
  if (f.high) hi[a] = std::max(hi[a] + mm, lo[a] + kMinClipBoxMm);
  else lo[a] = std::min(lo[a] + mm, hi[a] - kMinClipBoxMm);
}

ClipPlaneDrag viewPlaneThrough(const OrbitCamera& camera, const glm::dvec3& point) {
  ClipPlaneDrag p;
  p.normal = camera.forward();
  p.offset = glm::dot(p.normal, point);
  return p;
}

double planeDragMm(const OrbitCamera& camera, const Viewport& vp, glm::dvec2 deltaPx) {
  // Up (negative y) pushes the plane away from the viewer (along the viewing direction).
  return -deltaPx.y * camera.pixelSizeAt(camera.distance, vp.height);
}

WindowLevel windowLevelDrag(const WindowLevel& start, glm::dvec2 deltaPx, double spreadRatio, const Viewport& vp, double width) {
  WindowLevel w = start;
  if (!std::isfinite(deltaPx.x) || !std::isfinite(deltaPx.y)) return w;
  w.scale = std::clamp(start.scale * std::pow(kWindowPerViewportWidth, deltaPx.x / double(std::max(1, vp.width))), kMinWindowScale, kMaxWindowScale);
  if (std::isfinite(width) && width > 0.0) w.shift = start.shift - deltaPx.y / double(std::max(1, vp.height)) * width;
  if (std::isfinite(spreadRatio) && spreadRatio > 0.0) w.opacity = std::clamp(start.opacity * spreadRatio, kMinOpacity, kMaxOpacity);
  return w;
}

}  // namespace handson
