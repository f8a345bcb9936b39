#include "session.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <string>
#include <vector>
#include <iomanip>
#include <sstream>

#include "render/transfer_function.h"

namespace handson {

Session::Session(const VolumeGeometry& geometry, const Viewport& viewport, std::string preset)
    : geometry_(geometry), gestures_(camera_), preset_(std::move(preset)) {
  gestures_.setViewport(viewport);
  resetCamera();
}

void Session::resetCamera() {
  const Viewport& vp = gestures_.viewport();
  camera_ = OrbitCamera::framing(geometry_, glm::radians(kDefaultAzimuthDeg), glm::radians(kDefaultElevationDeg),
                                 double(vp.width) / double(vp.height));
  gestures_.cancel();
}

void Session::setViewport(const Viewport& v) { gestures_.setViewport(v); }

namespace {

/// Comma-separated finite numbers, exactly n of them.
bool numbers(const std::string& text, std::size_t n, std::vector<float>& out) {
  out.clear();
  std::istringstream in(text);
  std::string item;
  while (std::getline(in, item, ',')) {
    char* end = nullptr;
    const float v = std::strtof(item.c_str(), &end);
    if (item.empty() || end == item.c_str() || *end != '\0' || !std::isfinite(v)) return false;
    out.push_back(v);
  }
  return out.size() == n;
}

/// The clip actions; false (state unchanged) for a malformed value.
bool applyClip(const std::string& action, const std::string& value, Session::Clip& clip) {
  std::vector<float> v;
  if (action == "clear-clip") {
    clip = {};
    return true;
  }
  if (action == "set-clip-box") {
    if (!numbers(value, 6, v) || !(v[0] < v[3] && v[1] < v[4] && v[2] < v[5])) return false;
    clip.box = true;
    clip.lo = {v[0], v[1], v[2]};
    clip.hi = {v[3], v[4], v[5]};
    return true;
  }
  if (!numbers(value, 4, v) || !(glm::length(glm::vec3(v[0], v[1], v[2])) > 1e-6f)) return false;
  clip.plane = true;
  clip.normal = {v[0], v[1], v[2]};
  clip.offset = v[3];
  return true;
}

}  // namespace

bool Session::apply(const ScriptEvent& e) {
  bool ok = true;
  if (e.isTouch) {
    ok = gestures_.handle(e.touch);
  } else if (e.action == "set-mode") {
    InteractionMode m;
    ok = parseMode(e.value, m);
    if (ok) gestures_.setMode(m);
  } else if (e.action == "set-preset") {
    const auto names = transferFunctionPresetNames();
    ok = std::find(names.begin(), names.end(), e.value) != names.end();
    if (ok && e.value != preset_) {
      preset_ = e.value;
      presetChanged_ = true;
    }
  } else if (e.action == "reset-camera") {
    resetCamera();
  } else if (e.action == "toggle-strain") {
    strainOverlay_ = !strainOverlay_;
  } else if (e.action == "toggle-labels") {
    labelTint_ = !labelTint_;
  } else if (e.action == "set-clip-box" || e.action == "set-clip-plane" || e.action == "clear-clip") {
    ok = applyClip(e.action, e.value, clip_);
  } else {
    ok = false;
    for (const auto& f : uiExtensions_)
      if (f(e)) {
        ok = true;
        break;
      }
  }
  if (ok && recording_) script_.events.push_back(e);
  return ok;
}

void Session::startRecording(const SessionScript& header) {
  script_ = header;
  script_.events.clear();
  script_.viewport = gestures_.viewport();
  script_.preset = preset_;
  script_.mode = modeName(gestures_.mode());
  script_.camera = CameraState::from(camera_);
  recording_ = true;
}

std::string describeCamera(const OrbitCamera& c) {
  std::ostringstream s;
  s << std::setprecision(9) << "camera azimuth_deg=" << glm::degrees(c.azimuth) << " elevation_deg=" << glm::degrees(c.elevation)
    << " roll_deg=" << glm::degrees(c.roll) << " distance=" << c.distance << " target=" << c.target.x << "," << c.target.y << "," << c.target.z;
  return s.str();
}

}  // namespace handson
