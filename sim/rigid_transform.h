#pragma once
// The one rigid transform of the code: a handle's pose from the gesture (interaction/), a handle's
// motion in the simulation (sim/) and a handle drawn where it moved (render/) are all this type.
#include <Eigen/Core>

namespace handson {

/// x = R X + t in millimetres (R a 3x3 rotation, t a 3-vector); world space where not said otherwise
/// (the gesture solve's increment, interaction/gesture_solve.h, is in view space).
struct RigidTransform {
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
  Eigen::Vector3d t = Eigen::Vector3d::Zero();

  /// The moved point R X + t of a rest point X.
  Eigen::Vector3d apply(const Eigen::Vector3d& X) const { return R * X + t; }
  /// The rest point Rᵀ (x - t) of a moved point x (the inverse of apply).
  Eigen::Vector3d toRest(const Eigen::Vector3d& x) const { return R.transpose() * (x - t); }
  /// The homogeneous 4x4 matrix of apply (rest -> moved).
  Eigen::Matrix4d matrix() const {
    Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
    m.topLeftCorner<3, 3>() = R;
    m.topRightCorner<3, 1>() = t;
    return m;
  }
  /// Within 1e-12 of the identity (Frobenius norm of R - I, length of t).
  bool isIdentity() const { return (R - Eigen::Matrix3d::Identity()).norm() < 1e-12 && t.norm() < 1e-12; }
  /// Rotation by a rotation vector (radians, axis * angle) about `pivot`, then a translation.
  static RigidTransform about(const Eigen::Vector3d& pivot, const Eigen::Vector3d& rotationVector, const Eigen::Vector3d& translation);
};

}  // namespace handson
