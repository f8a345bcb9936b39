#include "selection_controller.h"

#include <algorithm>
#include <chrono>
#include <utility>
#include <sstream>

#include "render/raymarch_reference.h"
#include "render/vk_context.h"
#include "sim/base/error.h"


namespace handson {

SelectionController::SelectionController(const QuantizedVolume& volume, Session& session, VolumeRenderer& renderer, const GrowParams& params,
                                         SelectionBackend backend)
    : volume_(volume), session_(session), renderer_(renderer), pinch_(volume, params), mask_(volume.data.size(), 0), ids_(volume.data.size(), 0) {
  dirtyMin_ = volume.geometry.dims;
  dirtyMax_ = Eigen::Vector3i(-1, -1, -1);
  const VkPhysicalDeviceProperties& device = renderer.context().properties();
  backend_ = resolveSelectionBackend(backend, device.deviceType == VK_PHYSICAL_DEVICE_TYPE_CPU, device.deviceName);
  if (backend_.backend == SelectionBackend::Gpu) {
    gpu_ = std::make_unique<GpuGrowthEngine>(renderer, volume, mask_);
    pinch_.setEngine(gpu_.get());
  }
  session_.gestures().setHandler(InteractionMode::Select, [this](const TouchEvent& e, const TouchInput& input) {
    {
      const StageTimes::Scope t(stages_, "selection-update");
      pinch_.onTouch(e, input, session_.camera(), session_.gestures().viewport());
      if (pinch_.changed()) refreshLive();
    }
    detectTap(e, input);
  });
  session_.gestures().setHandler(InteractionMode::Manipulate, [this](const TouchEvent& e, const TouchInput& input) { manipulate(e, input); });
  session_.gestures().setGrabProbe([this](glm::dvec2 px) { return onActiveHandle(px); });
  session_.addUiExtension([this](const ScriptEvent& e) { return applyUi(e); });
}

SelectionController::~SelectionController() {
  try {
    if (gpu_) gpu_->cancel();
  } catch (const std::exception&) {  // the device is lost: nothing left to wait for
  }
}

void SelectionController::repaint(const std::vector<std::uint32_t>& voxels, const std::optional<VoxelBox>& box) {
  if (box) {  // known: no voxel's coordinates needed (an empty box leaves the dirty box as it is)
    dirtyMin_ = dirtyMin_.cwiseMin(box->first);
    dirtyMax_ = dirtyMax_.cwiseMax(box->second);
  } else {
    for (std::uint32_t v : voxels) {
      const Eigen::Vector3i p = volume_.geometry.voxelOf(v);
      dirtyMin_ = dirtyMin_.cwiseMin(p);
      dirtyMax_ = dirtyMax_.cwiseMax(p);
    }
  }
  for (std::uint32_t v : voxels) mask_[v] = ids_[v];
  for (std::uint32_t v : landing_) mask_[v] = HandleSet::kLiveSelectionId;
  for (std::uint32_t v : live_) mask_[v] = HandleSet::kLiveSelectionId;
  if (gpu_ && !voxels.empty()) {  // the handles changed under a pinch growing on the GPU
    try {
      gpu_->rebase();
    } catch (const Error&) {  // the engine stopped: the pinch grows on the CPU at its next step
    }
  }
}

void SelectionController::relabel(const HandleSet::MaskChange& change, std::vector<std::uint32_t> also, const std::optional<VoxelBox>& box) {
  also.reserve(also.size() + change.cleared.size() + change.joined.size());
  for (std::uint32_t v : change.cleared) {
    ids_[v] = 0;
    also.push_back(v);
  }
  for (const auto& [v, id] : change.joined) {
    ids_[v] = id;
    also.push_back(v);
  }
  repaint(also, box);
}

void SelectionController::refreshLive() {
  std::vector<std::uint32_t> old = std::move(live_);
  live_ = pinch_.state() == PinchSelection::State::Growing ? pinch_.liveVoxels() : std::vector<std::uint32_t>{};
  bool drawn = false;  // the finished pinch stays drawn as it was: its live voxels became landing_
  if (auto done = pinch_.takeFinishedPinch()) {
    if (editing()) {
      done->gather();  // its grower's arrays back now: the next pinch must not wait behind the queue
      queued_.push_back({std::nullopt, std::move(*done), pinchOp_, picked_});
    } else {
      drawn = startPinchEdit(std::move(*done), pinchOp_, picked_, old);
    }
  }
  // The GPU painted the live selection into its box: back to the handles' ids there.
  if (const auto box = gpu_ && !gpu_->growing() ? gpu_->takePaintedBox() : std::nullopt) {
    dirtyMin_ = dirtyMin_.cwiseMin(box->first);
    dirtyMax_ = dirtyMax_.cwiseMax(box->first + box->second - Eigen::Vector3i::Ones());
  }
  if (drawn) old.clear();
  old.insert(old.end(), live_.begin(), live_.end());
  if (!drawn || !old.empty()) repaint(old);
}

void SelectionController::detectTap(const TouchEvent& e, const TouchInput& input) {
  if (e.phase == TouchPhase::Down) {
    if (input.fingers().size() == 1) {
      tapFinger_ = e.id;
      tapStart_ = e.px;
      tapTime_ = e.time;
      tapSpoiled_ = false;
    } else {
      tapSpoiled_ = true;  // a second finger: a pinch, not a tap
    }
  } else if (e.id == tapFinger_) {
    if (glm::length(e.px - tapStart_) > 12.0 || e.time - tapTime_ > 0.3) tapSpoiled_ = true;
    if (e.phase == TouchPhase::Up && !tapSpoiled_ && input.fingers().empty()) tapRequest_ = e.px;
    if (e.phase == TouchPhase::Up || e.phase == TouchPhase::Cancel) tapFinger_ = -1;
  }
}

void SelectionController::manipulate(const TouchEvent& e, const TouchInput& input) {
  if (e.phase == TouchPhase::Down && input.fingers().size() == 1) abandonGrab();  // a new gesture: the last one's grab, if unanswered, is dropped
  gestureLast_[e.id] = e.px;
  if (e.phase != TouchPhase::Move) {
    if (!manipulator_.active() && (grabPending_ || grabFrame_)) {
      unansweredFingerChange(e, input);
      return;
    }
    // The finger set changed: re-anchor on the fingers now down (their points are picked anew).
    manipulator_.release();
    grabRequest_.clear();
    for (const auto& f : input.fingers()) grabRequest_.push_back({f.id, f.px});
    grabPending_ = !grabRequest_.empty();
    // A new gesture: its first grab of a handle is one undo step, even when more fingers come
    // down before that grab is answered (fingers landing in the same frame).
    if (e.phase == TouchPhase::Down && input.fingers().size() == 1) grabUndoable_ = true;
    if (input.fingers().empty()) {
      manipulated_ = 0;
      grabUndoable_ = false;
    }
    return;
  }
  std::vector<std::pair<std::int64_t, glm::dvec2>> px;
  for (const auto& f : input.fingers()) px.push_back({f.id, f.px});
  moveHandleTo(px);
}

void SelectionController::abandonGrab() {
  grabRequest_.clear();
  grabSent_.clear();
  gestureLast_.clear();
  grabPending_ = grabLifted_ = false;
  grabFrame_.reset();  // its picks, when they come, are ignored
}

void SelectionController::unansweredFingerChange(const TouchEvent& e, const TouchInput& input) {
  // The grab's picks are not back, so the handle is still where the fingers came down: a finger
  // added joins the grab where it came down; a finger lifted stays in it (the drag takes its point
  // to where it lifted). Every finger lifted: the grab goes on and the drag is applied when its
  // picks return (a quick drag on slow frames); cancelled: nothing moves.
  if (e.phase == TouchPhase::Down) {
    grabRequest_.push_back({e.id, e.px});
    grabPending_ = true;
    return;
  }
  if (!input.fingers().empty()) return;
  grabLifted_ = e.phase == TouchPhase::Up;
  if (grabLifted_) return;
  grabRequest_.clear();
  grabPending_ = false;
  grabSent_.clear();
  manipulated_ = 0;
  grabUndoable_ = false;
}

void SelectionController::moveHandleTo(const std::vector<std::pair<std::int64_t, glm::dvec2>>& fingersPx) {
  if (!manipulator_.active() || !manipulated_) return;
  const Handle* h = handles_.find(manipulated_);
  if (!h) return;
  const Viewport& vp = session_.gestures().viewport();
  std::vector<std::pair<std::int64_t, glm::dvec2>> ndc;
  for (const auto& [id, px] : fingersPx) ndc.push_back({id, vp.toNdc(px)});
  std::string why;
  const StageTimes::Scope t(stages_, "gesture-solve");
  const auto pose = manipulator_.move(ndc, h->pose, session_.camera(), double(vp.width) / vp.height, locks_, &why);
  if (pose) handles_.setPose(manipulated_, *pose, false);
  manipulationNote_ = why;
}

bool SelectionController::onActiveHandle(glm::dvec2 px) const {
  if (!haveParams_ || renderer_.transferFunction().entries.empty()) return false;
  const bool any = std::any_of(handles_.handles().begin(), handles_.handles().end(), [](const Handle& h) { return h.status == HandleStatus::Active; });
  if (!any) return false;
  const ReferenceScene scene{&volume_, &renderer_.transferFunction(), &renderer_.occupancy(), &mask_, nullptr};
  const auto hit = pickReference(scene, lastParams_, {glm::vec2(session_.gestures().viewport().toNdc(px))});
  if (hit.empty() || hit[0].world.w <= 0.5f) return false;
  const Handle* h = handles_.find(int(hit[0].voxel.w));
  return h && h->status == HandleStatus::Active;
}

std::vector<MovingHandlePose> SelectionController::movingHandles() const {
  std::vector<MovingHandlePose> out;
  for (const auto& h : handles_.handles())
    if (!h.pose.isIdentity()) {
      MovingHandlePose m{std::uint32_t(h.id), h.pose};
      m.restMin = volume_.geometry.dims;
      for (std::uint32_t v : h.voxels) {
        const Eigen::Vector3i p = volume_.geometry.voxelOf(v);
        m.restMin = m.restMin.cwiseMin(p);
        m.restMax = m.restMax.cwiseMax(p);
      }
      out.push_back(m);
    }
  return out;
}

void SelectionController::syncTints() {
  if (!tintsDirty_) return;
  renderer_.setHandleTints(handles_.tints(picked_.empty() ? 0 : picked_.back()));
  tintsDirty_ = false;
}

bool SelectionController::labelHandle(const std::string& value) {
  labelNote_.clear();
  if (!labels_) {
    labelNote_ = "No label map is loaded (--labels)";
    return false;
  }
  Eigen::Vector3i v;
  char c1 = 0, c2 = 0;
  std::istringstream in(value);
  if (!(in >> v.x() >> c1 >> v.y() >> c2 >> v.z()) || c1 != ',' || c2 != ',' || !labels_->geometry.contains(v)) {
    labelNote_ = "label-handle needs a voxel I,J,K inside the volume";
    return false;
  }
  if (labels_->at(v) == 0) {
    labelNote_ = "No labelled organ there";
    return false;
  }
  if (handles_.add(labelComponent(*labels_, v), std::uint32_t(linearIndex(labels_->geometry, v))) == 0) {
    labelNote_ = "No handle left for that organ";
    return false;
  }
  return true;
}

int SelectionController::correctionTarget(const std::vector<int>& picked) const {
  for (auto it = picked.rbegin(); it != picked.rend(); ++it)
    if (handles_.find(*it)) return *it;
  return handles_.handles().empty() ? 0 : handles_.handles().back().id;
}

bool SelectionController::startPinchEdit(FinishedPinch pinch, PinchOp op, const std::vector<int>& picked, std::vector<std::uint32_t>& shown) {
  const PinchRequest request{op, op == PinchOp::New ? 0 : correctionTarget(picked), corrections_};
  auto edit = [request, g = volume_.geometry](std::vector<Handle> handles, FinishedPinch p) {
    const std::uint32_t seed = p.seed;
    return applyPinchOnCopy(std::move(handles), std::move(p).complete(), seed, request, g);
  };
  if (!editsInBackground_) {
    takeIn(edit(handles_.handles(), std::move(pinch)), true);
    return false;
  }
  const StageTimes::Scope t(stages_, "selection-edit");
  // Drawn as the live selection until it lands: grown on the CPU and shown, what was shown (its
  // voxels are gathered on the worker); else its voxels (the engine's, or gathered now: a pinch
  // that ended as its picks came back was never shown).
  const bool showsLive = pinch.grower && !shown.empty();
  if (showsLive) landing_ = std::move(shown);
  else {
    pinch.gather();
    landing_ = pinch.voxels;
  }
  editIsPinch_ = true;
  editFuture_ = std::async(std::launch::async, edit, handles_.handles(), std::move(pinch));
  return showsLive;
}

bool SelectionController::correct(int a, int b, bool unite) {
  const StageTimes::Scope t(stages_, "selection-edit");
  correctionNote_.clear();
  editIsPinch_ = false;
  editRefusal_ = unite ? "Union refused: both handles must exist and differ"
                       : "Difference refused: it would leave nothing of the handle, or none of the other lies beyond a neck";
  if (!editsInBackground_) {
    EditOnCopy edit = correctOnCopy(handles_.handles(), a, b, unite, corrections_, volume_.geometry);
    const bool ok = edit.changed;
    takeIn(std::move(edit), false);
    return ok;
  }
  if (a == b || !handles_.find(a) || !handles_.find(b)) {  // refused as the handles would refuse it
    correctionNote_ = editRefusal_;
    return false;
  }
  editFuture_ = std::async(std::launch::async, correctOnCopy, handles_.handles(), a, b, unite, corrections_, volume_.geometry);
  return true;
}

void SelectionController::takeIn(EditOnCopy edit, bool pinch) {
  correctionNote_ = pinch ? edit.refusal : edit.changed ? std::string() : editRefusal_;
  std::vector<std::uint32_t> landed = std::exchange(landing_, {});
  if (edit.changed) {
    // A handle moved while the edit was made in the background keeps its new pose.
    for (Handle& h : edit.after)
      if (const Handle* now = handles_.find(h.id)) h.pose = now->pose;
    handles_.replace(std::move(edit.after));
    picked_.erase(std::remove_if(picked_.begin(), picked_.end(), [&](int id) { return !handles_.find(id); }), picked_.end());
    tintsDirty_ = true;
  }
  relabel(edit.mask, std::move(landed), VoxelBox{edit.boxMin, edit.boxMax});  // the box holds the landed pinch too
}

void SelectionController::poll() {
  if (editFuture_.valid() && editFuture_.wait_for(std::chrono::seconds(0)) == std::future_status::ready) {
    const StageTimes::Scope t(stages_, "selection-edit");
    EditOnCopy edit;
    try {
      edit = editFuture_.get();
    } catch (...) {  // the edit failed (its error goes on to the caller): the pinch is no longer drawn
      queued_.clear();
      repaint(std::exchange(landing_, {}));
      throw;
    }
    takeIn(std::move(edit), editIsPinch_);
  }
  while (!editFuture_.valid() && !queued_.empty()) {  // the edits that waited, in order, until one goes to the background
    QueuedEdit q = std::move(queued_.front());
    queued_.pop_front();
    if (!q.ui) {
      std::vector<std::uint32_t> none;
      startPinchEdit(std::move(q.pinch), q.op, q.picked, none);
      repaint(landing_);  // a pinch that waited is drawn from now (it was repainted as it ended)
      continue;
    }
    correctionNote_.clear();
    if (!applyEdit(*q.ui, true) && correctionNote_.empty())
      correctionNote_ = std::string(uiActionName(q.ui->action)) + " " + q.ui->value + " was refused";
  }
}

void SelectionController::finishEdits() {
  while (editing()) {
    if (editFuture_.valid()) editFuture_.wait();
    poll();
  }
}

bool SelectionController::applyUi(const ScriptEvent& e) {
  if (!isHandleEdit(e.action) || !editing()) return applyEdit(e);
  if ((grabPending_ || grabFrame_) && !manipulator_.active()) abandonGrab();
  queued_.push_back({e, {}, PinchOp::New, {}});
  return true;
}

bool SelectionController::applyEdit(const ScriptEvent& e, bool waited) {
  // A handle edit (undo included) comes after a drag whose picks are not back: the drag is
  // dropped rather than applied after the edit it preceded (an edit that waited did so when it came).
  if (!waited && (grabPending_ || grabFrame_) && !manipulator_.active() && isHandleEdit(e.action)) abandonGrab();
  auto ids = [&](int& a, int& b) {  // "A,B", each a whole number written in full
    const auto comma = e.value.find(',');
    const std::string_view v = e.value;
    return comma != std::string::npos && parseWholeNumber(v.substr(0, comma), a) && parseWholeNumber(v.substr(comma + 1), b);
  };
  if (e.action == UiAction::HandleUnion || e.action == UiAction::HandleDifference) {
    int a = 0, b = 0;
    return ids(a, b) && correct(a, b, e.action == UiAction::HandleUnion);
  }
  const auto before = handles_.handles();
  bool ok = false;
  switch (e.action) {
    case UiAction::HandleStatus: {
      const auto colon = e.value.find(':');
      HandleStatus st;
      int id = 0;
      ok = colon != std::string::npos && parseHandleStatus(e.value.substr(colon + 1), st) &&
           parseWholeNumber(std::string_view(e.value).substr(0, colon), id) && handles_.setStatus(id, st);
      if (ok) tintsDirty_ = true;
      return ok;
    }
    case UiAction::HandleDelete: {
      int id = 0;
      ok = parseWholeNumber(e.value, id) && handles_.remove(id);
      break;
    }
    case UiAction::PinchOp: {
      PinchOp op;
      if (!parsePinchOp(e.value, op)) return false;
      pinchOp_ = op;
      return true;
    }
    case UiAction::LabelHandle: ok = labelHandle(e.value); break;
    case UiAction::ToggleLock: {
      unsigned lock = 0;
      if (!parseGestureLock(e.value, lock)) return false;
      locks_ ^= lock;
      return true;
    }
    case UiAction::Undo: ok = handles_.undo(); break;
    case UiAction::Redo: ok = handles_.redo(); break;
    default: return false;
  }
  if (ok) {
    relabel(HandleSet::maskChange(before, handles_.handles()));
    picked_.erase(std::remove_if(picked_.begin(), picked_.end(), [&](int id) { return !handles_.find(id); }), picked_.end());
    tintsDirty_ = true;
  }
  return ok;
}

void SelectionController::prepareFrame(FrameRequest& req, const Viewport& vp) {
  syncTints();
  pickInRequest_ = false;
  tapInRequest_ = false;
  if (tapRequest_) {
    tapOffset_ = req.pickPoints.size();
    req.pickPoints.push_back(glm::vec2(vp.toNdc(*tapRequest_)));
    tapRequest_.reset();
    tapInRequest_ = true;
  }
  grabInRequest_ = false;
  if (grabPending_) {
    grabOffset_ = req.pickPoints.size();
    for (const auto& [id, px] : grabRequest_) req.pickPoints.push_back(glm::vec2(vp.toNdc(px)));
    grabPending_ = false;
    grabInRequest_ = true;
    grabSent_ = grabRequest_;
    grabSentUndoable_ = grabUndoable_;
  }
  setMovingHandles(req.params, volume_.geometry, movingHandles());
  lastParams_ = req.params;  // the CPU grab probe sees moved handles where they are, either way
  haveParams_ = true;
  if (!rigidPreview_) req.params.movingCount = 0;  // the deformed volume already holds them there
  const auto pts = pinch_.takePickRequest();
  if (!pts.empty()) {
    pickOffset_ = req.pickPoints.size();
    for (const auto& p : pts) req.pickPoints.push_back(glm::vec2(vp.toNdc(p)));  // finger positions are continuous pixels
    pickInRequest_ = true;
  }
  if ((dirtyMin_.array() <= dirtyMax_.array()).all()) {
    const auto& d = volume_.geometry.dims;
    upload_ = maskBox(mask_, d, dirtyMin_, dirtyMax_ - dirtyMin_ + Eigen::Vector3i::Ones());
    req.maskUpload = &upload_;
    dirtyMin_ = d;
    dirtyMax_ = Eigen::Vector3i(-1, -1, -1);
  }
}

void SelectionController::submitted(std::uint64_t frame) {
  if (pickInRequest_) pickFrame_ = frame;
  if (tapInRequest_) tapFrame_ = frame;
  if (grabInRequest_) grabFrame_ = frame;
}

void SelectionController::onGrabResult(const FrameResult& r) {
  grabFrame_.reset();
  if (grabPending_) return;  // a finger came down since: the grab that includes it answers instead
  if (editing()) {  // a move now would be an undo step before the edit's: the handles wait for it
    abandonGrab();
    manipulationNote_ = "The selection is being edited: touch the handle again once it is done";
    return;
  }
  const std::vector<std::pair<std::int64_t, glm::dvec2>> sent = std::exchange(grabSent_, {});
  const bool lifted = std::exchange(grabLifted_, false);
  // The handle under the fingers: the one already being moved if a finger is on it, else the
  // first handle hit. Fingers on that handle anchor; the others ride along unanchored.
  int target = 0;
  for (std::size_t i = 0; i < sent.size() && grabOffset_ + i < r.picks.size(); ++i) {
    const int id = r.picks[grabOffset_ + i].world.w > 0.5f ? r.picks[grabOffset_ + i].voxel.w : 0;
    if (id > 0 && handles_.find(id) && (target == 0 || id == manipulated_)) target = id;
  }
  std::vector<FingerAnchor> anchors;
  for (std::size_t i = 0; i < sent.size() && grabOffset_ + i < r.picks.size(); ++i) {
    const auto& pk = r.picks[grabOffset_ + i];
    if (target && pk.world.w > 0.5f && pk.voxel.w == target) anchors.push_back({sent[i].first, Eigen::Vector3d(pk.world.x, pk.world.y, pk.world.z)});
  }
  if (target && !rigidPreview_) {
    // The frame showed the deformed volume: anchor on the handle's own voxels, within a fine tet
    // (at least two voxels) of the picked surface.
    const Handle* h = handles_.find(target);
    const glm::dvec3 e = session_.camera().eye();
    const double window = std::max(blurMm_, 2.0 * volume_.geometry.spacing.maxCoeff());
    for (auto& a : anchors)
      if (const auto c = contactOnHandle(volume_.geometry, mask_, target, h->pose, {Eigen::Vector3d(e.x, e.y, e.z), a.world, window})) a.world = *c;
  }
  const TouchInput& input = session_.gestures().input();
  const bool down = !input.fingers().empty();
  if (target && !anchors.empty() && (down || lifted)) {
    const RigidTransform picked = handles_.find(target)->pose;  // the pose the picks saw
    if (grabUndoable_ || grabSentUndoable_) handles_.setPose(target, picked, true);  // one undo step per gesture
    grabUndoable_ = false;
    manipulated_ = target;
    manipulator_.anchor(anchors, picked);
    manipulationNote_.clear();
    // The fingers may have moved (or lifted) since they came down: the handle catches up with
    // them at once, each finger where it is now or where it lifted (its last event).
    std::vector<std::pair<std::int64_t, glm::dvec2>> at;
    for (const auto& [id, px] : sent) {
      const auto last = gestureLast_.find(id);
      at.push_back({id, last != gestureLast_.end() ? last->second : px});
    }
    moveHandleTo(at);
    if (!down) {  // lifted before the picks returned: the gesture ends here
      manipulator_.release();
      manipulated_ = 0;
    } else {
      // Fingers lifted since the grab was sent no longer hold the handle: the ones still down
      // anchor on the same points of it (its rest frame), wherever the catch-up put them.
      const RigidTransform now = handles_.find(target)->pose;
      std::vector<FingerAnchor> held;
      for (const FingerAnchor& a : anchors)
        if (std::any_of(input.fingers().begin(), input.fingers().end(), [&](const Finger& f) { return f.id == a.finger; }))
          held.push_back({a.finger, now.apply(picked.toRest(a.world))});
      if (held.empty()) {
        manipulator_.release();
        manipulated_ = 0;
      } else if (held.size() < anchors.size()) {
        manipulator_.anchor(held, now);
      }
    }
  } else if (!target) {
    manipulationNote_ = "Touch a handle to move it";
  }
}

void SelectionController::onFrameResult(const FrameResult& r) {
  if (grabFrame_ && r.frame == *grabFrame_) onGrabResult(r);
  if (tapFrame_ && r.frame == *tapFrame_) {
    tapFrame_.reset();
    if (tapOffset_ < r.picks.size() && r.picks[tapOffset_].world.w > 0.5f) {
      const int id = r.picks[tapOffset_].voxel.w;
      if (id == HandleSet::kLiveSelectionId) {
        // The live selection, or a pinch whose edit is being made: not a handle yet.
      } else if (id > 0 && handles_.find(id)) {
        picked_.erase(std::remove(picked_.begin(), picked_.end(), id), picked_.end());
        picked_.push_back(id);
        if (picked_.size() > 2) picked_.erase(picked_.begin());
        tintsDirty_ = true;
      } else if (labels_) {
        // A tap on an organ that is no handle yet: the organ behind the picked surface (the first
        // 2 voxels or 4 mm of the ray) becomes a handle. Applied here, not recorded as an action:
        // the tap's touches are, and replay picks the same point.
        const glm::dvec3 hit(r.picks[tapOffset_].world);
        const glm::dvec3 dir = hit - session_.camera().eye();
        const double depth = std::max(4.0, 2.0 * labels_->geometry.spacing.maxCoeff());
        if (const auto v = labelledVoxelBehind(*labels_, {hit.x, hit.y, hit.z}, {dir.x, dir.y, dir.z}, depth)) {
          std::ostringstream text;
          text << v->x() << "," << v->y() << "," << v->z();
          applyUi(uiEvent(0.0, UiAction::LabelHandle, text.str()));
        } else {
          labelNote_ = "No labelled organ there";
        }
      }
    }
  }
  if (!pickFrame_ || r.frame != *pickFrame_) return;
  pickFrame_.reset();
  std::vector<std::optional<glm::dvec3>> world;
  for (std::size_t i = pickOffset_; i < pickOffset_ + 2 && i < r.picks.size(); ++i)
    world.push_back(r.picks[i].world.w > 0.5f ? std::optional<glm::dvec3>(glm::dvec3(r.picks[i].world)) : std::nullopt);
  const StageTimes::Scope t(stages_, "selection-update");
  pinch_.onPicks(world, session_.camera(), session_.gestures().viewport());
  if (pinch_.changed()) refreshLive();
}

}  // namespace handson
