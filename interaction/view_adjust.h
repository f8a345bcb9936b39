#pragma once
// What fingers mean in the two view-adjusting modes (no Vulkan, no SDL2):
//
// Clip mode (the clip box's six faces and a clip plane, world RAS mm):
//  - a drag that starts within faceGrabRadiusPx of a face centre's projection moves that face along its
//    axis by the finger's motion projected on the axis' screen direction: for the face centre p and
//    its axis a (unit), s = screen(p + a) - screen(p) (pixels per mm) and the face moves by
//    dot(d, s) / |s|^2 mm for a finger motion d (pixels). Faces whose axis lies within 35 degrees
//    of the line of sight are not offered: they face the viewer (their handle sits over the middle
//    of the box, where a drag means the plane) and their motion would be mostly along the view;
//  - any other drag places a plane through the point under the finger, its normal the viewing
//    direction (it keeps what lies beyond the point, n.x >= n.p), and moves it along the normal:
//    an upward drag pushes it away from the viewer by one pixel's size at the camera's target depth
//    per pixel, so the cut follows the finger at that depth.
//
// Window mode (the transfer function): a drag of the fingers' centroid moves the preset's level
// (up raises it, by the preset's width per viewport height) and its window (right widens it, 4x per
// viewport width); a two-finger spread scales its opacity by the spread's ratio. See WindowLevel.
#include <glm/glm.hpp>

#include <optional>

#include "camera.h"
#include "touch.h"

namespace handson {

/// A face of an axis-aligned box: axis 0/1/2 (x/y/z), high (the max face) or low.
struct BoxFace {
  int axis = 0;
  bool high = false;
};

/// A finger within this fraction of the viewport's smaller side of a face's handle grabs it (46 px
/// at 512 px, 97 px at 1080 px): a fraction, not pixels, so that a script replayed at another size
/// grabs the same faces.
inline constexpr double kFaceGrabFraction = 0.09;
double faceGrabRadiusPx(const Viewport& vp);
inline constexpr double kMinFaceAxisSine = 0.5736;  ///< sin(35 degrees): faces nearer end-on are not offered
inline constexpr double kMinClipBoxMm = 1.0;      ///< a dragged face stops this far from its opposite

/// The world box of a volume's voxels (voxel edges included; an oblique grid: the box of its
/// corners): the clip box a Clip-mode drag starts from when none is set.
void volumeWorldBox(const VolumeGeometry& g, glm::dvec3& lo, glm::dvec3& hi);
/// Pixel (x right, y down) of a world point; nullopt behind the camera.
std::optional<glm::dvec2> projectToPixel(const OrbitCamera& camera, const Viewport& vp, const glm::dvec3& world);
/// The centre of a box face (world mm).
glm::dvec3 faceCentre(const glm::dvec3& lo, const glm::dvec3& hi, BoxFace f);
/// The face whose centre projects nearest to px within radiusPx (faces near end-on excluded; a
/// radius <= 0: faceGrabRadiusPx).
std::optional<BoxFace> boxFaceNear(const glm::dvec3& lo, const glm::dvec3& hi, const OrbitCamera& camera, const Viewport& vp,
                                   glm::dvec2 px, double radiusPx = 0.0);
/// Millimetres along the face's axis for a finger motion deltaPx that started over the face.
double faceDragMm(const glm::dvec3& lo, const glm::dvec3& hi, BoxFace f, const OrbitCamera& camera, const Viewport& vp, glm::dvec2 deltaPx);
/// The box with face f moved by mm along its axis, kept at least kMinClipBoxMm thick.
void moveBoxFace(glm::dvec3& lo, glm::dvec3& hi, BoxFace f, double mm);

/// The view-oriented clip plane through a point: normal = the viewing direction, offset = n.point.
struct ClipPlaneDrag {
  glm::dvec3 normal{0.0, 0.0, 1.0};
  double offset = 0.0;
};
ClipPlaneDrag viewPlaneThrough(const OrbitCamera& camera, const glm::dvec3& point);
/// Millimetres along the plane's normal for a finger motion deltaPx (up = away from the viewer).
double planeDragMm(const OrbitCamera& camera, const Viewport& vp, glm::dvec2 deltaPx);

/// The transfer function's adjustment: values v map to anchor + (v - anchor) * scale + shift (so a
/// preset point at value v now sits there), opacities multiply by opacity (clamped to 1). The anchor
/// is the preset's lowest visible value (TransferFunction::visibleFrom); shift is in its units.
struct WindowLevel {
  double scale = 1.0, shift = 0.0, opacity = 1.0;
  bool identity() const { return scale == 1.0 && shift == 0.0 && opacity == 1.0; }
  bool operator==(const WindowLevel&) const = default;
};
inline constexpr double kWindowPerViewportWidth = 4.0;  ///< window factor of a full-width drag right
inline constexpr double kMinWindowScale = 1.0 / 64.0, kMaxWindowScale = 64.0;
inline constexpr double kMinOpacity = 1.0 / 16.0, kMaxOpacity = 16.0;
/// The adjustment after a drag from `start`: centroid motion deltaPx, spread ratio (current finger
/// distance over the distance at the gesture's start; 1 with one finger), `width` the preset's width
/// (TransferFunction::width: the level moves by it per viewport height). Each component is monotonic
/// in its input and clamped to the limits above.
WindowLevel windowLevelDrag(const WindowLevel& start, glm::dvec2 deltaPx, double spreadRatio, const Viewport& vp, double width);

}  // namespace handson
