#include "gesture.h"

#include <algorithm>
#include <cmath>

namespace handson {

const char* modeName(InteractionMode m) {
  switch (m) {
    case InteractionMode::Navigate: return "navigate";
    case InteractionMode::Select: return "select";
    case InteractionMode::Manipulate: return "manipulate";
    case InteractionMode::Clip: return "clip";
    case InteractionMode::Window: return "window";
  }
  return "?";
}

bool parseMode(const std::string& s, InteractionMode& out) {
  for (auto m : {InteractionMode::Navigate, InteractionMode::Select, InteractionMode::Manipulate, InteractionMode::Clip, InteractionMode::Window})
    if (s == modeName(m)) {
      out = m;
      return true;
    }
  return false;
}

void GestureRecognizer::setViewport(const Viewport& v) {
  Viewport safe = v;
  safe.width = std::max(1, v.width);
  safe.height = std::max(1, v.height);
  input_.setViewport(safe);
  anchor();
}

void GestureRecognizer::setMode(InteractionMode m) {
  if (m == mode_) return;
  mode_ = m;
  grabbing_ = false;
  anchor();  // fingers already down continue from where they are, in the new mode
}

void GestureRecognizer::setHandler(InteractionMode m, Handler h) {
  if (m == InteractionMode::Select) selectHandler_ = std::move(h);
  if (m == InteractionMode::Manipulate) manipulateHandler_ = std::move(h);
  if (m == InteractionMode::Clip) clipHandler_ = std::move(h);
  if (m == InteractionMode::Window) windowHandler_ = std::move(h);
}

void GestureRecognizer::cancel() {
  input_.cancelAll();
  if (grabbing_ && manipulateHandler_) {
    TouchEvent lifted;
    lifted.phase = TouchPhase::Cancel;
    manipulateHandler_(lifted, input_);  // the manipulation lets go
  }
  grabbing_ = false;
  anchor();
}

double GestureRecognizer::orbitRadiansPerPixel() const { return 3.14159265358979323846 / double(input_.viewport().height); }

void GestureRecognizer::anchor() {
  anchorCamera_ = camera_;
  anchorFingers_ = input_.fingers();
}

bool GestureRecognizer::handle(const TouchEvent& e) {
  const std::size_t before = input_.fingers().size();
  if (!input_.apply(e)) return false;
  if (input_.fingers().size() != before) anchor();
  switch (mode_) {
    case InteractionMode::Navigate:
      if (e.phase == TouchPhase::Down && before == 0 && grabProbe_ && manipulateHandler_) grabbing_ = grabProbe_(e.px);
      if (grabbing_) {
        manipulateHandler_(e, input_);
        if (input_.fingers().empty()) grabbing_ = false;
      } else if (e.phase == TouchPhase::Move) {
        navigate();
      }
      break;
    case InteractionMode::Select:
      if (selectHandler_) selectHandler_(e, input_);
      break;
    case InteractionMode::Manipulate:
      if (manipulateHandler_) manipulateHandler_(e, input_);
      break;
    case InteractionMode::Clip:
      if (clipHandler_) clipHandler_(e, input_);
      break;
    case InteractionMode::Window:
      if (windowHandler_) windowHandler_(e, input_);
      break;
  }
  return true;
}

void GestureRecognizer::navigate() {
  const auto& now = input_.fingers();
  if (now.empty() || anchorFingers_.size() != now.size()) return;
  // Fingers in anchor order (same ids: the set only changes through anchor()).
  auto current = [&](std::size_t i) {
    for (const auto& f : now)
      if (f.id == anchorFingers_[i].id) return f.px;
    return anchorFingers_[i].px;
  };
  const Viewport& vp = input_.viewport();
  if (now.size() == 1) {
    const glm::dvec2 d = current(0) - anchorFingers_[0].px;
    camera_ = anchorCamera_;
    camera_.orbit(d.x * orbitRadiansPerPixel(), d.y * orbitRadiansPerPixel());
    return;
  }
  // Two (or more) fingers: the first two define a similarity of the screen.
  const glm::dvec2 a0 = anchorFingers_[0].px, b0 = anchorFingers_[1].px;
  const glm::dvec2 a = current(0), b = current(1);
  const glm::dvec2 v0 = b0 - a0, v = b - a;
  const double l0 = glm::length(v0), l = glm::length(v);
  double scale = 1.0, twist = 0.0;
  if (l0 > 4.0 && l > 4.0) {  // fingers too close together give no reliable spread or angle
    scale = std::clamp(l / l0, 0.02, 50.0);
    twist = std::atan2(v.y, v.x) - std::atan2(v0.y, v0.x);
  }
  const OrbitCamera& c0 = anchorCamera_;
  const double pix0 = c0.pixelSizeAt(c0.distance, vp.height);
  const glm::dvec2 ctr = vp.center();
  const glm::dvec2 m0 = 0.5 * (a0 + b0), m = 0.5 * (a + b);
  // Point of the target plane under the anchor midpoint.
  const glm::dvec3 X = c0.target + c0.right() * ((m0.x - ctr.x) * pix0) + c0.up() * ((ctr.y - m0.y) * pix0);
  OrbitCamera c = c0;
  c.zoom(scale);
  const double s = c0.distance / c.distance;  // the zoom actually applied (after clamping)
  // Screen y points down, so a clockwise twist on screen is a positive angle; the content turns
  // with the fingers when the camera rolls the other way.
  c.rotateRoll(-twist);
  const double pix = pix0 / s;
  c.target = X - c.right() * ((m.x - ctr.x) * pix) - c.up() * ((ctr.y - m.y) * pix);
  camera_ = c;
}

}  // namespace handson
