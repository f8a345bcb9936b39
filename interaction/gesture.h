#pragma once
// The gesture recognizer: a state machine with five modes. In Navigate mode fingers drive the
// camera; Select, Manipulate, Clip and Window forward the fingers to handlers that the selection,
// manipulation, clipping and transfer-function features plug in (interaction/view_adjust.h says
// what fingers mean in the last two).
//
// Navigate:
//  - one finger orbits: a drag across the viewport's height turns the view by 180 degrees, the
//    object following the finger (right drag: azimuth grows; down drag: elevation grows);
//  - two fingers act as a similarity of the screen: the spread zooms, the twist rolls and the
//    centroid pans, computed from the positions at the last change of finger count (no drift), so
//    that the points of the plane through the camera target that lay under the two fingers stay
//    under them;
//  - further fingers are ignored in navigation; adding or lifting a finger re-anchors without a jump.
//  - a gesture whose first finger lands on something the grab probe claims (a handle) is not
//    navigation: all of its events, up to the last finger lifted, go to the Manipulate handler.
#include <functional>

#include "camera.h"
#include "touch.h"

namespace handson {

enum class InteractionMode : std::uint8_t { Navigate, Select, Manipulate, Clip, Window };
const char* modeName(InteractionMode m);
/// Parses "navigate", "select", "manipulate", "clip", "window"; false on anything else.
bool parseMode(const std::string& s, InteractionMode& out);

class GestureRecognizer {
 public:
  /// Called in Select / Manipulate / Clip / Window mode after each accepted event, with the current fingers.
  using Handler = std::function<void(const TouchEvent&, const TouchInput&)>;

  explicit GestureRecognizer(OrbitCamera& camera) : camera_(camera) {}

  void setViewport(const Viewport& v);
  const Viewport& viewport() const { return input_.viewport(); }
  void setMode(InteractionMode m);
  InteractionMode mode() const { return mode_; }
  void setHandler(InteractionMode m, Handler h);
  /// In Navigate mode, asked at a gesture's first touch-down (pixel position): true hands the
  /// whole gesture to the Manipulate handler instead of the camera.
  using GrabProbe = std::function<bool(glm::dvec2 px)>;
  void setGrabProbe(GrabProbe p) { grabProbe_ = std::move(p); }
  /// True while a Navigate-mode gesture is being handed to the Manipulate handler.
  bool grabbing() const { return grabbing_; }

  /// Feeds one event; returns false if the input layer refused it.
  bool handle(const TouchEvent& e);
  /// Lifts every finger (focus lost, reset).
  void cancel();

  const TouchInput& input() const { return input_; }
  /// Radians of orbit per pixel of one-finger drag (default: pi per viewport height).
  double orbitRadiansPerPixel() const;

 private:
  void anchor();
  void navigate();

  OrbitCamera& camera_;
  TouchInput input_;
  InteractionMode mode_ = InteractionMode::Navigate;
  Handler selectHandler_, manipulateHandler_, clipHandler_, windowHandler_;
  GrabProbe grabProbe_;
  bool grabbing_ = false;
  // Anchor: the camera and finger positions when the finger count last changed.
  OrbitCamera anchorCamera_;
  std::vector<Finger> anchorFingers_;
};

}  // namespace handson
