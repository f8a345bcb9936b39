#include "sdl_input.h"

#include <algorithm>
#include <SDL2/SDL_vulkan.h>

#include <cmath>

namespace handson {

SdlInput::SdlInput(SDL_Window* window) : window_(window) {
  mouseFallback_ = !SDL_GetHintBoolean(SDL_HINT_MOUSE_TOUCH_EVENTS, SDL_FALSE);
}

glm::dvec2 SdlInput::toDrawable(int x, int y) const {
  int ww = 1, wh = 1, dw = 1, dh = 1;
  SDL_GetWindowSize(window_, &ww, &wh);
  SDL_Vulkan_GetDrawableSize(window_, &dw, &dh);
  return {double(x) * dw / std::max(ww, 1), double(y) * dh / std::max(wh, 1)};
}

void SdlInput::emulate(glm::dvec2 mouse, TouchPhase phase, double time, std::vector<TouchEvent>& out) {
  static const glm::dvec2 kOffsets[3] = {{0, 0}, {120, 0}, {60, 100}};
  for (int k = 0; k < emulated_; ++k) {
    TouchEvent e;
    e.phase = phase;
    e.id = kMouseFingerBase + k;
    e.time = time;
    e.px = (k == 1 && mirrored_) ? 2.0 * centre_ - mouse : mouse + kOffsets[k];
    out.push_back(e);
  }
}

void SdlInput::translate(const SDL_Event& e, double time, const Viewport& vp, const UiHitTest& onUi, std::vector<TouchEvent>& out) {
  switch (e.type) {
    case SDL_FINGERDOWN:
    case SDL_FINGERMOTION:
    case SDL_FINGERUP: {
      TouchEvent t;
      t.id = (std::int64_t(e.tfinger.touchId) << 24) ^ std::int64_t(e.tfinger.fingerId);
      t.px = {double(e.tfinger.x) * vp.width, double(e.tfinger.y) * vp.height};
      t.pressure = e.tfinger.pressure > 0.0f ? e.tfinger.pressure : 1.0;
      t.time = time;
      t.phase = e.type == SDL_FINGERDOWN ? TouchPhase::Down : e.type == SDL_FINGERUP ? TouchPhase::Up : TouchPhase::Move;
      auto ui = std::find(uiFingers_.begin(), uiFingers_.end(), t.id);
      if (t.phase == TouchPhase::Down && onUi && onUi(t.px.x, t.px.y)) {
        uiFingers_.push_back(t.id);
        return;
      }
      if (ui != uiFingers_.end()) {  // a touch that belongs to the UI
        if (t.phase == TouchPhase::Up) uiFingers_.erase(ui);
        return;
      }
      out.push_back(t);
      return;
    }
    case SDL_MOUSEBUTTONDOWN:
      if (!mouseFallback_ || e.button.which == SDL_TOUCH_MOUSEID || e.button.button != SDL_BUTTON_LEFT || emulated_) return;
      {
        const glm::dvec2 at = toDrawable(e.button.x, e.button.y);
        if (onUi && onUi(at.x, at.y)) return;
        const SDL_Keymod mod = SDL_GetModState();
        const bool shift = mod & KMOD_SHIFT, ctrl = mod & KMOD_CTRL;
        emulated_ = (shift && ctrl) ? 3 : (shift || ctrl) ? 2 : 1;
        mirrored_ = ctrl && !shift;
        centre_ = vp.center();
        emulate(toDrawable(e.button.x, e.button.y), TouchPhase::Down, time, out);
      }
      return;
    case SDL_MOUSEMOTION:
      if (emulated_ && e.motion.which != SDL_TOUCH_MOUSEID) emulate(toDrawable(e.motion.x, e.motion.y), TouchPhase::Move, time, out);
      return;
    case SDL_MOUSEBUTTONUP:
      if (emulated_ && e.button.which != SDL_TOUCH_MOUSEID && e.button.button == SDL_BUTTON_LEFT) {
        emulate(toDrawable(e.button.x, e.button.y), TouchPhase::Up, time, out);
        emulated_ = 0;
      }
      return;
    case SDL_MOUSEWHEEL: {
      if (!mouseFallback_ || e.wheel.which == SDL_TOUCH_MOUSEID || emulated_ || e.wheel.y == 0) return;
      int mx = 0, my = 0;
      SDL_GetMouseState(&mx, &my);
      const glm::dvec2 c = toDrawable(mx, my);
      if (onUi && onUi(c.x, c.y)) return;
      const double spread = 60.0, factor = std::pow(1.15, std::clamp(e.wheel.y, -10, 10));
      const std::int64_t a = kMouseFingerBase + 10, b = kMouseFingerBase + 11;
      const glm::dvec2 d(spread, 0.0);
      out.push_back({TouchPhase::Down, a, c - d, 1.0, time});
      out.push_back({TouchPhase::Down, b, c + d, 1.0, time});
      out.push_back({TouchPhase::Move, a, c - d * factor, 1.0, time});
      out.push_back({TouchPhase::Move, b, c + d * factor, 1.0, time});
      out.push_back({TouchPhase::Up, a, c - d * factor, 1.0, time});
      out.push_back({TouchPhase::Up, b, c + d * factor, 1.0, time});
      return;
    }
    case SDL_WINDOWEVENT:
      if (e.window.event == SDL_WINDOWEVENT_FOCUS_LOST && emulated_) {
        int mx = 0, my = 0;
        SDL_GetMouseState(&mx, &my);
        emulate(toDrawable(mx, my), TouchPhase::Cancel, time, out);
        emulated_ = 0;
      }
      return;
    default: return;
  }
}

}  // namespace handson
