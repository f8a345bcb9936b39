#pragma once
// A perspective orbit camera around a target point, in world coordinates (RAS+, mm).
//   eye = target + distance * (cos(el) sin(az), cos(el) cos(az), sin(el))
// azimuth 0 looks at the patient from the front (anterior, +y) with superior (+z) up; roll turns
// the image about the viewing axis. Projection follows Vulkan: clip z in [0, 1], NDC y down.
#include <glm/glm.hpp>

#include "sim/volume.h"

namespace handson {

/// The default scene's camera: a three-quarter view from the front and above.
constexpr double kDefaultAzimuthDeg = 25.0, kDefaultElevationDeg = 15.0;

struct OrbitCamera {
  glm::dvec3 target{0.0};
  double distance = 500.0;   ///< mm
  double azimuth = 0.0;      ///< radians
  double elevation = 0.0;    ///< radians, kept within +-89 degrees
  double roll = 0.0;         ///< radians
  double fovY = glm::radians(35.0);
  double nearPlane = 1.0, farPlane = 10000.0;

  glm::dvec3 eye() const;
  glm::dvec3 forward() const;  ///< unit vector from eye to target
  glm::dvec3 up() const;       ///< unit, orthogonal to forward, includes roll
  glm::dvec3 right() const;    ///< unit, forward x up
  glm::mat4 view() const;
  glm::mat4 projection(double aspect) const;

  /// Rotate about the target (radians). Elevation is clamped to +-89 degrees.
  void orbit(double dAzimuth, double dElevation);
  /// Move target and eye in the view plane by (dx, dy) in mm (x right, y up on screen).
  void pan(double dxMm, double dyMm);
  /// Multiply the distance by 1/factor (factor > 1 moves closer). Clamped to [minDistance, maxDistance].
  void zoom(double factor);
  void rotateRoll(double dRoll);

  /// World length of one screen pixel at a given depth (mm along the viewing axis).
  double pixelSizeAt(double depthMm, int viewportHeightPx) const;

  /// Frames a volume: target at its centre, distance so that its bounding sphere fits the view.
  static OrbitCamera framing(const VolumeGeometry& geometry, double azimuth = 0.0, double elevation = 0.0, double aspect = 1.0);

  double minDistance = 1.0, maxDistance = 1e5;
};

}  // namespace handson
