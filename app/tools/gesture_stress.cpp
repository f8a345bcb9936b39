#include "gesture_stress.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "sim/base/error.h"

namespace handson {

namespace {

// The stream's generator: one random number engine, the script written so far, the fingers whose
// lift was lost. Sequences are appended in order; each draws from the engine in a fixed order, so
// a seed gives one stream.
class GestureStream {
 public:
  explicit GestureStream(const GestureStreamOptions& o) : o_(o), rng_(o.seed), w_(o.viewport.width), h_(o.viewport.height) {
    s_.viewport = o.viewport;
    s_.mode = "select";
  }

  SessionScript take() {
    std::stable_sort(s_.events.begin(), s_.events.end(), [](const ScriptEvent& a, const ScriptEvent& b) { return a.t < b.t; });
    return std::move(s_);
  }

  void sequence(int q) {
    const double t0 = q * o_.secondsPerSequence, dt = o_.secondsPerSequence / 16.0;
    t_ = t0;
    if (chance(0.3)) randomUi();
    if (!stuck_.empty() && chance(0.15)) {  // the platform cancels what it lost (as on a focus change)
      for (std::int64_t id : stuck_) touch(TouchPhase::Cancel, id, point());
      stuck_.clear();
    }
    // A quarter of the sequences are well-formed, so that the stream builds state to break: a pinch
    // in select mode or a one- to three-finger drag in manipulate mode, near the view's centre.
    const int kind = pick(8);
    if (kind <= 1) cleanGesture(kind, t0, dt);
    else wildGesture(t0, dt);
  }

 private:
  double uniform(double a, double b) { return std::uniform_real_distribution<double>(a, b)(rng_); }
  bool chance(double p) { return uniform(0.0, 1.0) < p; }
  int pick(int n) { return std::uniform_int_distribution<int>(0, n - 1)(rng_); }

  glm::dvec2 point() {
    const double nan = std::numeric_limits<double>::quiet_NaN(), inf = std::numeric_limits<double>::infinity();
    const double r = uniform(0.0, 1.0);
    if (r < 0.03) return {nan, uniform(0, h_)};
    if (r < 0.04) return {uniform(0, w_), -inf};
    if (r < 0.10) return {uniform(-5 * w_, 6 * w_), uniform(-5 * h_, 6 * h_)};  // far outside the window
    if (r < 0.12) return {1e12, -1e12};
    return {uniform(0, w_), uniform(0, h_)};
  }
  void ui(UiAction action, const std::string& value) { s_.events.push_back(uiEvent(t_, action, value)); }
  void touch(TouchPhase phase, std::int64_t id, glm::dvec2 px) {
    const double nan = std::numeric_limits<double>::quiet_NaN();
    const double pressure = chance(0.05) ? (chance(0.5) ? nan : uniform(-2.0, 3.0)) : uniform(0.2, 1.0);
    s_.events.push_back(touchEvent(t_, phase, id, px, pressure));
  }

  void randomUi() {
    const char* modes[] = {"navigate", "select", "select", "manipulate", "manipulate", "clip", "window"};
    const char* statuses[] = {"active", "fixed", "idle"};
    const char* locks[] = {"z-translation", "z-rotation", "xy-translation"};
    const int a = 1 + pick(4), b = 1 + pick(4);
    switch (pick(9)) {
      case 0: ui(UiAction::SetMode, modes[pick(7)]); break;
      case 1: ui(UiAction::HandleStatus, std::to_string(a) + ":" + statuses[pick(3)]); break;
      case 2: ui(UiAction::HandleUnion, std::to_string(a) + "," + std::to_string(b)); break;
      case 3: ui(UiAction::HandleDifference, std::to_string(a) + "," + std::to_string(b)); break;
      case 4: ui(chance(0.5) ? UiAction::Undo : UiAction::Redo, ""); break;
      case 5: ui(UiAction::HandleDelete, std::to_string(a)); break;
      case 6: ui(UiAction::ToggleLock, locks[pick(3)]); break;
      case 7: ui(UiAction::ResetCamera, ""); break;
      default: ui(UiAction::SetMode, modes[pick(5)]); break;
    }
  }

  // A pinch in select mode (kind 0) or a one- to three-finger drag in manipulate mode (kind 1).
  void cleanGesture(int kind, double t0, double dt) {
    ui(UiAction::SetMode, kind == 0 ? "select" : "manipulate");
    const int fingers = kind == 0 ? 2 : 1 + pick(3);
    const glm::dvec2 c(w_ * uniform(0.35, 0.65), h_ * uniform(0.35, 0.65));
    std::vector<glm::dvec2> p0, p1;
    for (int f = 0; f < fingers; ++f) {
      const double a = 2.0 * 3.141592653589793 * f / fingers + uniform(0.0, 1.0);
      const glm::dvec2 d = glm::dvec2(std::cos(a), std::sin(a)) * w_ * uniform(0.03, 0.08);
      p0.push_back(c + d);
      p1.push_back(kind == 0 ? c + d * uniform(1.2, 2.5) : c + d + glm::dvec2(uniform(-0.1, 0.1) * w_, uniform(-0.1, 0.1) * h_));
    }
    std::vector<std::int64_t> clean;
    for (int f = 0; f < fingers; ++f) {
      clean.push_back(nextId_++);
      touch(TouchPhase::Down, clean.back(), p0[std::size_t(f)]);
    }
    for (int m = 1; m <= 12; ++m) {
      t_ = t0 + m * dt;
      for (int f = 0; f < fingers; ++f) touch(TouchPhase::Move, clean[std::size_t(f)], glm::mix(p0[std::size_t(f)], p1[std::size_t(f)], m / 12.0));
    }
    t_ = t0 + 15 * dt;
    for (int f = 0; f < fingers; ++f) touch(TouchPhase::Up, clean[std::size_t(f)], p1[std::size_t(f)]);
  }

  // Anything goes. Fingers: usually 1-3, sometimes up to 20; a lost finger may come back.
  void wildGesture(double t0, double dt) {
    const int n = chance(0.05) ? 4 + pick(17) : 1 + pick(3);
    std::vector<std::int64_t> ids;
    std::vector<glm::dvec2> at;
    for (int f = 0; f < n; ++f) {
      const bool reuse = !stuck_.empty() && chance(0.3);
      ids.push_back(reuse ? stuck_[std::size_t(pick(int(stuck_.size())))] : nextId_++);
      at.push_back(point());
      touch(TouchPhase::Down, ids.back(), at.back());
      if (chance(0.2)) t_ += dt * 0.5;
    }
    wildMoves(at, ids, t0, dt);
    t_ = t0 + 15 * dt;
    for (std::size_t f = 0; f < ids.size(); ++f) {
      if (chance(0.05)) {  // the lift is lost
        if (std::find(stuck_.begin(), stuck_.end(), ids[f]) == stuck_.end()) stuck_.push_back(ids[f]);
        continue;
      }
      touch(chance(0.03) ? TouchPhase::Cancel : TouchPhase::Up, ids[f], chance(0.1) ? point() : at[f]);
      stuck_.erase(std::remove(stuck_.begin(), stuck_.end(), ids[f]), stuck_.end());
    }
  }

  // The fingers drift, spread and twist about their centre; some frames miss a finger, a UI action
  // or a tap elsewhere may come mid-gesture, and a finger may jump anywhere.
  void wildMoves(std::vector<glm::dvec2>& at, const std::vector<std::int64_t>& ids, double t0, double dt) {
    const int moves = pick(12);
    const glm::dvec2 drift(uniform(-8, 8), uniform(-8, 8));
    const double spread = uniform(-0.1, 0.1), twist = uniform(-0.2, 0.2);
    glm::dvec2 centre(0.0);
    for (const auto& p : at) centre += p / double(at.size());
    for (int m = 0; m < moves; ++m) {
      t_ = std::min(t_ + dt, t0 + 14 * dt);
      if (chance(0.05)) randomUi();  // a mode switch or edit mid-gesture
      if (chance(0.05)) {            // a tap elsewhere during the drag
        const std::int64_t tap = nextId_++;
        const glm::dvec2 p = point();
        touch(TouchPhase::Down, tap, p);
        touch(TouchPhase::Up, tap, p);
      }
      for (std::size_t f = 0; f < at.size(); ++f) {
        if (chance(0.3)) continue;  // not every finger reports every frame
        glm::dvec2 d = at[f] - centre;
        d = glm::dvec2(std::cos(twist) * d.x - std::sin(twist) * d.y, std::sin(twist) * d.x + std::cos(twist) * d.y) * (1.0 + spread);
        at[f] = chance(0.02) ? point() : centre + d + drift;
        touch(TouchPhase::Move, ids[f], at[f]);
      }
      centre += drift;
    }
  }

  const GestureStreamOptions& o_;
  std::mt19937 rng_;
  double w_, h_;
  SessionScript s_;
  std::vector<std::int64_t> stuck_;  // fingers whose lift was lost: still down in the app
  std::int64_t nextId_ = 1;
  double t_ = 0.0;  // the time of the events written next
};

}  // namespace

SessionScript randomGestureStream(const GestureStreamOptions& o) {
  if (o.sequences < 0 || o.sequences > 10'000'000) throw Error("gesture stream: 0 to 10,000,000 sequences");
  if (o.viewport.width < 1 || o.viewport.height < 1) throw Error("gesture stream: the viewport must be at least 1 x 1");
  if (!(o.secondsPerSequence > 0.0)) throw Error("gesture stream: secondsPerSequence must be positive");
  GestureStream stream(o);
  for (int q = 0; q < o.sequences; ++q) stream.sequence(q);
  return stream.take();
}

}  // namespace handson
