#pragma once
// What a running session is, for the window and for headless replay alike: the camera, the gesture
// recognizer, the interaction mode and the transfer-function preset, changed only through
// apply(ScriptEvent). Both the live app and `handson replay` drive it with the same events, so a
// recorded session replays to the same camera and the same frames.
#include <functional>
#include <string>
#include <vector>

#include "app/session_script.h"
#include "interaction/gesture.h"
#include "sim/volume.h"

namespace handson {

class Session {
 public:
  Session(const VolumeGeometry& geometry, const Viewport& viewport, std::string preset);

  /// Applies a touch or UI event. Returns false if it was refused (bad touch, unknown preset).
  bool apply(const ScriptEvent& e);
  void setViewport(const Viewport& v);
  void resetCamera();

  OrbitCamera& camera() { return camera_; }
  const OrbitCamera& camera() const { return camera_; }
  GestureRecognizer& gestures() { return gestures_; }
  const std::string& preset() const { return preset_; }
  /// True once after the preset changed (the renderer re-uploads the table).
  bool takePresetChanged() { return std::exchange(presetChanged_, false); }
  /// The strain overlay (the "toggle-strain" action): tissue coloured by its strain while deforming.
  bool strainOverlay() const { return strainOverlay_; }
  /// The label tint (the "toggle-labels" action): tissue coloured by its organ label, where the
  /// renderer has labels (on from the start when a label map is loaded: setLabelTint).
  bool labelTint() const { return labelTint_; }
  /// Clipping (world RAS mm), set by the "set-clip-box" ("X0,Y0,Z0,X1,Y1,Z1"), "set-clip-plane"
  /// ("NX,NY,NZ,D": keeps n.x >= D) and "clear-clip" actions: drawn and respected by picking.
  struct Clip {
    bool box = false;
    glm::vec3 lo{0.0f}, hi{0.0f};
    bool plane = false;
    glm::vec3 normal{0.0f, 0.0f, 1.0f};
    float offset = 0.0f;
  };
  const Clip& clip() const { return clip_; }
  void setLabelTint(bool on) { labelTint_ = on; }

  /// UI actions the session does not know itself (handle edits, export) go to these, in order,
  /// until one applies it (returns true).
  void addUiExtension(std::function<bool(const ScriptEvent&)> f) { uiExtensions_.push_back(std::move(f)); }

  /// Recording: every applied event is appended (with its time) to a script.
  void startRecording(const SessionScript& header);
  bool recording() const { return recording_; }
  const SessionScript& script() const { return script_; }

 private:
  VolumeGeometry geometry_;
  OrbitCamera camera_;
  GestureRecognizer gestures_;
  std::string preset_;
  bool presetChanged_ = false;
  bool strainOverlay_ = false;
  bool labelTint_ = false;
  Clip clip_;
  bool recording_ = false;
  SessionScript script_;
  std::vector<std::function<bool(const ScriptEvent&)>> uiExtensions_;
};

/// One line for tests and scripting: "camera azimuth_deg=... elevation_deg=... roll_deg=...
/// distance=... target=x,y,z".
std::string describeCamera(const OrbitCamera& c);

}  // namespace handson
