#pragma once
// The session script: a documented, versioned JSON record of what a user did — timestamped touch
// events and UI actions, the starting camera, the viewport and the volume it was recorded on. The
// app writes it with --record; `handson replay` plays it back headless. Format (version 1):
//
// {
//   "format": "handson-session", "version": 1,
//   "volume": {"source": "phantom"}  |  {"source": "file", "path": "ct.nii.gz"},
//   "viewport": [512, 512],                  // pixels; touch coordinates refer to it
//   "preset": "ct-abdomen",                  // transfer function at the start (optional)
//   "mode": "navigate",                      // interaction mode at the start (optional)
//   "camera": {"target": [x, y, z], "distance": mm, "azimuth_deg": a, "elevation_deg": e,
//              "roll_deg": r, "fov_deg": f}, // optional: default framing of the volume
//   "free_area": [x0, y0, x1, y1],           // optional: the part of the viewport the app's panels
//                                            // left free (fractions), where reset-camera frames
//   "events": [                              // sorted by "t" (seconds from the start)
//     {"t": 0.00, "touch": "down", "id": 0, "x": 256, "y": 256, "pressure": 1},
//     {"t": 0.05, "touch": "move", "id": 0, "x": 262, "y": 255},
//     {"t": 0.40, "touch": "up", "id": 0, "x": 300, "y": 250},
//     {"t": 0.50, "ui": "set-mode", "value": "select"},     // navigate | select | manipulate
//     {"t": 0.60, "ui": "set-preset", "value": "ct-bone"},  // a transfer-function preset
//     {"t": 0.70, "ui": "reset-camera"},
//     {"t": 0.80, "ui": "handle-status", "value": "1:fixed"},  // handle edits: handle-status ID:STATUS,
//                                                               // handle-delete ID, handle-union A,B,
//                                                               // handle-difference A,B, undo, redo,
//                                                               // toggle-lock z-translation|z-rotation|xy-translation
//     {"t": 0.85, "ui": "toggle-strain"},  // the strain overlay on / off (while deforming)
//     {"t": 0.86, "ui": "toggle-limits"},  // the highlight of tissue past its strain limit on / off
//     {"t": 0.87, "ui": "set-interface", "value": "sliding"},  // the handles' interface: sliding | glued
//     {"t": 0.88, "ui": "cut", "value": "X0,Y0,Z0,...,Z3;..."},  // cut the tissue along planar quads (RAS mm,
//                                                               // docs/cutting.md); clear-cuts undoes every cut
//     {"t": 0.90, "ui": "export"},  // session, deformed volume, mesh, screenshot (app/session/session_export.h)
//   ]
// }
#include <optional>
#include <string>
#include <vector>

#include "app/session/ui_action.h"
#include "interaction/camera.h"
#include "interaction/touch.h"

namespace handson {

constexpr int kSessionScriptVersion = 1;

struct ScriptEvent {
  double t = 0.0;
  bool isTouch = true;
  TouchEvent touch;     ///< when isTouch (touch.time == t)
  UiAction action = UiAction::None;  ///< when !isTouch
  std::string value;
};

/// A UI action at time t.
ScriptEvent uiEvent(double t, UiAction action, std::string value = {});
/// A touch at time t (touch.time = t).
ScriptEvent touchEvent(double t, TouchPhase phase, std::int64_t id, glm::dvec2 px, double pressure = 1.0);

struct CameraState {
  glm::dvec3 target{0.0};
  double distance = 500.0, azimuthDeg = 0.0, elevationDeg = 0.0, rollDeg = 0.0, fovDeg = 35.0;
  static CameraState from(const OrbitCamera& c);
  bool operator==(const CameraState&) const = default;
  /// Applies onto a camera that already has sensible near/far planes for the volume.
  void applyTo(OrbitCamera& c) const;
};

struct SessionScript {
  int version = kSessionScriptVersion;
  std::string volumeSource = "phantom";  ///< "phantom" or "file"
  std::string volumePath;
  Viewport viewport{512, 512};
  std::string preset;  ///< empty: the volume's default
  std::string mode = "navigate";
  std::optional<CameraState> camera;
  std::optional<ScreenArea> freeArea;
  std::vector<ScriptEvent> events;

  double duration() const { return events.empty() ? 0.0 : events.back().t; }
};

/// Parses a script; throws handson::Error naming `name` and the problem (bad JSON, wrong format or
/// version, missing or mistyped fields, unsorted or non-finite times, unknown actions).
SessionScript parseSessionScript(const std::string& text, const std::string& name = "script");
SessionScript readSessionScript(const std::string& path);
std::string formatSessionScript(const SessionScript& script);
/// Written atomically (temporary file renamed into place).
void writeSessionScript(const SessionScript& script, const std::string& path);

}  // namespace handson
