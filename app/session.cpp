#include "session.h"

#include <algorithm>
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
