#pragma once
// The touch model, independent of SDL: fingers with an id, a position in pixels (and NDC), a
// timestamp and a pressure, going down, moving, going up or being cancelled. TouchInput keeps the
// set of fingers on the screen and never trusts its input: unknown ids, ups without downs, an
// eleventh finger, NaN or far-away coordinates are refused with a reason, never a crash.
#include <glm/glm.hpp>

#include <cstdint>
#include <string>
#include <vector>

namespace handson {

enum class TouchPhase : std::uint8_t { Down, Move, Up, Cancel };
const char* touchPhaseName(TouchPhase p);

struct Viewport {
  int width = 1, height = 1;
  /// Pixel (x right, y down) to Vulkan NDC (x right, y down, [-1, 1] across the viewport).
  glm::dvec2 toNdc(glm::dvec2 px) const { return {2.0 * px.x / width - 1.0, 2.0 * px.y / height - 1.0}; }
  glm::dvec2 center() const { return {0.5 * width, 0.5 * height}; }
};

struct TouchEvent {
  TouchPhase phase = TouchPhase::Down;
  std::int64_t id = 0;      ///< finger id, unique while the finger is down
  glm::dvec2 px{0.0};       ///< position in pixels of the viewport
  double pressure = 1.0;    ///< 0..1 (1 when the device does not report it)
  double time = 0.0;        ///< seconds (session clock)
};

struct Finger {
  std::int64_t id = 0;
  glm::dvec2 px{0.0}, downPx{0.0};
  double pressure = 1.0;
  double downTime = 0.0, time = 0.0;
};

class TouchInput {
 public:
  static constexpr std::size_t kMaxFingers = 10;

  void setViewport(const Viewport& v) { viewport_ = v; }
  const Viewport& viewport() const { return viewport_; }

  /// Applies one event. Returns false (and a reason in *why) if the event was refused; the finger
  /// set is then unchanged. A Down for a finger already down is treated as a Move. Coordinates
  /// outside the viewport are accepted within one viewport size of it (fingers slide off the
  /// edge), clamped to that margin; NaN or infinite values are refused.
  bool apply(const TouchEvent& e, std::string* why = nullptr);
  /// Lifts every finger (window lost focus, mode change, reset).
  void cancelAll();

  const std::vector<Finger>& fingers() const { return fingers_; }
  const Finger* find(std::int64_t id) const;
  std::size_t refusedCount() const { return refused_; }

 private:
  Viewport viewport_;
  std::vector<Finger> fingers_;
  std::size_t refused_ = 0;
};

}  // namespace handson
