#pragma once
// One frame of a session, shared by the window (app/platform/viewer) and the headless replay (app/session/replay,
// which the soak and the benchmark suite run): `frame` runs the whole sequence - the input applied,
// the window's panels and their actions, the session's clock, the transfer function kept to the
// session's preset, the frame request at the session's camera, the simulation's state attached
// (live or settled), the selection's passes, the frame budget, the timing record and the
// submission - and `completed` takes the finished frames back. The callers differ only in where
// events come from (the window's input and a played script, or a script on a clock), where frames
// go (a swapchain, or PNG files and a wait) and what they report.
#include <chrono>
#include <cstdint>
#include <deque>
#include <functional>
#include <optional>
#include <utility>
#include <vector>

#include "app/session/frame_budget.h"

#include "app/session/deformation_controller.h"
#include "app/session/latency_log.h"
#include "app/session/selection_controller.h"
#include "app/session/session.h"
#include "render/frame_renderer.h"
#include "render/volume_renderer.h"
#include "sim/quantized_volume.h"
#include "sim/volume.h"

namespace handson {

/// One frame's input (FrameDriver::frame).
struct FrameInput {
  /// An input event and when it arrived, on the driver's clock (the latency log's input times);
  /// `arrived` < 0: when it is applied (a script's events, applied as their frame comes).
  struct Event {
    ScriptEvent event;
    double arrived = -1.0;
  };
  std::vector<Event> events;  ///< touches and a script's events: applied first, in order; the frame's input
  /// The window's panels, laid out on the state the input left; the actions it returns (its
  /// buttons', the keys', a played script's) are applied next. Not counted as input.
  std::function<std::vector<ScriptEvent>()> panels;
  /// The session's clock (s): a framing's camera move advances to it, and the actions a settled
  /// clip drag adds are stamped with it. < 0: the driver's clock once the input and the panels'
  /// actions are applied (the window: its panels' actions are stamped when they are built).
  double sessionClock = -1.0;
  /// A clip drag that settled frames the clip and, unless the window was set by hand, fits the
  /// window to it (the window's own gestures; a played or replayed script carries these actions).
  bool followClip = false;
  Viewport view;               ///< the view (touches, picks, the camera's aspect)
  int width = 0, height = 0;   ///< the raymarch's full size (the budget may draw it smaller)
  bool settled = false;        ///< wait for the simulation of the current pose (a replay); else the newest landed state
  bool readbackImage = false;  ///< the frame's image read back
  /// Asked once the input is applied: whether this frame carries a pending export's image (read
  /// back, at full quality whatever the budget says).
  std::function<bool()> exportImage;
  FrameExtension* extension = nullptr;  ///< passes after the raymarch (the window's present and panels)
  std::function<void()> beforeSubmit;   ///< once the request is made, before it is submitted
};

/// What `frame` did.
struct FrameOutcome {
  std::uint64_t frame = 0;    ///< the submitted frame's number
  FrameQuality quality;       ///< the budget's quality it was drawn at
  int width = 0, height = 0;  ///< the raymarch's size as drawn
  int stillPhases = 0;        ///< jitter phases summed in it (1..kStillJitterPhases; 0: none)
  bool exportImage = false;   ///< it carries a pending export's image
  std::vector<ScriptEvent> refused;  ///< events and actions the session refused
  /// The simulation refused a pose, stopped without converging or failed to build since the last
  /// frame: the caller saves the session and says so.
  bool newFailure = false;
};

class FrameDriver {
 public:
  FrameDriver(const Volume& volume, const QuantizedVolume& q, Session& session, FrameRenderer& renderer, SelectionController& selection,
              DeformationController& deform)
      : volume_(volume), q_(q), session_(session), renderer_(renderer), selection_(selection), deform_(deform) {
    session_.addUiExtension([this](const ScriptEvent& e) { return applyUi(e); });
  }

  /// The frame's whole sequence, in this order: the input events applied (refusals kept), the
  /// panels' actions applied, the clip followed and the session's clock advanced, the transfer
  /// function refreshed, the request made at the session's camera, the simulation attached (and a
  /// new failure noted), the selection's passes, the frame budget, the simulation's state into
  /// `ft`, `beforeSubmit`, the submission. `ft`'s input, CPU, quality and submit fields are filled
  /// on the driver's clock. A frame with nothing to do is submitted all the same (a still picture
  /// goes on summing its jitter phases; the budget refines).
  FrameOutcome frame(const FrameInput& in, FrameTiming& ft);
  /// A finished frame's results (picks, grown regions, its GPU times) to the budget, the selection
  /// and the session's clip.
  void completed(const FrameResult& result);

  /// The clock the timing record is on: seconds since `t0`.
  void setClockStart(std::chrono::steady_clock::time_point t0) { t0_ = t0; }
  double now() const { return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0_).count(); }
  /// The frame budget (app/session/frame_budget.h; 0: off, the default).
  void setFrameBudget(double budgetMs) { budget_ = FrameBudget(budgetMs); }
  const FrameBudget& frameBudget() const { return budget_; }
  /// The UI actions that need the volume or the simulation: "set-interface" sliding|glued
  /// (DeformationController::setInterface), "cut" and "clear-cuts" (addCut, clearCuts: a value that
  /// is no cut's quads is refused) and "auto-window" (the session's window fitted to the
  /// soft tissue of what the clip leaves: render/auto_window.h; refused where there is none).
  bool applyUi(const ScriptEvent& e);
  /// True once for each new simulation failure (a refused pose, no convergence, a failed build);
  /// `frame` asks after attaching the simulation (FrameOutcome::newFailure), the window's panel
  /// also before laying itself out.
  bool newFailure();

 private:
  /// Applies the frame's events and the panels' actions; whether any was applied.
  bool applyInput(const FrameInput& in, FrameTiming& ft, FrameOutcome& out);
  /// A clip drag that settled: framed and the window fitted when `follow`, let go otherwise.
  void followClip(bool follow, double now);
  /// The session's transfer function, when an applied event changed its preset.
  void refreshTransferFunction();
  /// The budget's quality for this frame, applied to a request made, attached and ready to submit:
  /// its raymarch size scaled (its full size is the request's) and its step. The picture counts as
  /// changing when `eventsApplied` (input or UI actions this frame), a finger is down, its parameters differ from the
  /// last frame's (camera, clip, overlays, moved handles), the transfer function changed or it
  /// carries a new simulation state or mask. Off: the request as it is.
  /// `fullQuality`: this frame at full quality whatever the budget says (an export's image).
  /// A still picture at full quality with the ray jitter on then sums kStillJitterPhases jitter
  /// phases, one a frame, showing their running mean (render/render_params.h, setStillPhase); the
  /// settled frame is their mean, budget or none.
  FrameQuality applyFrameBudget(FrameRequest& request, bool eventsApplied, bool fullQuality = false);
  /// A frame at the session's camera over a vp-sized view, raymarched at width x height (the
  /// strain overlay as the session says).
  FrameRequest request(const Viewport& vp, int width, int height) const;
  /// The simulation's state attached to the request: the newest landed one (`settled` false: never
  /// waits for the solve), or the one of the current pose (`settled`: waits for it); handles not yet
  /// simulated are previewed rigidly.
  void attachSimulation(FrameRequest& request, bool settled);
  /// The selection's passes (and the pick that places a clip plane); the frame's CPU stage times
  /// (selection, then simulation) into ft.
  void attachSelection(FrameRequest& request, const Viewport& vp, FrameTiming& ft);
  /// What the frame shows of the simulation (state, its age, the reactions) into ft.
  void recordSimulation(FrameTiming& ft) const;
  /// Submits the frame (waiting only for the frame two submissions back); its number.
  std::uint64_t submit(const FrameRequest& request);
  bool applyAutoWindow();
  const Volume& volume_;
  const QuantizedVolume& q_;
  Session& session_;
  FrameRenderer& renderer_;
  SelectionController& selection_;
  DeformationController& deform_;
  std::uint64_t failuresSeen_ = 0;
  std::size_t clipPickOffset_ = 0;
  bool clipPickInRequest_ = false;
  std::optional<std::uint64_t> clipPickFrame_;
  std::chrono::steady_clock::time_point t0_ = std::chrono::steady_clock::now();
  FrameBudget budget_{0.0};
  FrameQuality nextQuality_;                                    ///< applied to the request about to be submitted
  std::deque<std::pair<std::uint64_t, FrameQuality>> inFlight_;  ///< submitted frames' qualities, until completed
  gpu::RenderParams lastParams_{};
  bool hasLastParams_ = false, tfChanged_ = false;
};

}  // namespace handson
