#include "gesture_solve.h"

#include <Eigen/Cholesky>
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

namespace handson {

namespace {

Eigen::Matrix3d skew(const Eigen::Vector3d& v) {
  Eigen::Matrix3d m;
  m << 0, -v.z(), v.y(), v.z(), 0, -v.x(), -v.y(), v.x(), 0;
  return m;
}

Eigen::Vector2d project(const Eigen::Matrix<double, 2, 3>& P, const Eigen::Vector3d& v) { return P * v / v.z(); }

// J(v) = (1 / v_z) P (I - v k^T / v_z)
Eigen::Matrix<double, 2, 3> projectionJacobian(const Eigen::Matrix<double, 2, 3>& P, const Eigen::Vector3d& v) {
  Eigen::Matrix3d m = Eigen::Matrix3d::Identity();
  m.col(2) -= v / v.z();
  return P * m / v.z();
}

Eigen::Vector3d centroid(const std::vector<Eigen::Vector3d>& pts) {
  Eigen::Vector3d c = Eigen::Vector3d::Zero();
  for (const auto& q : pts) c += q;
  return c / double(pts.size());
}

constexpr double kMinDepth = 1e-6;

RigidIncrement refused(const std::string& why) {
  RigidIncrement r;
  r.ok = false;
  r.reason = why;
  return r;
}

}  // namespace

bool parseGestureLock(const std::string& s, unsigned& lock) {
  if (s == "z-translation") lock = kLockZTranslation;
  else if (s == "z-rotation") lock = kLockZRotation;
  else if (s == "xy-translation") lock = kLockXYTranslation;
  else return false;
  return true;
}

Eigen::Matrix3d rodrigues(const Eigen::Vector3d& r) {
  const double theta = r.norm();
  const Eigen::Matrix3d K = skew(r);
  if (theta < 1e-8) return Eigen::Matrix3d::Identity() + K + 0.5 * K * K;  // series, exact to O(theta^3)
  return Eigen::Matrix3d::Identity() + std::sin(theta) / theta * K + (1.0 - std::cos(theta)) / (theta * theta) * K * K;
}

Eigen::Matrix<bool, 6, 1> gestureDofs(std::size_t fingers, unsigned locks) {
  Eigen::Matrix<bool, 6, 1> d;
  if (fingers <= 1) d << true, true, false, false, false, false;
  else if (fingers == 2) d << true, true, true, false, false, true;
  else d << true, true, true, true, true, true;
  if (locks & kLockXYTranslation) d(0) = d(1) = false;
  if (locks & kLockZTranslation) d(2) = false;
  if (locks & kLockZRotation) d(5) = false;
  return d;
}

std::string validateGestureProblem(const GestureProblem& p) {
  if (p.points.empty()) return "no points";
  if (p.points.size() != p.targets.size()) return "points and targets differ in number";
  if (!p.projection.allFinite()) return "the projection is not finite";
  for (const auto& q : p.points) {
    if (!q.allFinite()) return "a point is not finite";
    if (q.z() <= kMinDepth) return "a point lies at or behind the camera";
  }
  for (const auto& t : p.targets)
    if (!t.allFinite()) return "a target is not finite";
  return "";
}

double gestureRms(const GestureProblem& p, const Eigen::Matrix3d& R, const Eigen::Vector3d& t) {
  double s = 0;
  for (std::size_t j = 0; j < p.points.size(); ++j) {
    const Eigen::Vector3d v = R * p.points[j] + t;
    if (v.z() <= kMinDepth) return std::numeric_limits<double>::infinity();
    s += (project(p.projection, v) - p.targets[j]).squaredNorm();
  }
  return std::sqrt(s / double(p.points.size()));
}

RigidIncrement solveLinearized(const GestureProblem& p, const LinearizedOptions& o) {
  if (const std::string why = validateGestureProblem(p); !why.empty()) return refused(why);
  const auto dofs = gestureDofs(p.points.size(), p.locks);
  if (!dofs.any()) return refused("every degree of freedom is locked");
  const Eigen::Vector3d c = centroid(p.points);
  Eigen::Matrix<double, 6, 6> A = Eigen::Matrix<double, 6, 6>::Zero();
  Eigen::Matrix<double, 6, 1> b = Eigen::Matrix<double, 6, 1>::Zero();
  double meanDepth = 0;
  for (std::size_t j = 0; j < p.points.size(); ++j) {
    const Eigen::Vector3d& q = p.points[j];
    const Eigen::Matrix<double, 2, 3> J = projectionJacobian(p.projection, q);
    Eigen::Matrix<double, 2, 6> G;
    G << J, -J * skew(q - c);
    const Eigen::Vector2d f = project(p.projection, q) - p.targets[j];
    A += G.transpose() * G;
    b -= G.transpose() * f;
    meanDepth += q.z();
  }
  meanDepth /= double(p.points.size());
  // Only the allowed columns: the locked ones become identity rows with a zero right-hand side
  // (a fixed-size 6x6 solve, no allocation), then damping.
  double diag = 0;
  int n = 0;
  for (int i = 0; i < 6; ++i)
    if (dofs(i)) {
      diag += A(i, i);
      ++n;
    }
  const double lambda = 1e-9 * diag / n + 1e-12;
  for (int i = 0; i < 6; ++i) {
    if (dofs(i)) continue;
    A.row(i).setZero();
    A.col(i).setZero();
    A(i, i) = 1.0;
    b(i) = 0.0;
  }
  A.diagonal().array() += lambda;
  const Eigen::Matrix<double, 6, 1> x = A.ldlt().solve(b);
  if (!x.allFinite()) return refused("the system is singular (degenerate finger layout)");
  Eigen::Vector3d t = x.head<3>(), r = x.tail<3>();
  RigidIncrement out;
  // Per-event clamp: large steps break the linearization (and can invert elements downstream).
  const double maxT = o.maxTranslationFraction * meanDepth;
  const double scaleT = t.norm() > maxT ? maxT / t.norm() : 1.0;
  const double scaleR = r.norm() > o.maxRotation ? o.maxRotation / r.norm() : 1.0;
  const double scale = std::min(scaleT, scaleR);
  if (scale < 1.0) {
    t *= scale;
    r *= scale;
    out.clamped = true;
    std::ostringstream why;
    why << "step clamped to " << scale * 100.0 << " % (per-event limits: translation " << maxT << ", rotation " << o.maxRotation << " rad)";
    out.reason = why.str();
  }
  out.motion.R = rodrigues(r);
  out.motion.t = c - out.motion.R * c + t;
  out.rmsBefore = gestureRms(p, Eigen::Matrix3d::Identity(), Eigen::Vector3d::Zero());
  out.rmsAfter = gestureRms(p, out.motion.R, out.motion.t);
  out.iterations = 1;
  if (!out.motion.R.allFinite() || !out.motion.t.allFinite() || !std::isfinite(out.rmsAfter))
    return refused("the increment is not finite or moves a point behind the camera");
  return out;
}

RigidIncrement solveLinearizedSubsteps(const GestureProblem& p, double maxSubstepNdc, const LinearizedOptions& o) {
  if (const std::string why = validateGestureProblem(p); !why.empty()) return refused(why);
  if (!(maxSubstepNdc > 0.0) || !std::isfinite(maxSubstepNdc)) return refused("the sub-step size must be > 0");
  std::vector<Eigen::Vector2d> start;
  double largest = 0;
  for (std::size_t j = 0; j < p.points.size(); ++j) {
    start.push_back(project(p.projection, p.points[j]));
    largest = std::max(largest, (p.targets[j] - start.back()).norm());
  }
  const int steps = std::clamp(int(std::ceil(largest / maxSubstepNdc)), 1, 1000);
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
  Eigen::Vector3d t = Eigen::Vector3d::Zero();
  RigidIncrement out;
  GestureProblem sub = p;
  for (int k = 1; k <= steps; ++k) {
    for (std::size_t j = 0; j < p.points.size(); ++j) {
      sub.points[j] = R * p.points[j] + t;
      sub.targets[j] = start[j] + (p.targets[j] - start[j]) * (double(k) / steps);
    }
    const RigidIncrement s = solveLinearized(sub, o);
    if (!s.ok) {
      if (k == 1) return s;
      out.reason = "stopped after " + std::to_string(k - 1) + " of " + std::to_string(steps) + " sub-steps: " + s.reason;
      break;
    }
    R = s.motion.R * R;
    t = s.motion.R * t + s.motion.t;
    if (s.clamped) {
      out.clamped = true;
      out.reason = s.reason;
    }
    out.iterations = k;
  }
  // Polish: where the fingers leave the points (a sub-step's linearization was off, e.g. a turn that
  // only perspective reveals), up to two more steps toward the final targets, kept only if they
  // bring the points closer. Not after a stop or a clamp: those leave the rest to the next events.
  double rms = gestureRms(p, R, t);
  for (int extra = 0; extra < 2 && out.reason.empty() && rms > 0.1 * maxSubstepNdc; ++extra) {
    for (std::size_t j = 0; j < p.points.size(); ++j) {
      sub.points[j] = R * p.points[j] + t;
      sub.targets[j] = p.targets[j];
    }
    const RigidIncrement s = solveLinearized(sub, o);
    if (!s.ok || s.clamped) break;
    const Eigen::Matrix3d R2 = s.motion.R * R;
    const Eigen::Vector3d t2 = s.motion.R * t + s.motion.t;
    const double rms2 = gestureRms(p, R2, t2);
    if (!(rms2 < rms)) break;
    R = R2;
    t = t2;
    rms = rms2;
    ++out.iterations;
  }
  out.motion.R = R;
  out.motion.t = t;
  out.rmsBefore = gestureRms(p, Eigen::Matrix3d::Identity(), Eigen::Vector3d::Zero());
  out.rmsAfter = rms;
  return out;
}

RigidIncrement solveLevenbergMarquardt(const GestureProblem& p, int maxIterations) {
  if (const std::string why = validateGestureProblem(p); !why.empty()) return refused(why);
  const auto dofs = gestureDofs(p.points.size(), p.locks);
  if (!dofs.any()) return refused("every degree of freedom is locked");
  const Eigen::Vector3d c = centroid(p.points);
  // State: R, t of the map q -> R (q - c) + c + t; updates R <- exp([dr]) R, t <- t + dt, so the
  // allowed degrees of freedom keep their meaning (rotations about the view axes through c).
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
  Eigen::Vector3d t = Eigen::Vector3d::Zero();
  auto cost = [&](const Eigen::Matrix3d& Rm, const Eigen::Vector3d& tm) {
    double s = 0;
    for (std::size_t j = 0; j < p.points.size(); ++j) {
      const Eigen::Vector3d v = Rm * (p.points[j] - c) + c + tm;
      if (v.z() <= kMinDepth) return std::numeric_limits<double>::infinity();
      s += (project(p.projection, v) - p.targets[j]).squaredNorm();
    }
    return s;
  };
  std::vector<int> idx;
  for (int i = 0; i < 6; ++i)
    if (dofs(i)) idx.push_back(i);
  const int n = int(idx.size());
  double mu = 1e-3, current = cost(R, t);
  RigidIncrement out;
  int it = 0;
  for (; it < maxIterations; ++it) {
    Eigen::MatrixXd A = Eigen::MatrixXd::Zero(n, n);
    Eigen::VectorXd g = Eigen::VectorXd::Zero(n);
    for (std::size_t j = 0; j < p.points.size(); ++j) {
      const Eigen::Vector3d d = R * (p.points[j] - c);
      const Eigen::Vector3d v = d + c + t;
      const Eigen::Matrix<double, 2, 3> J = projectionJacobian(p.projection, v);
      Eigen::Matrix<double, 2, 6> G;
      G << J, -J * skew(d);  // d/d(dr) of exp([dr]) d = -[d]_x
      Eigen::MatrixXd Gr(2, n);
      for (int i = 0; i < n; ++i) Gr.col(i) = G.col(idx[i]);
      const Eigen::Vector2d f = project(p.projection, v) - p.targets[j];
      A += Gr.transpose() * Gr;
      g += Gr.transpose() * f;
    }
    if (g.norm() < 1e-15) break;
    bool improved = false;
    for (int tries = 0; tries < 30 && !improved; ++tries) {
      Eigen::MatrixXd D = A;
      D.diagonal() += mu * (A.diagonal().array() + 1e-12).matrix();
      const Eigen::VectorXd step = D.ldlt().solve(-g);
      Eigen::Matrix<double, 6, 1> x = Eigen::Matrix<double, 6, 1>::Zero();
      for (int i = 0; i < n; ++i) x(idx[i]) = step(i);
      const Eigen::Matrix3d Rn = rodrigues(x.tail<3>()) * R;
      const Eigen::Vector3d tn = t + x.head<3>();
      const double next = cost(Rn, tn);
      if (std::isfinite(next) && next < current) {
        const double gain = current - next;
        R = Rn;
        t = tn;
        current = next;
        mu = std::max(mu / 3.0, 1e-12);
        improved = true;
        if (gain < 1e-30 + 1e-15 * current) it = maxIterations;  // converged
      } else {
        mu *= 4.0;
      }
    }
    if (!improved) break;
  }
  out.motion.R = R;
  out.motion.t = c - R * c + t;
  out.rmsBefore = gestureRms(p, Eigen::Matrix3d::Identity(), Eigen::Vector3d::Zero());
  out.rmsAfter = gestureRms(p, out.motion.R, out.motion.t);
  out.iterations = std::min(it, maxIterations);
  if (!out.motion.R.allFinite() || !out.motion.t.allFinite()) return refused("the solve did not produce a finite result");
  return out;
}

}  // namespace handson
