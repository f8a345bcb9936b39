#pragma once
// Moving a handle with one, two or three fingers (docs/gesture-solve.md, "in the app"): at
// touch-down each finger's point on the handle is picked (world, RAS mm); as the fingers move, the
// rigid increment that keeps those points under them is solved in the camera's frame (sub-stepped
// linearized solve) and composed into the handle's cumulative pose (R_m, t_m), world = R_m rest + t_m.
// Adding or lifting a finger re-anchors on the new finger set without a jump.
#include <Eigen/Core>
#include <glm/glm.hpp>

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "camera.h"
#include "gesture_solve.h"
#include "sim/volume.h"

namespace handson {

struct FingerAnchor {
  std::int64_t finger = 0;
  Eigen::Vector3d world{0, 0, 0};  ///< the picked point on the handle at touch-down (current pose)
};

class HandleManipulator {
 public:
  /// Anchors on the fingers now touching the handle; the points are stored in the handle's rest frame.
  void anchor(const std::vector<FingerAnchor>& fingers, const RigidTransform& pose);
  void release() { anchors_.clear(); }
  bool active() const { return !anchors_.empty(); }
  std::size_t fingerCount() const { return anchors_.size(); }

  /// Fingers' current positions (NDC, x right, y down) by id; returns the handle's new pose, or
  /// nullopt with a reason if the increment was refused (the pose then stays).
  std::optional<RigidTransform> move(const std::vector<std::pair<std::int64_t, glm::dvec2>>& fingersNdc, const RigidTransform& pose,
                                const OrbitCamera& camera, double aspect, unsigned locks, std::string* why = nullptr) const;

 private:
  std::vector<std::pair<std::int64_t, Eigen::Vector3d>> anchors_;  // finger id, rest-frame point
};

/// Where a finger's ray meets the handle itself. Under the simulation the handle is drawn from the
/// deformed volume, resampled through fine tets that straddle its boundary, so the surface a pick
/// finds can lie up to a fine tet off the handle's own, rigidly moved voxels. Marching the ray from
/// `eye` through `picked` in half-voxel steps over [-windowMm, +windowMm] about the pick: the first
/// point whose nearest voxel, taken back to rest by `pose`, belongs to handle `id` in `mask` (the
/// handles' ids at rest, on `geometry`'s grid, x fastest). nullopt when no such point lies in the
/// window, and for bad input (a non-finite point, eye == picked, a mask that does not fit the grid,
/// a negative or non-finite window).
struct ContactRay {
  Eigen::Vector3d eye, picked;  ///< the finger's ray from the eye through the picked point (world mm)
  double windowMm = 0.0;        ///< how far before and behind the pick to look
};
std::optional<Eigen::Vector3d> contactOnHandle(const VolumeGeometry& geometry, const std::vector<std::uint8_t>& mask, int id, const RigidTransform& pose,
                                               const ContactRay& ray);

}  // namespace handson
