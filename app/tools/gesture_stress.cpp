#include "gesture_stress.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "sim/error.h"

namespace handson {

SessionScript randomGestureStream(const GestureStreamOptions& o) {
  if (o.sequences < 0 || o.sequences > 10'000'000) throw Error("gesture stream: 0 to 10,000,000 sequences");
  if (o.viewport.width < 1 || o.viewport.height < 1) throw Error("gesture stream: the viewport must be at least 1 x 1");
  if (!(o.secondsPerSequence > 0.0)) throw Error("gesture stream: secondsPerSequence must be positive");
  std::mt19937 rng(o.seed);
  auto uniform = [&](double a, double b) { return std::uniform_real_distribution<double>(a, b)(rng); };
  auto chance = [&](double p) { return uniform(0.0, 1.0) < p; };
  auto pick = [&](int n) { return std::uniform_int_distribution<int>(0, n - 1)(rng); };
  const double w = o.viewport.width, h = o.viewport.height;
  const double nan = std::numeric_limits<double>::quiet_NaN(), inf = std::numeric_limits<double>::infinity();

  SessionScript s;
  s.viewport = o.viewport;
  s.mode = "select";
  std::vector<std::int64_t> stuck;  // fingers whose lift was lost: still down in the app
  std::int64_t nextId = 1;
  auto point = [&]() -> glm::dvec2 {
    const double r = uniform(0.0, 1.0);
    if (r < 0.03) return {nan, uniform(0, h)};
    if (r < 0.04) return {uniform(0, w), -inf};
    if (r < 0.10) return {uniform(-5 * w, 6 * w), uniform(-5 * h, 6 * h)};  // far outside the window
    if (r < 0.12) return {1e12, -1e12};
    return {uniform(0, w), uniform(0, h)};
  };
  for (int q = 0; q < o.sequences; ++q) {
    const double t0 = q * o.secondsPerSequence, dt = o.secondsPerSequence / 16.0;
    double t = t0;
    auto ui = [&](const std::string& action, const std::string& value) { s.events.push_back(uiEvent(t, action, value)); };
    auto touch = [&](TouchPhase phase, std::int64_t id, glm::dvec2 px) {
      const double pressure = chance(0.05) ? (chance(0.5) ? nan : uniform(-2.0, 3.0)) : uniform(0.2, 1.0);
      s.events.push_back(touchEvent(t, phase, id, px, pressure));
    };
    auto randomUi = [&]() {
      const char* modes[] = {"navigate", "select", "select", "manipulate", "manipulate", "clip", "window"};
      const char* statuses[] = {"active", "fixed", "idle"};
      const char* locks[] = {"z-translation", "z-rotation", "xy-translation"};
      const int a = 1 + pick(4), b = 1 + pick(4);
      switch (pick(9)) {
        case 0: ui("set-mode", modes[pick(7)]); break;
        case 1: ui("handle-status", std::to_string(a) + ":" + statuses[pick(3)]); break;
        case 2: ui("handle-union", std::to_string(a) + "," + std::to_string(b)); break;
        case 3: ui("handle-difference", std::to_string(a) + "," + std::to_string(b)); break;
        case 4: ui(chance(0.5) ? "undo" : "redo", ""); break;
        case 5: ui("handle-delete", std::to_string(a)); break;
        case 6: ui("toggle-lock", locks[pick(3)]); break;
        case 7: ui("reset-camera", ""); break;
        default: ui("set-mode", modes[pick(5)]); break;
      }
    };
    if (chance(0.3)) randomUi();
    if (!stuck.empty() && chance(0.15)) {  // the platform cancels what it lost (as on a focus change)
      for (std::int64_t id : stuck) touch(TouchPhase::Cancel, id, point());
      stuck.clear();
    }
    // A quarter of the sequences are well-formed, so that the stream builds state to break: a pinch
    // in select mode or a one- to three-finger drag in manipulate mode, near the view's centre.
    const int kind = pick(8);
    if (kind <= 1) {
      ui("set-mode", kind == 0 ? "select" : "manipulate");
      const int fingers = kind == 0 ? 2 : 1 + pick(3);
      const glm::dvec2 c(w * uniform(0.35, 0.65), h * uniform(0.35, 0.65));
      std::vector<glm::dvec2> p0, p1;
      for (int f = 0; f < fingers; ++f) {
        const double a = 2.0 * 3.141592653589793 * f / fingers + uniform(0.0, 1.0);
        const glm::dvec2 d = glm::dvec2(std::cos(a), std::sin(a)) * w * uniform(0.03, 0.08);
        p0.push_back(c + d);
        p1.push_back(kind == 0 ? c + d * uniform(1.2, 2.5) : c + d + glm::dvec2(uniform(-0.1, 0.1) * w, uniform(-0.1, 0.1) * h));
      }
      std::vector<std::int64_t> clean;
      for (int f = 0; f < fingers; ++f) {
        clean.push_back(nextId++);
        touch(TouchPhase::Down, clean.back(), p0[std::size_t(f)]);
      }
      for (int m = 1; m <= 12; ++m) {
        t = t0 + m * dt;
        for (int f = 0; f < fingers; ++f) touch(TouchPhase::Move, clean[std::size_t(f)], glm::mix(p0[std::size_t(f)], p1[std::size_t(f)], m / 12.0));
      }
      t = t0 + 15 * dt;
      for (int f = 0; f < fingers; ++f) touch(TouchPhase::Up, clean[std::size_t(f)], p1[std::size_t(f)]);
      continue;
    }
    // Otherwise anything goes. Fingers: usually 1-3, sometimes up to 20; a lost finger may come back.
    const int n = chance(0.05) ? 4 + pick(17) : 1 + pick(3);
    std::vector<std::int64_t> ids;
    std::vector<glm::dvec2> at;
    for (int f = 0; f < n; ++f) {
      const bool reuse = !stuck.empty() && chance(0.3);
      ids.push_back(reuse ? stuck[std::size_t(pick(int(stuck.size())))] : nextId++);
      at.push_back(point());
      touch(TouchPhase::Down, ids.back(), at.back());
      if (chance(0.2)) t += dt * 0.5;
    }
    const int moves = pick(12);
    const glm::dvec2 drift(uniform(-8, 8), uniform(-8, 8));
    const double spread = uniform(-0.1, 0.1), twist = uniform(-0.2, 0.2);
    glm::dvec2 centre(0.0);
    for (const auto& p : at) centre += p / double(at.size());
    for (int m = 0; m < moves; ++m) {
      t = std::min(t + dt, t0 + 14 * dt);
      if (chance(0.05)) randomUi();  // a mode switch or edit mid-gesture
      if (chance(0.05)) {            // a tap elsewhere during the drag
        const std::int64_t tap = nextId++;
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
    t = t0 + 15 * dt;
    for (std::size_t f = 0; f < ids.size(); ++f) {
      if (chance(0.05)) {  // the lift is lost
        if (std::find(stuck.begin(), stuck.end(), ids[f]) == stuck.end()) stuck.push_back(ids[f]);
        continue;
      }
      touch(chance(0.03) ? TouchPhase::Cancel : TouchPhase::Up, ids[f], chance(0.1) ? point() : at[f]);
      stuck.erase(std::remove(stuck.begin(), stuck.end(), ids[f]), stuck.end());
    }
  }
  std::stable_sort(s.events.begin(), s.events.end(), [](const ScriptEvent& a, const ScriptEvent& b) { return a.t < b.t; });
  return s;
}

}  // namespace handson
