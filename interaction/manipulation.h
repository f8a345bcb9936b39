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

}  // namespace handson
