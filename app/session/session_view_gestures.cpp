// The Session's Clip and Window modes: what one to three fingers do to the clip region and to the
// transfer function's window (the maths in interaction/view_adjust.h). Touches are what scripts
// record here, so a replay feeds the same touches through the same code; the one outside input, the
// point under the finger that places a clip plane, comes from the frame's pick, which a replay
// repeats at the same frame.
#include <algorithm>
#include <cmath>

#include "app/session/session.h"
#include "render/transfer_function.h"

namespace handson {

void Session::onClipTouch(const TouchEvent& e, const TouchInput& input) {
  const Viewport& vp = gestures_.viewport();
  if (e.phase == TouchPhase::Down && input.fingers().size() == 1) {
    // A new drag: a face of the box (today's, or the volume's bounds when there is none), else the plane.
    drag_ = {};
    drag_.finger = e.id;
    drag_.startPx = e.px;
    drag_.startClip = clip_;
    if (clip_.box) {
      drag_.lo = glm::dvec3(clip_.lo);
      drag_.hi = glm::dvec3(clip_.hi);
    } else {
      volumeWorldBox(geometry_, drag_.lo, drag_.hi);
    }
    if (const auto face = boxFaceNear(drag_.lo, drag_.hi, camera_, vp, e.px)) {
      drag_.kind = ViewDrag::Kind::Face;
      drag_.face = *face;
      return;
    }
    drag_.kind = ViewDrag::Kind::Plane;
    const glm::dvec3 n = camera_.forward();
    const double len = glm::length(glm::dvec3(clip_.normal));
    if (clip_.plane && len > 0.0 && glm::dot(glm::dvec3(clip_.normal) / len, n) > 1.0 - 1e-5) {
      drag_.plane = ClipPlaneDrag{n, double(clip_.offset) / len};  // the same view: move today's plane
    } else {
      drag_.pickWanted = true;  // a new plane through the point under the finger
    }
    return;
  }
  if (drag_.kind == ViewDrag::Kind::None || drag_.kind == ViewDrag::Kind::Window) return;
  if (e.phase == TouchPhase::Move && e.id == drag_.finger && input.find(e.id)) {
    drag_.deltaPx = e.px - drag_.startPx;
    if (drag_.kind == ViewDrag::Kind::Face) {
      glm::dvec3 lo = drag_.lo, hi = drag_.hi;
      moveBoxFace(lo, hi, drag_.face, faceDragMm(drag_.lo, drag_.hi, drag_.face, camera_, vp, drag_.deltaPx));
      clip_.box = true;
      clip_.lo = glm::vec3(lo);
      clip_.hi = glm::vec3(hi);
    } else {
      applyPlaneDrag();
    }
  }
  if ((e.phase == TouchPhase::Up || e.phase == TouchPhase::Cancel) && input.fingers().empty() && !drag_.pickWanted && !drag_.pickPending)
    endClipDrag();
}

void Session::endClipDrag() {
  drag_.kind = ViewDrag::Kind::None;
  if (!(clip_ == drag_.startClip)) clipSettled_ = true;
}

void Session::applyPlaneDrag() {
  if (!drag_.plane) return;  // waiting for the pick: applied when it lands
  clip_.plane = true;
  clip_.normal = glm::vec3(drag_.plane->normal);
  clip_.offset = float(drag_.plane->offset + planeDragMm(camera_, gestures_.viewport(), drag_.deltaPx));
}

std::optional<glm::dvec2> Session::takeClipPickRequest() {
  if (drag_.kind != ViewDrag::Kind::Plane || !drag_.pickWanted) return std::nullopt;
  drag_.pickWanted = false;
  drag_.pickPending = true;
  return drag_.startPx;
}

void Session::clipPicked(const std::optional<glm::dvec3>& world) {
  if (drag_.kind != ViewDrag::Kind::Plane || !drag_.pickPending) return;
  drag_.pickPending = false;
  drag_.plane = viewPlaneThrough(camera_, world.value_or(camera_.target));
  applyPlaneDrag();
  if (gestures_.input().fingers().empty()) endClipDrag();
}

void Session::onWindowTouch(const TouchEvent& e, const TouchInput& input) {
  const auto& fingers = input.fingers();
  auto centroid = [&] {
    glm::dvec2 c(0.0);
    for (const auto& f : fingers) c += f.px;
    return fingers.empty() ? c : c / double(fingers.size());
  };
  auto spread = [&] { return fingers.size() >= 2 ? glm::length(fingers[1].px - fingers[0].px) : 0.0; };
  if (fingers.empty()) {
    drag_.kind = ViewDrag::Kind::None;
    return;
  }
  if (drag_.kind != ViewDrag::Kind::Window || fingers.size() != drag_.fingers) {
    // A new drag, or a finger added or lifted: re-anchor where the fingers are, without a jump.
    drag_ = {};
    drag_.kind = ViewDrag::Kind::Window;
    drag_.fingers = fingers.size();
    drag_.startPx = centroid();
    drag_.window = window_;
    drag_.spread0 = spread();
    drag_.width = transferFunctionPreset(preset_).width();  // the level's rate, once a drag
    return;
  }
  if (e.phase != TouchPhase::Move) return;
  const double ratio = drag_.spread0 > 4.0 && spread() > 4.0 ? spread() / drag_.spread0 : 1.0;  // fingers too close: no spread
  const WindowLevel w = windowLevelDrag(drag_.window, centroid() - drag_.startPx, ratio, gestures_.viewport(), drag_.width);
  if (!(w == window_)) {
    window_ = w;
    windowAuto_ = false;  // set by hand: it stays where the fingers put it
    presetChanged_ = true;
  }
}

}  // namespace handson
