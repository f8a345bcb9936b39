#pragma once
// Framing a region: the camera that shows a convex part of the volume (the volume's box cut by a
// clip box or plane) filling the view, and the animated move from one camera to another.
//
// The region is the intersection of half-spaces: the volume's box (voxel edges included, possibly
// oblique) and the cuts. Its vertices are found exactly by brute force: every three of its planes
// that meet in one point give a candidate, kept when it lies in every half-space (13 planes for a
// box and a plane: 286 triples). The camera keeps its direction and roll; its target and distance
// are the fixed point of OrbitCamera::framingIn's iteration applied to those vertices.
#include <glm/glm.hpp>

#include <array>
#include <optional>
#include <vector>

#include "interaction/camera.h"
#include "sim/volume.h"

namespace handson {

/// A half-space of world space (RAS mm): the points x with dot(normal, x) >= offset.
struct HalfSpace {
  glm::dvec3 normal{0.0, 0.0, 1.0};
  double offset = 0.0;
};

/// The six half-spaces of an axis-aligned box lo..hi (world mm).
std::vector<HalfSpace> boxHalfSpaces(const glm::dvec3& lo, const glm::dvec3& hi);

/// The vertices of the volume's box (voxel edges included) cut by `cuts`; empty when nothing of
/// the volume is left. A cut whose normal is zero or not finite is ignored.
std::vector<glm::dvec3> clippedVolumeCorners(const VolumeGeometry& geometry, const std::vector<HalfSpace>& cuts);

/// `from` turned towards nothing new (its azimuth, elevation, roll and field of view kept) with its
/// target and distance chosen so that the points' projected bounding box is centred in the view's
/// area and fills `fill` of it in its tighter dimension. `from` unchanged when points is empty or
/// spans under a micrometre (a point or an edge: nothing to fill the view with).
OrbitCamera framePoints(const OrbitCamera& from, const std::vector<glm::dvec3>& points, const FramingView& view);

/// framePoints' iteration from the camera c as it is (its target and distance the start): the
/// distance scaled by the box's size over the wanted size and the target moved by the box centre's
/// offset until both change by less than 1e-4 (at most 60 rounds). OrbitCamera::framingIn runs it
/// on the volume's corners.
OrbitCamera fitPointsFrom(OrbitCamera c, const std::vector<glm::dvec3>& points, const FramingView& view);

/// The pixel bounding box (x0, y0, x1, y1) of points seen by camera in a width x height view;
/// nullopt when one lies behind the near plane or there are none.
std::optional<std::array<double, 4>> projectedPointsBox(const OrbitCamera& camera, const std::vector<glm::dvec3>& points, int width, int height);

/// The camera between a and b at s in [0, 1]: target, distance (geometrically), azimuth, elevation
/// and roll (each the short way round) eased by smoothstep; s <= 0 gives a, s >= 1 gives b exactly.
OrbitCamera blendCameras(const OrbitCamera& a, const OrbitCamera& b, double s);

/// A camera moving from one framing to another over `seconds`, driven by the caller's clock (a
/// replay's frame times, the window's seconds since start), so that a replay moves it identically.
struct CameraMove {
  OrbitCamera from, to;
  double start = 0.0, seconds = 0.35;
  /// The camera at time t (to once t >= start + seconds).
  OrbitCamera at(double t) const;
  bool done(double t) const { return !(t < start + seconds); }
};

}  // namespace handson
