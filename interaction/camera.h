#pragma once
// A perspective orbit camera around a target point, in world coordinates (RAS+, mm).
//   eye = target + distance * (cos(el) sin(az), cos(el) cos(az), sin(el))
// azimuth 0 looks at the patient from the front (anterior, +y) with superior (+z) up; roll turns
// the image about the viewing axis. Projection follows Vulkan: clip z in [0, 1], NDC y down.
#include <glm/glm.hpp>

#include <array>
#include <optional>
#include <vector>

#include "sim/volume.h"

namespace handson {

/// A rectangle of the viewport as fractions of its width and height (x right, y down, 0..1): the
/// part of the window the UI's panels leave free.
struct ScreenArea {
  double x0 = 0.0, y0 = 0.0, x1 = 1.0, y1 = 1.0;
  bool whole() const { return x0 <= 0.0 && y0 <= 0.0 && x1 >= 1.0 && y1 >= 1.0; }
  bool valid() const { return x0 >= 0.0 && y0 >= 0.0 && x1 <= 1.0 && y1 <= 1.0 && x1 - x0 > 0.05 && y1 - y0 > 0.05; }
  bool operator==(const ScreenArea&) const = default;
};

/// What a framing needs besides what it frames: the view's size and the part of it to fill.
struct FramingView {
  int width = 512, height = 512;
  ScreenArea area;      ///< the part of the view the panels leave free (the whole view by default)
  double fill = 0.92;   ///< the share of the area's tighter dimension the framed box fills
  double sceneDiagonalMm = 0.0;  ///< the volume's diagonal: the far plane reaches past it
};

/// The 8 corners of a volume's box (voxel edges included; an oblique grid's are not axis-aligned), world mm.
std::array<glm::dvec3, 8> volumeBoxCorners(const VolumeGeometry& geometry);

/// The pixel bounding box (x0, y0, x1, y1) of a volume's box (its 8 corners, voxel edges included)
/// as a camera sees it in a width x height view; nullopt when a corner lies behind the near plane.
struct OrbitCamera;
std::optional<std::array<double, 4>> projectedVolumeBox(const OrbitCamera& camera, const VolumeGeometry& geometry, int width, int height);

/// The largest rectangle of a width x height view that meets none of the obstacles (pixel rectangles
/// x0, y0, x1, y1: the UI's panels) and holds the biggest box of the given aspect (width / height),
/// less a margin of `marginPx` from every obstacle and edge; as fractions of the view. Exhaustive
/// over the rectangles whose sides lie on the obstacles' and the view's edges (exact for
/// axis-aligned obstacles). The whole view when nothing fits.
ScreenArea largestFreeArea(int width, int height, const std::vector<std::array<double, 4>>& obstacles, double aspect, double marginPx = 8.0);

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
  /// Frames a volume in part of a width x height view: the same direction, the target and distance
  /// chosen so that the projection of the volume's box (its 8 corners, voxel edges included) is
  /// centred in the view's area and fills `fill` of it in its tighter dimension (the view's
  /// sceneDiagonalMm is the geometry's). Perspective makes this a
  /// fixed point: the distance is scaled by the box's size over the wanted size and the target moved
  /// by the box centre's offset until both change by less than 1e-4 (at most 60 rounds).
  static OrbitCamera framingIn(const VolumeGeometry& geometry, double azimuth, double elevation, const FramingView& view);

  double minDistance = 1.0, maxDistance = 1e5;
};

}  // namespace handson
