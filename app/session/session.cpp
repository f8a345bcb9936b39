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
  gestures_.setHandler(InteractionMode::Clip, [this](const TouchEvent& e, const TouchInput& in) { onClipTouch(e, in); });
  gestures_.setHandler(InteractionMode::Window, [this](const TouchEvent& e, const TouchInput& in) { onWindowTouch(e, in); });
  resetCamera();
}

void Session::resetCamera() {
  move_.reset();
  const Viewport& vp = framingViewport_ ? *framingViewport_ : gestures_.viewport();
  const double az = glm::radians(kDefaultAzimuthDeg), el = glm::radians(kDefaultElevationDeg);
  camera_ = freeArea_.whole() ? OrbitCamera::framing(geometry_, az, el, double(vp.width) / double(vp.height))
                              : OrbitCamera::framingIn(geometry_, az, el, FramingView{vp.width, vp.height, freeArea_});
  gestures_.cancel();
  if (recording_ && script_.events.empty()) script_.camera = CameraState::from(camera_);
}

void Session::setFreeArea(const ScreenArea& area) {
  freeArea_ = area.valid() ? area : ScreenArea{};
  if (recording_) script_.freeArea = freeArea_.whole() ? std::nullopt : std::optional<ScreenArea>(freeArea_);
}

void Session::setViewport(const Viewport& v) { gestures_.setViewport(v); }

namespace {

/// The clip actions; false (state unchanged) for a malformed value.
bool applyClip(UiAction action, const std::string& value, ClipRegion& clip) {
  if (action == UiAction::ClearClip) {
    clip = {};
    return true;
  }
  return (action == UiAction::SetClipBox ? parseClipBox(value, clip) : parseClipPlane(value, clip)).empty();
}

/// "SCALE,SHIFT,OPACITY" (finite, scale and opacity > 0); false (unchanged) otherwise.
bool parseWindow(const std::string& value, WindowLevel& w) {
  std::istringstream in(value);
  WindowLevel v;
  char c1 = 0, c2 = 0;
  if (!(in >> v.scale >> c1 >> v.shift >> c2 >> v.opacity) || c1 != ',' || c2 != ',' || !(in >> std::ws).eof()) return false;
  if (!std::isfinite(v.scale) || !std::isfinite(v.shift) || !std::isfinite(v.opacity) || !(v.scale > 0.0) || !(v.opacity > 0.0)) return false;
  w = v;
  return true;
}

}  // namespace

bool Session::apply(const ScriptEvent& e) {
  // A framing in progress is where it is at the event's time (not at the last frame's): a finger
  // stops it there, a new framing starts from there, live and in a replay alike.
  if (move_) advance(e.t);
  bool ok = true;
  if (e.isTouch) {
    move_.reset();  // a finger stops a framing where it is: the gesture acts on the camera shown
    ok = gestures_.handle(e.touch);
  } else if (const std::optional<bool> view = applyViewAction(e)) {
    ok = *view;
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

std::optional<bool> Session::applyViewAction(const ScriptEvent& e) {
  switch (e.action) {
    case UiAction::SetMode: {
      InteractionMode m;
      if (!parseMode(e.value, m)) return false;
      gestures_.setMode(m);
      return true;
    }
    case UiAction::SetPreset: return setPreset(e.value);
    case UiAction::SetWindow:
    case UiAction::ResetWindow: {
      WindowLevel w;
      if (e.action == UiAction::SetWindow && !parseWindow(e.value, w)) return false;
      windowAuto_ = false;
      if (!(w == window_)) {
        window_ = w;
        presetChanged_ = true;
      }
      return true;
    }
    case UiAction::ResetCamera: resetCamera(); return true;
    case UiAction::FrameClip: {
      const Viewport& vp = framingViewport_ ? *framingViewport_ : gestures_.viewport();
      const std::optional<OrbitCamera> to = frameClip(camera_, geometry_, clip_, FramingView{vp.width, vp.height, freeArea_});
      const OrbitCamera before = camera_;
      if (!frameTo(to, e.t)) return false;
      beforeFraming_ = before;
      return true;
    }
    case UiAction::CameraBack: return frameTo(std::exchange(beforeFraming_, std::nullopt), e.t);
    case UiAction::ToggleStrain: strainOverlay_ = !strainOverlay_; return true;
    case UiAction::ToggleLimits: limitHighlight_ = !limitHighlight_; return true;
    case UiAction::ToggleLabels: labelTint_ = !labelTint_; return true;
    case UiAction::SetClipBox:
    case UiAction::SetClipPlane:
    case UiAction::ClearClip: return applyClip(e.action, e.value, clip_);
    default: return std::nullopt;  // not the view's: the extensions'
  }
}

bool Session::setPreset(const std::string& name) {
  const auto names = transferFunctionPresetNames();
  if (std::find(names.begin(), names.end(), name) == names.end()) return false;
  if (name != preset_) {
    preset_ = name;
    window_ = {};
    windowAuto_ = false;
    presetChanged_ = true;
  }
  return true;
}

void Session::setAutomaticWindow(const WindowLevel& w) {
  if (!(w == window_)) presetChanged_ = true;
  window_ = w;
  windowAuto_ = true;
}

bool Session::frameTo(std::optional<OrbitCamera> to, double t) {
  if (!to) return false;
  gestures_.cancel();
  move_ = CameraMove{camera_, *to, t, kFramingSeconds};
  return true;
}

void Session::stopFraming() {
  move_.reset();
  beforeFraming_.reset();
}

void Session::advance(double t) {
  if (!move_) return;
  camera_ = move_->at(t);
  if (move_->done(t)) move_.reset();
}

void Session::startRecording(const SessionScript& header) {
  script_ = header;
  script_.events.clear();
  script_.viewport = gestures_.viewport();
  script_.preset = preset_;
  script_.mode = modeName(gestures_.mode());
  script_.camera = CameraState::from(camera_);
  script_.freeArea = freeArea_.whole() ? std::nullopt : std::optional<ScreenArea>(freeArea_);
  recording_ = true;
}

std::string describeCamera(const OrbitCamera& c) {
  std::ostringstream s;
  s << std::setprecision(9) << "camera azimuth_deg=" << glm::degrees(c.azimuth) << " elevation_deg=" << glm::degrees(c.elevation)
    << " roll_deg=" << glm::degrees(c.roll) << " distance=" << c.distance << " target=" << c.target.x << "," << c.target.y << "," << c.target.z;
  return s.str();
}

}  // namespace handson
