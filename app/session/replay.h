#pragma once
// Headless replay of a session script on any Vulkan device (lavapipe included), with no window:
// the same session logic and frame graph as the app, frames rendered at a fixed rate of script
// time, written as numbered PNGs with a timing log. The same script on the same driver gives
// bit-identical frames.
#include <cstdint>
#include <functional>
#include <optional>
#include <string>

#include "app/session/session_options.h"
#include "app/session/session_script.h"

namespace handson {

/// The replay's options: the session's (app/session/session_options.h; `volume` overrides the
/// script's, `frames` 0: through the script's last event, plus one, and the simulation waited for
/// each frame: deterministic) and its own.
struct ReplayOptions : SessionOptions {
  std::string script;      ///< path; empty: the built-in orbit-and-zoom demo
  std::optional<SessionScript> scriptData;  ///< a script in memory instead (e.g. app/tools/gesture_stress.h: may hold NaN)
  std::string framesOut;   ///< directory for frame_NNNNN.png (created); empty: no PNGs
  double fps = 30.0;       ///< frames per second of script time
  double frameBudgetMs = 0.0;  ///< app/session/frame_budget.h; 0: off (frames bit-identical run to run)
  int width = 0, height = 0;  ///< output size; 0: the script's viewport (touches are scaled)
  bool printHandles = false;
  std::string exportPath;  ///< the deformed volume at the end (.nii.gz, the input's grid)
  /// Called after each frame (index, frame count, validation messages so far): soaks sample here.
  std::function<void(int frame, int frames, std::uint64_t validationMessages)> afterFrame;
};

/// The built-in demo script (assets/gestures/orbit-and-zoom.json, embedded at build time).
SessionScript builtInDemoScript();
/// The whole touch workflow on the phantom (assets/gestures/full-session.json, embedded): the right
/// kidney and the vena cava pinch-selected, the kidney tilted and dragged with the tissue deforming
/// around it, handle edits, an orbit, an export. The headless main job replays it.
SessionScript builtInFullSessionScript();

/// 0 on success; 1 when a validation message appeared or a handle's pose or the camera ended up
/// holding a non-finite number (named on stderr). Throws Error for bad options or input.
int runReplay(const ReplayOptions& options);

}  // namespace handson
