#pragma once
// Wires selection into a running session, for the window and for replay alike: the pinch's
// depth-pick requests ride on the next frame and their answers come back with its results; the
// live selection and the handles are painted into a CPU copy of the handle-id mask whose changed
// box is uploaded inside the next frame; handle edits come in as UI actions (recorded and replayed
// like touches):
//   handle-status "ID:active|fixed|idle", handle-delete "ID", handle-union "A,B" (A := A ∪ B) and
//   handle-difference "A,B" (A := A \ B), both under the correction rule (interaction/
//   selection_edit.h: with neck, the default, a union adds B's lobe its seed lies in and a
//   difference takes B's part beyond A's narrowest neck), pinch-op "new|add|remove" (what the next
//   pinches do: a new handle, or a correction of the handle tapped last, else the newest), undo,
//   redo, toggle-lock "z-translation|z-rotation|xy-translation",
//   label-handle "I,J,K" (with a label map: the labelled organ at voxel I,J,K becomes a handle - what
//   a tap on an organ that is no handle yet does in select mode).
// Edits in the background (the window): a finished pinch (its voxels sorted and rimmed, then its
// edit), a union and a difference are made on a copy of the handles by a worker thread and taken
// in at the first frame after they are done (poll), so a liver-sized correction (hundreds of ms)
// never holds a frame; handle edits and pinches that end meanwhile wait behind it, in order, and a
// new grab of a handle waits too (a drag under way goes on, its pose carried over). Otherwise
// (replays, tests) each edit lands in the frame that makes it: the same handles.
#include <deque>
#include <future>
#include <memory>
#include <map>
#include <optional>
#include <vector>

#include "app/session/gpu_growth.h"
#include "app/session/selection_backend.h"
#include "app/session/session.h"
#include "app/session/stage_times.h"
#include "interaction/handles.h"
#include "interaction/label_map.h"
#include "interaction/manipulation.h"
#include "interaction/selection.h"
#include "interaction/selection_edit.h"
#include "render/render_params.h"
#include "render/volume_renderer.h"

namespace handson {

class SelectionController {
 public:
  /// `backend`: where pinches grow (app/session/selection_backend.h; Auto resolves by the renderer's device).
  SelectionController(const QuantizedVolume& volume, Session& session, VolumeRenderer& renderer, const GrowParams& params = {},
                      SelectionBackend backend = SelectionBackend::Cpu);
  ~SelectionController();
  SelectionController(const SelectionController&) = delete;
  SelectionController& operator=(const SelectionController&) = delete;

  /// Before submitting a frame: appends pending pick points (NDC) and sets the mask upload.
  void prepareFrame(FrameRequest& request, const Viewport& viewport);
  /// After submitting it, with the frame id the renderer returned.
  void submitted(std::uint64_t frame);
  /// With every completed frame's results.
  void onFrameResult(const FrameResult& result);
  /// Handle edits; false for actions that are not the controller's or that were refused (an edit
  /// waiting behind one in the background, or made there, is accepted: a refusal shows later in
  /// correctionNote()).
  bool applyUi(const ScriptEvent& e);

  /// Edits made in the background (the window) or in the frame that makes them (default).
  void setEditsInBackground(bool on) { editsInBackground_ = on; }
  /// At the start of a frame: a background edit that is done is taken in, and the edits waiting
  /// behind it start.
  void poll();
  /// Waits for the edits in the background and those behind them, and takes them in (a save, the
  /// session's end).
  void finishEdits();
  /// An edit is being made in the background or waits behind one.
  bool editing() const { return editFuture_.valid() || !queued_.empty(); }

  /// Organ labels on the volume's grid (owned by the caller, kept alive while this controller is):
  /// taps and "label-handle" actions then make labelled organs handles. nullptr: none.
  void setLabels(const LabelMap* labels) { labels_ = labels; }
  /// What handle-union and handle-difference, and pinches that add or remove, take of a correction
  /// pinch (interaction/selection_edit.h; default Neck).
  void setCorrectionRule(CorrectionRule r) { corrections_ = r; }
  /// What a finished pinch does (the "pinch-op" action; New by default).
  PinchOp pinchOp() const { return pinchOp_; }
  /// Why the last correction pinch was refused ("" if it was not).
  const std::string& correctionNote() const { return correctionNote_; }
  /// Why the last label-handle action was refused ("" if it was not).
  const std::string& labelNote() const { return labelNote_; }

  const HandleSet& handles() const { return handles_; }
  /// Handles picked by tapping them (most recent last, at most two): union and difference act on them.
  const std::vector<int>& picked() const { return picked_; }
  /// Handles with a pose, for the raymarch (drawn moved rigidly until the simulation lands).
  std::vector<MovingHandlePose> movingHandles() const;
  /// Whether moved handles are drawn rigidly: off while the renderer shows the simulated
  /// deformation, whose resampling blurs a handle's surface by up to `blurMm` (a fine tet); fingers
  /// then anchor on the handle's own voxels before or behind the picked surface (contactOnHandle).
  void setRigidPreview(bool on, double blurMm = 0.0) {
    rigidPreview_ = on;
    blurMm_ = blurMm;
  }
  const std::string& manipulationNote() const { return manipulationNote_; }
  /// Locks of the manipulation (GestureLock bits), toggled by the "toggle-lock" UI action.
  unsigned locks() const { return locks_; }
  const PinchSelection& pinch() const { return pinch_; }
  std::size_t liveVoxelCount() const { return live_.size(); }
  /// A pinch is growing on the GPU now (its voxels are not counted on the CPU).
  bool liveOnGpu() const { return gpu_ && gpu_->growing(); }
  /// Where pinches grow (Gpu or Cpu) and the UI's line saying why.
  const SelectionBackendChoice& backend() const { return backend_; }
  /// CPU time since the last call: "selection-update" (region growing and the mask's repaint) and
  /// "gesture-solve" (the manipulation's rigid solve), for the timing log.
  std::vector<std::pair<std::string, double>> takeStageTimes() { return stages_.take(); }

 private:
  /// Voxels whose shown id may have changed: the handles' ids, the live selection over them; the
  /// upload's box grows by theirs (`box`, inclusive voxel indices, when the caller knows it).
  using VoxelBox = std::pair<Eigen::Vector3i, Eigen::Vector3i>;
  void repaint(const std::vector<std::uint32_t>& voxels, const std::optional<VoxelBox>& box = std::nullopt);
  /// The handles' ids changed (and `also` is to be repainted).
  void relabel(const HandleSet::MaskChange& change, std::vector<std::uint32_t> also = {}, const std::optional<VoxelBox>& box = std::nullopt);
  bool labelHandle(const std::string& voxel);
  void refreshLive();
  void syncTints();
  // Edits (app/session/selection_controller.h's head): a handle edit now, or behind the one in
  // the background; a finished pinch's edit started (in the background or made now); an edit
  // made on a copy taken in.
  bool applyEdit(const ScriptEvent& e, bool waited = false);
  bool correct(int a, int b, bool unite);
  /// `picked`: the handles tapped as the pinch ended (a correction's target: correctionTarget);
  /// `shown`: its voxels as drawn live (empty if none), taken as landing_ when the edit goes to the
  /// background with the pinch's voxels still in its grower - then it returns true (nothing to repaint).
  bool startPinchEdit(FinishedPinch pinch, PinchOp op, const std::vector<int>& picked, std::vector<std::uint32_t>& shown);
  void takeIn(EditOnCopy edit, bool pinch);
  struct QueuedEdit {
    std::optional<ScriptEvent> ui;  // a UI action, else a finished pinch
    FinishedPinch pinch;
    PinchOp op = PinchOp::New;
    std::vector<int> picked;  // as the pinch ended
  };
  bool editsInBackground_ = false;
  std::future<EditOnCopy> editFuture_;
  bool editIsPinch_ = false;
  std::string editRefusal_;  // what a union or difference says when the handles refuse it
  std::deque<QueuedEdit> queued_;
  std::vector<std::uint32_t> landing_;  // a pinch whose edit is in the background: drawn as the live selection

  const QuantizedVolume& volume_;
  Session& session_;
  VolumeRenderer& renderer_;
  PinchSelection pinch_;
  HandleSet handles_;
  std::vector<std::uint8_t> mask_;           // handle ids on the volume grid (CPU copy)
  std::vector<std::uint8_t> ids_;            // the handles' ids alone (the mask without the live selection)
  std::vector<std::uint32_t> live_;          // voxels of the live selection
  Eigen::Vector3i dirtyMin_, dirtyMax_;      // box to upload (empty when min > max)
  MaskUpload upload_;
  bool tintsDirty_ = true;
  std::optional<std::uint64_t> pickFrame_;   // frame carrying the pinch's picks
  std::size_t pickOffset_ = 0;
  bool pickInRequest_ = false;
  // Manipulation: fingers landing on a handle in manipulate mode pick their points on it; moves
  // solve the rigid increment that keeps those points under the fingers.
  void manipulate(const TouchEvent& e, const TouchInput& input);
  // In navigate mode a gesture starting on an active handle moves it: decided at once on the CPU
  // (the pick pass's reference on the last frame's parameters and this mask), so the camera
  // never moves first; the GPU picks then anchor the fingers as in manipulate mode.
  bool onActiveHandle(glm::dvec2 px) const;
  gpu::RenderParams lastParams_{};
  bool rigidPreview_ = true;
  double blurMm_ = 0.0;
  bool haveParams_ = false;
  HandleManipulator manipulator_;
  int manipulated_ = 0;                         // handle being moved (0: none)
  std::vector<std::pair<std::int64_t, glm::dvec2>> grabRequest_;  // fingers (px) to pick
  bool grabPending_ = false, grabInRequest_ = false, grabUndoable_ = false;
  std::optional<std::uint64_t> grabFrame_;
  std::size_t grabOffset_ = 0;
  // The grab in flight (attached to a frame, its picks not back yet): its fingers as sent, and
  // whether it starts an undo step. `grabLifted_`: every finger lifted while a grab was to be sent
  // or in flight (a quick drag on slow frames: applied when its picks return). `gestureLast_`: each
  // finger's last position in this gesture (down or lifted).
  std::vector<std::pair<std::int64_t, glm::dvec2>> grabSent_;
  std::map<std::int64_t, glm::dvec2> gestureLast_;
  bool grabLifted_ = false, grabSentUndoable_ = false;
  /// Forgets the grab not yet answered (its request, its fingers' positions, its lift).
  void abandonGrab();
  /// A finger down or up while the grab's picks are not back (the handle not anchored yet).
  void unansweredFingerChange(const TouchEvent& e, const TouchInput& input);
  /// Moves the handle being manipulated so its anchored points stay under these fingers (px).
  void moveHandleTo(const std::vector<std::pair<std::int64_t, glm::dvec2>>& fingersPx);
  /// The grab's picks: anchors the fingers on the handle under them (the drag applied at once when
  /// they have all lifted since).
  void onGrabResult(const FrameResult& r);
  std::string manipulationNote_;
  unsigned locks_ = kLockNone;
  // Taps (a finger down and up again within 0.3 s and 12 px, alone) pick the handle under them.
  void detectTap(const TouchEvent& e, const TouchInput& input);
  std::optional<glm::dvec2> tapRequest_;
  std::optional<std::uint64_t> tapFrame_;
  std::size_t tapOffset_ = 0;
  bool tapInRequest_ = false;
  std::int64_t tapFinger_ = -1;
  glm::dvec2 tapStart_{0.0};
  double tapTime_ = 0.0;
  bool tapSpoiled_ = false;
  std::vector<int> picked_;
  const LabelMap* labels_ = nullptr;
  CorrectionRule corrections_ = CorrectionRule::Neck;
  PinchOp pinchOp_ = PinchOp::New;
  std::string correctionNote_;
  /// The handle a correction pinch edits: the one of `picked` tapped last, else the newest (0: none).
  int correctionTarget(const std::vector<int>& picked) const;
  std::string labelNote_;
  StageTimes stages_;
  SelectionBackendChoice backend_;
  std::unique_ptr<GpuGrowthEngine> gpu_;  // set when pinches grow on the GPU
};

}  // namespace handson
