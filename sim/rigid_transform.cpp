#include "rigid_transform.h"

#include <Eigen/Geometry>

namespace handson {

RigidTransform RigidTransform::about(const Eigen::Vector3d& pivot, const Eigen::Vector3d& rv, const Eigen::Vector3d& translation) {
  RigidTransform T;
  const double angle = rv.norm();
  if (angle > 0) T.R = Eigen::AngleAxisd(angle, rv / angle).toRotationMatrix();
  T.t = pivot - T.R * pivot + translation;
  return T;
}

}  // namespace handson
