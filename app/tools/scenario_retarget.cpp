#include "scenario_retarget.h"

#include <algorithm>
#include <cmath>
#include <set>

#include "app/tools/selection_eval.h"
#include "render/raymarch_reference.h"
#include "render/render_params.h"
#include "render/transfer_function.h"
#include "render/volume_texture.h"
#include "sim/base/error.h"
#include "sim/quantized_volume.h"

namespace handson {

namespace {

struct Touch {
  glm::dvec2 px;
  bool pinch;  // one of the first pinch's two fingers
};

// Distinct touch-down positions; the first two-finger pinch (two downs at the same time, before any
// other finger) marked.
std::vector<Touch> touchDowns(const SessionScript& s, glm::dvec2& pinchMid) {
  std::vector<Touch> out;
  std::set<std::pair<long, long>> seen;
  int pinchFound = 0;
  for (std::size_t i = 0; i < s.events.size(); ++i) {
    const ScriptEvent& e = s.events[i];
    if (!e.isTouch || e.touch.phase != TouchPhase::Down) continue;
    bool pinch = false;
    if (pinchFound == 0 && i + 1 < s.events.size()) {
      const ScriptEvent& f = s.events[i + 1];
      if (f.isTouch && f.touch.phase == TouchPhase::Down && f.t == e.t) {
        pinchFound = 1;
        pinch = true;
        pinchMid = 0.5 * (e.touch.px + f.touch.px);
      }
    } else if (pinchFound == 1) {
      pinchFound = 2;
      pinch = true;
    }
    const std::pair<long, long> key{std::lround(e.touch.px.x * 4), std::lround(e.touch.px.y * 4)};
    if (!seen.insert(key).second) continue;
    out.push_back({e.touch.px, pinch});
  }
  if (pinchFound < 2) throw Error("retarget: the script has no two-finger pinch to aim at the organ");
  return out;
}

double angleBetweenDeg(double a, double b) {
  const double d = std::fmod(std::abs(a - b), 360.0);
  return std::min(d, 360.0 - d);
}

}  // namespace

CpuPicker::CpuPicker(const Volume& ct, const std::string& preset)
    : ct_(ct), preset_(preset.empty() ? defaultPresetFor(ct) : preset), q_(quantizeVolume(ct)) {
  lut_ = transferFunctionPreset(preset_).lookupTable(q_);
  occupancy_ = brickOccupancy(computeBrickGrid(q_), lut_.maxAlpha());
}

std::vector<gpu::PickResult> CpuPicker::pick(const OrbitCamera& cam, const Viewport& vp, const std::vector<glm::dvec2>& pixels,
                                             const std::vector<std::uint8_t>* handleMask, const std::vector<MovingHandlePose>& moving) const {
  std::vector<glm::vec2> ndc;
  ndc.reserve(pixels.size());
  for (const glm::dvec2& p : pixels) ndc.push_back(glm::vec2(vp.toNdc(p)));
  RenderSettings rs;
  rs.width = vp.width;
  rs.height = vp.height;
  rs.clip = clip_;
  const double aspect = double(vp.width) / double(vp.height);
  gpu::RenderParams params = makeRenderParams(ct_.geometry(), cam.view(), cam.projection(aspect), glm::vec3(cam.eye()), rs, std::uint32_t(ndc.size()));
  if (!moving.empty()) setMovingHandles(params, ct_.geometry(), moving);
  if (handleMask && handleMask->size() != q_.data.size()) throw Error("pick: the handle mask is not on the volume's grid");
  const ReferenceScene scene{&q_, &lut_, &occupancy_, handleMask, nullptr};
  return pickReference(scene, params, ndc);
}

int CpuPicker::labelAt(const gpu::PickResult& hit, const Volume& labels) const {
  if (hit.world.w <= 0.5f) return -1;
  const Eigen::Vector3i v(hit.voxel.x, hit.voxel.y, hit.voxel.z);
  if (!labels.geometry().contains(v)) return -1;
  const float value = labels.value(v.x(), v.y(), v.z());
  return std::isfinite(value) ? int(std::lround(value)) : -1;
}

RetargetedScript retargetScript(const SessionScript& script, const Volume& ct, const Volume& labels, int label, const std::string& volumePath) {
  if (!labels.geometry().sameGrid(ct.geometry()))
    throw Error("retarget: the label map's grid is not the CT's (dimensions, spacing, origin or orientation differ)");
  const Eigen::Vector3i deep = deepestVoxel(labels, label, ct);
  if (deep.x() < 0) throw Error("retarget: label " + std::to_string(label) + " is not in the label map");
  const Eigen::Vector3d aimW = ct.geometry().toWorld(deep.cast<double>());
  const glm::dvec3 aim(aimW.x(), aimW.y(), aimW.z());
  const Eigen::Vector3d centreW = ct.geometry().center();
  const glm::dvec3 centre(centreW.x(), centreW.y(), centreW.z());
  glm::dvec2 pinchMid(0.0);
  const std::vector<Touch> touches = touchDowns(script, pinchMid);

  const Viewport vp = script.viewport;
  const double aspect = double(vp.width) / double(vp.height);
  const CpuPicker picker(ct, script.preset);
  std::vector<glm::dvec2> pixels;
  for (const auto& t : touches) pixels.push_back(t.px);

  OrbitCamera base = OrbitCamera::framing(ct.geometry(), 0.0, 0.0, aspect);
  const CameraState original = script.camera ? *script.camera : CameraState::from(base);
  RetargetedScript best;
  int bestScore = -1;
  double bestTurn = 1e9;
  for (double elevation : {0.0, 25.0, -25.0})
    for (int k = 0; k < 12; ++k) {
      const double azimuth = std::remainder(original.azimuthDeg + 30.0 * k, 360.0);
      CameraState c = original;
      c.azimuthDeg = azimuth;
      c.elevationDeg = elevation;
      c.rollDeg = 0.0;
      OrbitCamera cam = base;
      c.target = centre;
      c.applyTo(cam);
      // The target stays in the plane through the volume's centre across the view (framing's depth:
      // its near and far planes hold); within that plane it moves so that the ray through the pinch
      // passes through the aim point. With f, r, u the camera's forward, right and up, h = tan(fov/2)
      // and m the pinch in NDC (y down): A - E = l (f + m.x a h r - m.y h u), E = T - D f.
      const glm::dvec2 m = vp.toNdc(pinchMid);
      const glm::dvec3 f = cam.forward(), rgt = cam.right(), up = cam.up(), d = aim - centre;
      const double h = std::tan(0.5 * cam.fovY), l = glm::dot(d, f) + cam.distance;
      cam.target = centre + rgt * (glm::dot(d, rgt) - l * m.x * aspect * h) + up * (glm::dot(d, up) + l * m.y * h);
      const std::vector<gpu::PickResult> hits = picker.pick(cam, vp, pixels);
      int on = 0, pinchOn = 0, pinchN = 0;
      for (std::size_t i = 0; i < touches.size(); ++i) {
        const bool hit = i < hits.size() && picker.labelAt(hits[i], labels) == label;
        on += hit;
        if (touches[i].pinch) {
          ++pinchN;
          pinchOn += hit;
        }
      }
      // The pinch's fingers count most: the selection must start on the organ.
      const int score = 1000 * pinchOn + on;
      const double turn = angleBetweenDeg(azimuth, original.azimuthDeg) + std::abs(elevation - original.elevationDeg);
      if (score > bestScore || (score == bestScore && turn < bestTurn)) {
        bestScore = score;
        bestTurn = turn;
        best.script = script;
        best.script.camera = CameraState::from(cam);
        best.touchDowns = int(touches.size());
        best.onOrgan = on;
        best.pinchTouches = pinchN;
        best.pinchOnOrgan = pinchOn;
        best.azimuthDeg = azimuth;
        best.elevationDeg = elevation;
      }
    }
  if (best.pinchOnOrgan < best.pinchTouches)
    throw Error("retarget: no view direction puts the pinch's fingers on label " + std::to_string(label) + " (best: " +
                std::to_string(best.pinchOnOrgan) + " of " + std::to_string(best.pinchTouches) + ")");
  if (!volumePath.empty()) {
    best.script.volumeSource = "file";
    best.script.volumePath = volumePath;
  }
  return best;
}

}  // namespace handson
