#pragma once
// SDL events -> touch events. Native multi-touch (SDL_FINGERDOWN/MOTION/UP) is used as it is;
// the mouse is a fallback that emulates fingers (a pen arrives through SDL2 as mouse or touch):
//   left drag               one finger
//   Shift + left drag       two fingers moving together (pan)
//   Ctrl + left drag        two fingers mirrored about the window centre (pinch to zoom, twist to roll)
//   Ctrl + Shift + left drag  three fingers moving together
//   wheel                   a short two-finger pinch about the cursor
// Mouse events that SDL synthesizes from touches (which == SDL_TOUCH_MOUSEID) are left to the UI;
// with SDL_MOUSE_TOUCH_EVENTS=1 the mouse already arrives as touches and the fallback is off.
#include <SDL2/SDL.h>

#include <functional>
#include <vector>

#include "interaction/touch.h"

namespace handson {

class SdlInput {
 public:
  explicit SdlInput(SDL_Window* window);

  /// Decides whether a press at a drawable pixel belongs to the UI.
  using UiHitTest = std::function<bool(double x, double y)>;
  /// Appends the touch events an SDL event means. `time` stamps them (session clock). Presses that
  /// land on the UI start no finger; fingers already down keep moving.
  void translate(const SDL_Event& e, double time, const Viewport& drawable, const UiHitTest& onUi, std::vector<TouchEvent>& out);
  bool mouseFallbackEnabled() const { return mouseFallback_; }

  static constexpr std::int64_t kMouseFingerBase = 1'000'000'000;

 private:
  void emulate(glm::dvec2 mouse, TouchPhase phase, double time, std::vector<TouchEvent>& out);
  glm::dvec2 toDrawable(int x, int y) const;

  SDL_Window* window_;
  bool mouseFallback_ = true;
  int emulated_ = 0;          // fingers of the current mouse drag (0: none)
  bool mirrored_ = false;     // Ctrl: second finger mirrored about the centre
  glm::dvec2 centre_{0.0};
  std::vector<std::int64_t> uiFingers_;  // touches that began on the UI
};

}  // namespace handson
