#include "manipulation.h"
#include "sim/volume.h"

#include <algorithm>
#include <cmath>


namespace handson {

void HandleManipulator::anchor(const std::vector<FingerAnchor>& fingers, const RigidTransform& pose) {
  anchors_.clear();
  for (const auto& f : fingers)
    if (f.world.allFinite()) anchors_.emplace_back(f.finger, pose.toRest(f.world));
}

std::optional<RigidTransform> HandleManipulator::move(const std::vector<std::pair<std::int64_t, glm::dvec2>>& fingers, const RigidTransform& pose,
                                                 const OrbitCamera& camera, double aspect, unsigned locks, std::string* why) const {
  auto fail = [&](const std::string& reason) -> std::optional<RigidTransform> {
    if (why) *why = reason;
    return std::nullopt;
  };
  if (anchors_.empty()) return fail("no finger is anchored on the handle");
  // The solver's camera frame: x right, y down (as NDC), z forward (depth); B's columns in world.
  const glm::dvec3 e = camera.eye(), r = camera.right(), u = camera.up(), f = camera.forward();
  Eigen::Matrix3d B;
  B << r.x, -u.x, f.x, r.y, -u.y, f.y, r.z, -u.z, f.z;
  const Eigen::Vector3d eye(e.x, e.y, e.z);
  const double tanHalf = std::tan(0.5 * camera.fovY);
  GestureProblem p;
  // Residuals in units of the view's height on both axes (NDC x scaled by the aspect): the fit
  // weighs a pixel alike across and up the screen, so the answer does not depend on the window's
  // aspect (in NDC a pixel across counted 1/aspect of one up, and a played session moved the
  // kidney 3.7 mm differently in depth at 1280x800 than at 512x512).
  p.projection << 1.0 / tanHalf, 0, 0, 0, 1.0 / tanHalf, 0;
  p.locks = locks;
  for (const auto& [id, rest] : anchors_) {
    const auto it = std::find_if(fingers.begin(), fingers.end(), [id = id](const auto& fp) { return fp.first == id; });
    if (it == fingers.end()) return fail("an anchored finger is missing: re-anchor first");
    p.points.push_back(B.transpose() * (pose.apply(rest) - eye));
    p.targets.emplace_back(it->second.x * aspect, it->second.y);
  }
  const RigidIncrement inc = solveLinearizedSubsteps(p);
  if (!inc.ok) return fail(inc.reason);
  // Back to world: x' = B R B^T x + (eye - B R B^T eye + B t).
  const Eigen::Matrix3d Rw = B * inc.motion.R * B.transpose();
  const Eigen::Vector3d tw = eye - Rw * eye + B * inc.motion.t;
  RigidTransform next;
  next.R = Rw * pose.R;
  next.t = Rw * pose.t + tw;
  if (!next.R.allFinite() || !next.t.allFinite()) return fail("the increment is not finite");
  if (why) *why = inc.reason;
  return next;
}

std::optional<Eigen::Vector3d> contactOnHandle(const VolumeGeometry& g, const std::vector<std::uint8_t>& mask, int id, const RigidTransform& pose,
                                               const ContactRay& r) {
  const Eigen::Vector3d &eye = r.eye, &picked = r.picked;
  const double windowMm = r.windowMm;
  const Eigen::Vector3d ray = picked - eye;
  const double len = ray.norm();
  if (!eye.allFinite() || !picked.allFinite() || !(len > 0.0) || !std::isfinite(len) || !(windowMm >= 0.0) || !std::isfinite(windowMm) ||
      mask.size() != g.voxelCount() || id <= 0 || id > 255)
    return std::nullopt;
  const Eigen::Vector3d dir = ray / len;
  const double step = 0.5 * g.spacing.minCoeff();
  if (!(step > 0.0)) return std::nullopt;
  const int half = int(std::min(4096.0, std::floor(windowMm / step)));
  for (int s = -half; s <= half; ++s) {
    const Eigen::Vector3d w = picked + dir * (step * s);
    const auto v = nearestVoxel(g, pose.toRest(w));
    if (v && mask[linearIndex(g, *v)] == id) return w;
  }
  return std::nullopt;
}

}  // namespace handson
