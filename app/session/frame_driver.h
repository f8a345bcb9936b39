#pragma once
// One frame of a session, shared by the window (app/platform/viewer) and the headless replay (app/session/replay,
// which the soak and the benchmark suite run): the transfer function kept to the session's preset,
// the frame request at the session's camera, the simulation's state attached (live or settled),
// the selection's passes, the submission and the finished frames handed back. The loops differ only
// in where events come from (the window's input and a played script, or a script on a clock), where
// frames go (a swapchain, or PNG files and a wait) and what they report.
#include <cstdint>
#include <deque>
#include <optional>
#include <utility>

#include "app/session/frame_budget.h"

#include "app/session/deformation_controller.h"
#include "app/session/latency_log.h"
#include "app/session/selection_controller.h"
#include "app/session/session.h"
#include "render/volume_renderer.h"
#include "sim/quantized_volume.h"
#include "sim/volume.h"

namespace handson {

class FrameDriver {
 public:
  FrameDriver(const Volume& volume, const QuantizedVolume& q, Session& session, VolumeRenderer& renderer, SelectionController& selection,
              DeformationController& deform)
      : volume_(volume), q_(q), session_(session), renderer_(renderer), selection_(selection), deform_(deform) {
    session_.addUiExtension([this](const ScriptEvent& e) { return applyUi(e); });
  }

  /// The UI actions that need the volume or the simulation: "set-interface" sliding|glued
  /// (DeformationController::setInterface) and "auto-window" (the session's window fitted to the
  /// soft tissue of what the clip leaves: render/auto_window.h; refused where there is none).
  bool applyUi(const ScriptEvent& e);
  /// The session's transfer function, when an applied event changed its preset.
  void refreshTransferFunction();
  /// The frame budget (app/session/frame_budget.h; 0: off, the default).
  void setFrameBudget(double budgetMs) { budget_ = FrameBudget(budgetMs); }
  const FrameBudget& frameBudget() const { return budget_; }
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
  /// The jitter phases summed in the frame last submitted (1..kStillJitterPhases; 0: none).
  int stillPhases() const { return renderer_.stillPhasesShown(); }
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
  /// True once for each new simulation failure (a refused pose, no convergence, a failed build):
  /// the caller saves the session and says so.
  bool newFailure();
  /// Submits the frame (waiting only for the frame two submissions back); its number.
  std::uint64_t submit(const FrameRequest& request);
  /// A finished frame's results (picks, grown regions) to the selection and the session's clip.
  void completed(const FrameResult& result);

 private:
  bool applyAutoWindow();
  const Volume& volume_;
  const QuantizedVolume& q_;
  Session& session_;
  VolumeRenderer& renderer_;
  SelectionController& selection_;
  DeformationController& deform_;
  std::uint64_t failuresSeen_ = 0;
  std::size_t clipPickOffset_ = 0;
  bool clipPickInRequest_ = false;
  std::optional<std::uint64_t> clipPickFrame_;
  FrameBudget budget_{0.0};
  FrameQuality nextQuality_;                                    ///< applied to the request about to be submitted
  std::deque<std::pair<std::uint64_t, FrameQuality>> inFlight_;  ///< submitted frames' qualities, until completed
  gpu::RenderParams lastParams_{};
  bool hasLastParams_ = false, tfChanged_ = false;
};

}  // namespace handson
