#include "camera.h"

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

}  // namespace handson
