#pragma once
// Direct manipulation: the rigid increment that brings handle points under the fingers
// (docs/gesture-solve.md). View space: camera at the origin looking along +z (depth z > 0);
// a point v projects to NDC as Proj(v) = P v / (k^T v), P the 2x3 linear part of the projection,
// k = (0, 0, 1).
//
// Residual f_j = Proj(R (q_j - c) + c + t) - p_j, rotation about the points' centroid c.
// Linearized (one Gauss-Newton step from R = I, t = 0, small rotation R q ~ q + r x q):
//   J(v) = (1 / k^T v) P (I - v k^T / k^T v)                       (2x3)
//   G_j  = [ J(q_j) , -J(q_j) [q_j - c]_x ]                          (2x6, columns t then r)
//   (sum G_j^T G_j + lambda I) x = -sum G_j^T f_j(0),  x = (t, r)    (only the allowed columns)
//   R = exp([r]_x) (Rodrigues); the result maps q to R q + (c - R c + t).
// Degrees of freedom by finger count: 1 -> screen-plane translation (t_x, t_y); 2 -> t_x, t_y, t_z
// and rotation about the view axis (r_z); 3+ -> all six. Locks remove z translation, z rotation or
// xy translation. Conditioning [team formulation]: the centroid pivot, damping lambda = 1e-9 of the
// system's mean diagonal (plus an absolute floor), and a per-event clamp of the step (translation
// and rotation), reported when it acts. Degenerate input never yields NaN: it is refused with a reason.
#include <Eigen/Core>

#include <string>
#include <vector>

#include "sim/rigid_transform.h"

namespace handson {

enum GestureLock : unsigned { kLockNone = 0, kLockZTranslation = 1, kLockZRotation = 2, kLockXYTranslation = 4 };
/// "z-translation", "z-rotation", "xy-translation"; false on anything else.
bool parseGestureLock(const std::string& s, unsigned& lock);

struct GestureProblem {
  Eigen::Matrix<double, 2, 3> projection = Eigen::Matrix<double, 2, 3>::Zero();
  std::vector<Eigen::Vector3d> points;   ///< q_j, view space
  std::vector<Eigen::Vector2d> targets;  ///< p_j, NDC
  unsigned locks = kLockNone;
};

struct RigidIncrement {
  RigidTransform motion;  ///< new points = motion.apply(q), view space
  bool ok = true;         ///< false: refused (identity returned), see reason
  bool clamped = false;   ///< the step was reduced by the per-event clamp
  std::string reason;     ///< why it was refused or reduced
  double rmsBefore = 0, rmsAfter = 0;  ///< RMS reprojection error (NDC) before and after
  int iterations = 0;
};

struct LinearizedOptions {
  double maxTranslationFraction = 0.25;  ///< of the points' mean depth, per event
  double maxRotation = 0.5;              ///< radians per event
};

/// The degrees of freedom in use (columns t_x, t_y, t_z, r_x, r_y, r_z) for a problem.
Eigen::Matrix<bool, 6, 1> gestureDofs(std::size_t fingers, unsigned locks);

/// Checks a problem; returns "" if it is usable, else the reason.
std::string validateGestureProblem(const GestureProblem& p);

RigidIncrement solveLinearized(const GestureProblem& p, const LinearizedOptions& options = {});

/// The linearized solve in sub-steps: the fingers' screen displacement is split so that no finger
/// moves more than `maxSubstepNdc` per sub-step, and each sub-step is one linearized solve from
/// where the points have got to (the per-event step where one step stops being accurate enough,
/// see `handson bench gesture`). Same degrees of freedom, clamp and refusals as one step.
RigidIncrement solveLinearizedSubsteps(const GestureProblem& p, double maxSubstepNdc = 0.004, const LinearizedOptions& options = {});

/// Reference: the full nonlinear least squares on the same objective and degrees of freedom,
/// Levenberg-Marquardt with an analytic Jacobian of the exponential-map parametrization about
/// the current estimate.
RigidIncrement solveLevenbergMarquardt(const GestureProblem& p, int maxIterations = 100);

/// RMS reprojection error (NDC) of the problem's points moved by a rigid transform.
double gestureRms(const GestureProblem& p, const Eigen::Matrix3d& R, const Eigen::Vector3d& t);
/// exp([r]_x), Rodrigues' formula (exact for any angle, stable near zero).
Eigen::Matrix3d rodrigues(const Eigen::Vector3d& r);

}  // namespace handson
