#include "touch.h"

#include <algorithm>
#include <cmath>

namespace handson {

const char* touchPhaseName(TouchPhase p) {
  switch (p) {
    case TouchPhase::Down: return "down";
    case TouchPhase::Move: return "move";
    case TouchPhase::Up: return "up";
    case TouchPhase::Cancel: return "cancel";
  }
  return "?";
}

const Finger* TouchInput::find(std::int64_t id) const {
  for (const auto& f : fingers_)
    if (f.id == id) return &f;
  return nullptr;
}

bool TouchInput::apply(const TouchEvent& e, std::string* why) {
  auto refuse = [&](const char* reason) {
    ++refused_;
    if (why) *why = reason;
    return false;
  };
  if (!std::isfinite(e.px.x) || !std::isfinite(e.px.y)) return refuse("non-finite coordinates");
  if (!std::isfinite(e.time)) return refuse("non-finite timestamp");
  const glm::dvec2 lo(-viewport_.width, -viewport_.height), hi(2.0 * viewport_.width, 2.0 * viewport_.height);
  const glm::dvec2 px = glm::clamp(e.px, lo, hi);
  const double pressure = std::isfinite(e.pressure) ? std::clamp(e.pressure, 0.0, 1.0) : 1.0;
  auto it = std::find_if(fingers_.begin(), fingers_.end(), [&](const Finger& f) { return f.id == e.id; });
  switch (e.phase) {
    case TouchPhase::Down:
      if (it != fingers_.end()) {  // a repeated down: treat as a move
        it->px = px;
        it->pressure = pressure;
        it->time = e.time;
        return true;
      }
      if (fingers_.size() >= kMaxFingers) return refuse("more than 10 fingers");
      fingers_.push_back(Finger{e.id, px, px, pressure, e.time, e.time});
      return true;
    case TouchPhase::Move:
      if (it == fingers_.end()) return refuse("move of a finger that is not down");
      it->px = px;
      it->pressure = pressure;
      it->time = e.time;
      return true;
    case TouchPhase::Up:
    case TouchPhase::Cancel:
      if (it == fingers_.end()) return refuse("up of a finger that is not down");
      fingers_.erase(it);
      return true;
  }
  return refuse("unknown phase");
}

void TouchInput::cancelAll() { fingers_.clear(); }

}  // namespace handson
