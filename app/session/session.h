#pragma once
// What a running session is, for the window and for headless replay alike: the camera, the gesture
// recognizer, the interaction mode, the transfer-function preset and its window, and the clipping,
// changed only through apply(ScriptEvent) (touches included: the Clip and Window modes' gestures are
// the session's own, app/session/session_view_gestures.cpp). Both the live app and `handson replay` drive it with the same events, so a
// recorded session replays to the same camera and the same frames.
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "app/session/clip_framing.h"
#include "app/session/session_script.h"
#include "interaction/camera_framing.h"
#include "interaction/gesture.h"
#include "interaction/view_adjust.h"
#include "render/render_params.h"
#include "sim/volume.h"

namespace handson {

class Session {
 public:
  Session(const VolumeGeometry& geometry, const Viewport& viewport, std::string preset);

  /// Applies a touch or UI event. Returns false if it was refused (bad touch, unknown preset).
  bool apply(const ScriptEvent& e);
  void setViewport(const Viewport& v);
  /// The view's default framing (and reset-camera): the volume centred in the given part of the
  /// viewport, filling it (OrbitCamera::framingIn); the whole viewport (the default) keeps the
  /// classic framing of the volume's bounding sphere. Recorded in the script's header.
  void setFreeArea(const ScreenArea& area);
  const ScreenArea& freeArea() const { return freeArea_; }
  /// The default framing; before any event is recorded, it also becomes the recording's start.
  void resetCamera();
  /// Frames (reset-camera) as a view of this size would (a played script's viewport, so that its
  /// camera resets as where it was recorded whatever the window's aspect); unset: the viewport.
  void setFramingViewport(const std::optional<Viewport>& v) { framingViewport_ = v; }

  /// Framing the clip: the "frame-clip" action moves the camera (its direction kept) so that the
  /// volume's clipped part fills the free area (refused when nothing is clipped or nothing is
  /// left), "camera-back" returns to the camera before the last framing (refused when there is
  /// none). Both move it over kFramingSeconds from the event's time, as advance() is called: a
  /// touch stops the move where it is, reset-camera ends it.
  static constexpr double kFramingSeconds = 0.35;
  /// The camera at time t (the clock of the events: a replay's frame times, the window's seconds):
  /// called before each frame.
  void advance(double t);
  bool cameraMoving() const { return move_.has_value(); }
  /// No framing in progress and none to go back from (a played script's start).
  void stopFraming();
  bool canGoBack() const { return beforeFraming_.has_value(); }
  /// True once after a Clip-mode drag that changed the clip has ended (its plane's pick landed):
  /// the live window then frames the clip with a recorded "frame-clip" (a replay plays the
  /// recorded action instead).
  bool takeClipSettled() { return std::exchange(clipSettled_, false); }

  OrbitCamera& camera() { return camera_; }
  const OrbitCamera& camera() const { return camera_; }
  GestureRecognizer& gestures() { return gestures_; }
  const std::string& preset() const { return preset_; }
  /// The preset's window, level and opacity (the "set-window" action "SCALE,SHIFT,OPACITY",
  /// "reset-window", and the Window mode's drags; a new preset starts from the identity).
  const WindowLevel& window() const { return window_; }
  /// The automatic window (the "auto-window" action, which the frame driver answers with the
  /// region's soft-tissue peak: render/auto_window.h): set here, it follows the region until the
  /// window is set by hand (a Window-mode drag, set-window) or the preset changes.
  void setAutomaticWindow(const WindowLevel& w);
  /// The window is the preset's own or automatic: a framing of the clip may fit it to the region.
  bool windowFollowsRegion() const { return window_.identity() || windowAuto_; }
  /// True once after the preset or its window changed (the renderer re-uploads the table).
  bool takePresetChanged() { return std::exchange(presetChanged_, false); }
  /// The strain overlay (the "toggle-strain" action): tissue coloured by its strain while deforming.
  bool strainOverlay() const { return strainOverlay_; }
  /// The limit highlight (the "toggle-limits" action): tissue past its strain limit coloured while
  /// deforming (render/render_params.h limitHighlight).
  bool limitHighlight() const { return limitHighlight_; }
  /// The label tint (the "toggle-labels" action): tissue coloured by its organ label, where the
  /// renderer has labels (on from the start when a label map is loaded: setLabelTint).
  bool labelTint() const { return labelTint_; }
  /// Clipping (world RAS mm), set by the "set-clip-box" ("X0,Y0,Z0,X1,Y1,Z1"), "set-clip-plane"
  /// ("NX,NY,NZ,D": keeps n.x >= D) and "clear-clip" actions and by the Clip mode's drags: drawn
  /// and respected by picking.
  using Clip = ClipRegion;
  const Clip& clip() const { return clip_; }
  /// A Clip-mode drag that places a plane needs the point under its finger: the pixel to pick in
  /// the next frame (once: the request is then taken), and the pick's result (nullopt: nothing
  /// visible there, the plane goes through the camera's target).
  std::optional<glm::dvec2> takeClipPickRequest();
  void clipPicked(const std::optional<glm::dvec3>& world);
  void setLabelTint(bool on) { labelTint_ = on; }

  /// UI actions the session does not know itself (handle edits, export) go to these, in order,
  /// until one applies it (returns true).
  void addUiExtension(std::function<bool(const ScriptEvent&)> f) { uiExtensions_.push_back(std::move(f)); }

  /// Recording: every applied event is appended (with its time) to a script.
  void startRecording(const SessionScript& header);
  bool recording() const { return recording_; }
  const SessionScript& script() const { return script_; }

 private:
  /// The view's actions (mode, preset, window, camera, clip, overlays): whether it was accepted;
  /// nullopt for an action that is not the view's (the extensions' then).
  std::optional<bool> applyViewAction(const ScriptEvent& e);
  bool setPreset(const std::string& name);

  VolumeGeometry geometry_;
  OrbitCamera camera_;
  GestureRecognizer gestures_;
  std::string preset_;
  bool presetChanged_ = false;
  bool strainOverlay_ = false;
  bool limitHighlight_ = false;
  bool labelTint_ = false;
  Clip clip_;
  WindowLevel window_;
  bool windowAuto_ = false;
  ScreenArea freeArea_;
  std::optional<Viewport> framingViewport_;
  std::optional<CameraMove> move_;            ///< a framing in progress
  std::optional<OrbitCamera> beforeFraming_;  ///< where "camera-back" returns
  bool clipSettled_ = false;
  bool frameTo(std::optional<OrbitCamera> to, double t);
  /// A Clip or Window mode drag in progress (app/session/session_view_gestures.cpp).
  struct ViewDrag {
    enum class Kind { None, Face, Plane, Window } kind = Kind::None;
    std::int64_t finger = 0;
    glm::dvec2 startPx{0.0}, deltaPx{0.0};
    BoxFace face;
    glm::dvec3 lo{0.0}, hi{0.0};           ///< the box at the drag's start
    ClipRegion startClip;                   ///< the whole clip at the drag's start (a change frames it)
    std::optional<ClipPlaneDrag> plane;     ///< the plane at the drag's start (after the pick)
    bool pickWanted = false, pickPending = false;
    WindowLevel window;                     ///< the window at the drag's (or finger count's) start
    double spread0 = 0.0, width = 1.0;
    std::size_t fingers = 0;
  } drag_;
  void onClipTouch(const TouchEvent& e, const TouchInput& input);
  void onWindowTouch(const TouchEvent& e, const TouchInput& input);
  void applyPlaneDrag();
  void endClipDrag();
  bool recording_ = false;
  SessionScript script_;
  std::vector<std::function<bool(const ScriptEvent&)>> uiExtensions_;
};

/// One line for tests and scripting: "camera azimuth_deg=... elevation_deg=... roll_deg=...
/// distance=... target=x,y,z".
std::string describeCamera(const OrbitCamera& c);

}  // namespace handson
