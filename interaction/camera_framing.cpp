#include "interaction/camera_framing.h"

#include <Eigen/Dense>

#include <algorithm>
#include <cmath>
#include <limits>

namespace handson {

namespace {

constexpr double kPi = 3.14159265358979323846;

/// The pixel box of the points (lo, hi); false when one lies behind the near plane.
bool pixelBox(const OrbitCamera& c, const std::vector<glm::dvec3>& points, int w, int h, glm::dvec2& lo, glm::dvec2& hi) {
  const glm::dmat4 pv = glm::dmat4(c.projection(double(w) / double(h))) * glm::dmat4(c.view());
  lo = glm::dvec2(std::numeric_limits<double>::infinity());
  hi = -lo;
  for (const glm::dvec3& p : points) {
    const glm::dvec4 q = pv * glm::dvec4(p, 1.0);
    if (!(q.w > c.nearPlane)) return false;
    const glm::dvec2 px((q.x / q.w + 1.0) * 0.5 * w, (q.y / q.w + 1.0) * 0.5 * h);
    lo = glm::min(lo, px);
    hi = glm::max(hi, px);
  }
  return !points.empty();
}

/// An angle's difference b - a the short way round, in (-pi, pi].
double shortWay(double a, double b) { return std::remainder(b - a, 2.0 * kPi); }

}  // namespace

std::vector<HalfSpace> boxHalfSpaces(const glm::dvec3& lo, const glm::dvec3& hi) {
  std::vector<HalfSpace> h;
  for (int axis = 0; axis < 3; ++axis) {
    glm::dvec3 n(0.0);
    n[axis] = 1.0;
    h.push_back({n, lo[axis]});     // x_axis >= lo
    h.push_back({-n, -hi[axis]});   // x_axis <= hi
  }
  return h;
}

std::vector<glm::dvec3> clippedVolumeCorners(const VolumeGeometry& geometry, const std::vector<HalfSpace>& cuts) {
  // In index space the volume's box is axis-aligned (-0.5 .. dims - 0.5) and a world half-space
  // n.x >= d, with x = A i + b (A 3x3, b 3x1: the index-to-world map), is (A^T n).i >= d - n.b.
  const Eigen::Matrix4d indexToWorld = geometry.indexToWorld();
  const Eigen::Matrix3d A = indexToWorld.block<3, 3>(0, 0);
  const Eigen::Vector3d b = indexToWorld.block<3, 1>(0, 3);
  struct Plane {
    Eigen::Vector3d n;
    double d;
  };
  std::vector<Plane> planes;
  for (int k = 0; k < 3; ++k) {
    planes.push_back({Eigen::Vector3d::Unit(k), -0.5});
    planes.push_back({-Eigen::Vector3d::Unit(k), -(double(geometry.dims[k]) - 0.5)});
  }
  for (const HalfSpace& c : cuts) {
    const Eigen::Vector3d n(c.normal.x, c.normal.y, c.normal.z);
    const double len = n.norm();
    if (!(len > 0.0) || !std::isfinite(len) || !std::isfinite(c.offset)) continue;
    const Eigen::Vector3d ni = A.transpose() * (n / len);  // in index space, scaled by the spacing
    planes.push_back({ni, (c.offset - n.dot(b)) / len});
  }
  // Every three planes meeting in one point; kept when no half-space is violated by more than
  // 1e-9 of a voxel (times its normal's length: the tolerance is a distance).
  std::vector<glm::dvec3> out;
  const std::size_t m = planes.size();
  for (std::size_t i = 0; i < m; ++i)
    for (std::size_t j = i + 1; j < m; ++j)
      for (std::size_t k = j + 1; k < m; ++k) {
        Eigen::Matrix3d M;
        M << planes[i].n.transpose(), planes[j].n.transpose(), planes[k].n.transpose();
        const Eigen::FullPivLU<Eigen::Matrix3d> lu(M);
        if (!lu.isInvertible()) continue;
        const Eigen::Vector3d p = lu.solve(Eigen::Vector3d(planes[i].d, planes[j].d, planes[k].d));
        const bool inside = std::all_of(planes.begin(), planes.end(), [&](const Plane& q) { return q.n.dot(p) >= q.d - 1e-9 * (1.0 + q.n.norm()); });
        if (!inside || !p.allFinite()) continue;
        const Eigen::Vector3d w = A * p + b;
        out.emplace_back(w.x(), w.y(), w.z());
      }
  return out;
}

std::optional<std::array<double, 4>> projectedPointsBox(const OrbitCamera& camera, const std::vector<glm::dvec3>& points, int width, int height) {
  glm::dvec2 lo, hi;
  if (!pixelBox(camera, points, std::max(width, 1), std::max(height, 1), lo, hi)) return std::nullopt;
  return std::array<double, 4>{lo.x, lo.y, hi.x, hi.y};
}

OrbitCamera fitPointsFrom(OrbitCamera c, const std::vector<glm::dvec3>& points, const FramingView& view) {
  if (points.empty()) return c;
  const int w = std::max(view.width, 1), h = std::max(view.height, 1);
  const ScreenArea& area = view.area;
  const glm::dvec2 want((area.x1 - area.x0) * w * view.fill, (area.y1 - area.y0) * h * view.fill);
  const glm::dvec2 centre(0.5 * (area.x0 + area.x1) * w, 0.5 * (area.y0 + area.y1) * h);
  for (int round = 0; round < 60; ++round) {
    glm::dvec2 lo, hi;
    if (!pixelBox(c, points, w, h, lo, hi)) {
      c.distance *= 1.5;  // a corner behind the eye: back off and try again
    } else {
      const double k = std::max((hi.x - lo.x) / want.x, (hi.y - lo.y) / want.y);
      const glm::dvec2 off = centre - 0.5 * (lo + hi);  // where the box's centre must move on screen
      const double pix = c.pixelSizeAt(c.distance, h);
      // Content moves right when the target moves left, down when the target moves up.
      c.target += -c.right() * (off.x * pix) + c.up() * (off.y * pix);
      c.distance *= std::clamp(k, 0.5, 2.0);
      if (std::abs(k - 1.0) < 1e-4 && glm::length(off) < 1e-4 * h) break;
    }
    c.nearPlane = std::max(1e-3, 0.01 * c.distance);
    c.farPlane = c.distance + 2.0 * view.sceneDiagonalMm;
  }
  c.maxDistance = std::max(c.maxDistance, 2.0 * c.distance);
  return c;
}

OrbitCamera framePoints(const OrbitCamera& from, const std::vector<glm::dvec3>& points, const FramingView& view) {
  if (points.empty() || !view.area.valid() || !(view.fill > 0.0 && view.fill <= 1.0)) return from;
  // Start from the points' bounding sphere (about its box's centre) seen whole, then fit.
  glm::dvec3 lo(std::numeric_limits<double>::infinity()), hi(-std::numeric_limits<double>::infinity());
  for (const glm::dvec3& p : points) {
    lo = glm::min(lo, p);
    hi = glm::max(hi, p);
  }
  // A region without extent (a plane through a corner leaves a point or an edge) has no framing.
  if (!(glm::length(hi - lo) > 1e-3)) return from;
  OrbitCamera c = from;
  c.target = 0.5 * (lo + hi);
  const double radius = std::max(0.5 * glm::length(hi - lo), 1e-3);
  const double aspect = double(std::max(view.width, 1)) / double(std::max(view.height, 1));
  const double halfFov = 0.5 * std::min(c.fovY, 2.0 * std::atan(std::tan(0.5 * c.fovY) * aspect));
  c.distance = radius / std::sin(halfFov) * 1.02;
  c.nearPlane = std::max(1e-3, 0.01 * c.distance);
  c.farPlane = c.distance + 2.0 * std::max(view.sceneDiagonalMm, radius);
  c = fitPointsFrom(c, points, view);
  c.minDistance = std::min(c.minDistance, 0.5 * c.distance);
  return c;
}

OrbitCamera blendCameras(const OrbitCamera& a, const OrbitCamera& b, double s) {
  if (!(s > 0.0)) return a;
  if (s >= 1.0) return b;
  const double e = s * s * (3.0 - 2.0 * s);  // smoothstep: starts and ends at rest
  OrbitCamera c = b;
  c.target = a.target + (b.target - a.target) * e;
  c.distance = a.distance * std::pow(b.distance / a.distance, e);  // zooms at a steady rate
  c.azimuth = std::remainder(a.azimuth + shortWay(a.azimuth, b.azimuth) * e, 2.0 * kPi);
  c.elevation = a.elevation + (b.elevation - a.elevation) * e;
  c.roll = std::remainder(a.roll + shortWay(a.roll, b.roll) * e, 2.0 * kPi);
  c.nearPlane = std::min(a.nearPlane, b.nearPlane);
  c.farPlane = std::max(a.farPlane, b.farPlane);
  return c;
}

OrbitCamera CameraMove::at(double t) const {
  if (done(t) || !(seconds > 0.0)) return to;
  return blendCameras(from, to, (t - start) / seconds);
}

}  // namespace handson
