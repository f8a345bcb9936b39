#include "camera.h"

#include "interaction/camera_framing.h"

#include <array>
#include <limits>
#include <optional>

#include <algorithm>
#include <cmath>
#include <glm/gtc/matrix_transform.hpp>

namespace handson {

namespace {
constexpr double kMaxElevation = 89.0 * 3.14159265358979323846 / 180.0;

bool finite(double v) { return std::isfinite(v); }
}  // namespace

glm::dvec3 OrbitCamera::eye() const {
  const double ce = std::cos(elevation);
  return target + distance * glm::dvec3(ce * std::sin(azimuth), ce * std::cos(azimuth), std::sin(elevation));
}

glm::dvec3 OrbitCamera::forward() const { return glm::normalize(target - eye()); }

glm::dvec3 OrbitCamera::up() const {
  const glm::dvec3 f = forward();
  const glm::dvec3 worldUp(0, 0, 1);
  const glm::dvec3 r0 = glm::normalize(glm::cross(f, worldUp));
  const glm::dvec3 u0 = glm::cross(r0, f);
  return std::cos(roll) * u0 + std::sin(roll) * r0;
}

glm::dvec3 OrbitCamera::right() const { return glm::normalize(glm::cross(forward(), up())); }

glm::mat4 OrbitCamera::view() const { return glm::mat4(glm::lookAtRH(eye(), target, up())); }

glm::mat4 OrbitCamera::projection(double aspect) const {
  glm::dmat4 p = glm::perspectiveRH_ZO(fovY, aspect, nearPlane, farPlane);
  p[1][1] *= -1.0;  // Vulkan NDC: y down
  return glm::mat4(p);
}

void OrbitCamera::orbit(double dAzimuth, double dElevation) {
  if (!finite(dAzimuth) || !finite(dElevation)) return;
  azimuth = std::remainder(azimuth + dAzimuth, 2.0 * 3.14159265358979323846);
  elevation = std::clamp(elevation + dElevation, -kMaxElevation, kMaxElevation);
}

void OrbitCamera::pan(double dxMm, double dyMm) {
  if (!finite(dxMm) || !finite(dyMm)) return;
  target += right() * dxMm + up() * dyMm;
}

void OrbitCamera::zoom(double factor) {
  if (!finite(factor) || factor <= 0.0) return;
  distance = std::clamp(distance / factor, minDistance, maxDistance);
}

void OrbitCamera::rotateRoll(double dRoll) {
  if (!finite(dRoll)) return;
  roll = std::remainder(roll + dRoll, 2.0 * 3.14159265358979323846);
}

double OrbitCamera::pixelSizeAt(double depthMm, int viewportHeightPx) const {
  return 2.0 * depthMm * std::tan(0.5 * fovY) / double(std::max(viewportHeightPx, 1));
}

OrbitCamera OrbitCamera::framing(const VolumeGeometry& geometry, double azimuth, double elevation, double aspect) {
  OrbitCamera c;
  const Eigen::Vector3d ctr = geometry.center();
  c.target = glm::dvec3(ctr.x(), ctr.y(), ctr.z());
  const double radius = 0.5 * geometry.diagonalMm();
  const double halfFov = 0.5 * std::min(c.fovY, 2.0 * std::atan(std::tan(0.5 * c.fovY) * std::max(aspect, 1e-3)));
  c.distance = radius / std::sin(halfFov) * 1.02;
  c.azimuth = azimuth;
  c.elevation = std::clamp(elevation, -kMaxElevation, kMaxElevation);
  c.nearPlane = std::max(1e-3, 0.01 * c.distance);
  c.farPlane = c.distance + 4.0 * radius;
  c.minDistance = 0.05 * radius;
  c.maxDistance = 20.0 * radius + c.distance;
  return c;
}

std::array<glm::dvec3, 8> volumeBoxCorners(const VolumeGeometry& geometry) {
  std::array<glm::dvec3, 8> corners;
  for (int k = 0; k < 8; ++k) {
    const Eigen::Vector3d idx((k & 1) ? geometry.dims.x() - 0.5 : -0.5, (k & 2) ? geometry.dims.y() - 0.5 : -0.5,
                              (k & 4) ? geometry.dims.z() - 0.5 : -0.5);
    const Eigen::Vector3d p = geometry.toWorld(idx);
    corners[std::size_t(k)] = {p.x(), p.y(), p.z()};
  }
  return corners;
}

std::optional<std::array<double, 4>> projectedVolumeBox(const OrbitCamera& camera, const VolumeGeometry& geometry, int width, int height) {
  const std::array<glm::dvec3, 8> corners = volumeBoxCorners(geometry);
  return projectedPointsBox(camera, std::vector<glm::dvec3>(corners.begin(), corners.end()), width, height);
}

OrbitCamera OrbitCamera::framingIn(const VolumeGeometry& geometry, double azimuth, double elevation, const FramingView& view) {
  const int w = std::max(view.width, 1), h = std::max(view.height, 1);
  const OrbitCamera c = framing(geometry, azimuth, elevation, double(w) / double(h));
  if (!view.area.valid() || !(view.fill > 0.0 && view.fill <= 1.0)) return c;
  const std::array<glm::dvec3, 8> corners = volumeBoxCorners(geometry);
  return fitPointsFrom(c, std::vector<glm::dvec3>(corners.begin(), corners.end()), FramingView{w, h, view.area, view.fill, geometry.diagonalMm()});
}

ScreenArea largestFreeArea(int width, int height, const std::vector<std::array<double, 4>>& obstacles, double aspect, double marginPx) {
  const double w = std::max(width, 1), h = std::max(height, 1);
  if (!(aspect > 0.0) || !std::isfinite(aspect)) aspect = 1.0;
  // Candidate sides: the view's edges and each obstacle's edges pushed out by the margin.
  std::vector<double> xs{marginPx, w - marginPx}, ys{marginPx, h - marginPx};
  for (const auto& o : obstacles) {
    xs.push_back(o[0] - marginPx);
    xs.push_back(o[2] + marginPx);
    ys.push_back(o[1] - marginPx);
    ys.push_back(o[3] + marginPx);
  }
  ScreenArea best;
  double bestSize = 0.0;  // the width of the biggest box of that aspect inside
  for (double x0 : xs)
    for (double x1 : xs)
      for (double y0 : ys)
        for (double y1 : ys) {
          if (!(x0 >= 0.0 && x1 <= w && y0 >= 0.0 && y1 <= h && x1 > x0 && y1 > y0)) continue;
          const double size = std::min(x1 - x0, (y1 - y0) * aspect);
          if (size <= bestSize) continue;
          bool clear = true;
          for (const auto& o : obstacles)
            if (x0 < o[2] + marginPx && x1 > o[0] - marginPx && y0 < o[3] + marginPx && y1 > o[1] - marginPx) {
              clear = false;
              break;
            }
          if (!clear) continue;
          bestSize = size;
          best = ScreenArea{x0 / w, y0 / h, x1 / w, y1 / h};
        }
  return best.valid() ? best : ScreenArea{};
}

}  // namespace handson
