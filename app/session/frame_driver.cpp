#include "app/session/frame_driver.h"

#include "interaction/cut_stroke.h"
#include "render/auto_window.h"
#include "sim/base/error.h"
#include "render/transfer_function.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <utility>

namespace handson {

bool FrameDriver::applyUi(const ScriptEvent& e) {
  if (e.action == UiAction::AutoWindow) return applyAutoWindow();
  if (e.action == UiAction::ClearCuts) {
    deform_.clearCuts();
    return true;
  }
  if (e.action == UiAction::Cut) try {
      return deform_.addCut(parseCutQuads(e.value));
    } catch (const Error&) {
      return false;  // refused: not a cut's quads
    }
  if (e.action != UiAction::SetInterface) return false;
  const auto i = parseInterface(e.value);
  if (!i) return false;  // refused: an unknown interface
  deform_.setInterface(*i);
  return true;
}

FrameOutcome FrameDriver::frame(const FrameInput& in, FrameTiming& ft) {
  FrameOutcome out;
  selection_.poll();  // a handle edit made in the background since the last frame
  const bool applied = applyInput(in, ft, out);
  const double clock = in.sessionClock >= 0.0 ? in.sessionClock : now();
  followClip(in.followClip, clock);
  session_.advance(clock);  // a framing's camera move
  refreshTransferFunction();
  FrameRequest req = request(in.view, in.width, in.height);
  out.exportImage = in.exportImage && in.exportImage();
  req.readbackImage = in.readbackImage || out.exportImage;
  req.extension = in.extension;
  attachSimulation(req, in.settled);
  out.newFailure = newFailure();
  attachSelection(req, in.view, ft);
  out.quality = applyFrameBudget(req, applied, out.exportImage);
  out.width = req.params.outputWidth;
  out.height = req.params.outputHeight;
  ft.qualityScale = out.quality.scale;
  ft.qualityStep = out.quality.stepScale;
  recordSimulation(ft);
  if (in.beforeSubmit) in.beforeSubmit();
  ft.cpuEnd = now();
  out.frame = submit(req);  // waits only for the frame two submissions back
  ft.frame = out.frame;
  out.stillPhases = ft.stillPhases = renderer_.stillPhasesShown();
  ft.submit = now();
  return out;
}

bool FrameDriver::applyInput(const FrameInput& in, FrameTiming& ft, FrameOutcome& out) {
  for (const FrameInput::Event& e : in.events) {
    const double arrived = e.arrived >= 0.0 ? e.arrived : now();
    if (!session_.apply(e.event)) out.refused.push_back(e.event);
    if (ft.inputFirst < 0 || arrived < ft.inputFirst) ft.inputFirst = arrived;
    ft.inputLast = std::max(ft.inputLast, arrived);
    ++ft.inputCount;
  }
  std::size_t actions = 0;
  if (in.panels)
    for (const ScriptEvent& a : in.panels()) {
      ++actions;
      if (!session_.apply(a)) out.refused.push_back(a);
    }
  return !in.events.empty() || actions > 0;
}

void FrameDriver::followClip(bool follow, double now) {
  if (!session_.takeClipSettled() || !follow) return;  // taken either way: a settled drag is followed once or not at all
  session_.apply(uiEvent(now, UiAction::FrameClip));
  if (session_.windowFollowsRegion()) session_.apply(uiEvent(now, UiAction::AutoWindow));
}

bool FrameDriver::applyAutoWindow() {
  // The preset's ramps on the soft tissue of what the clip leaves (the whole volume without one);
  // refused where there is none (too few soft-tissue voxels) or the preset has no reference.
  const auto w = autoWindowFor(volume_, transferFunctionPreset(session_.preset()), session_.clip());
  if (!w) return false;
  session_.setAutomaticWindow(WindowLevel{1.0, w->shift, session_.window().opacity});
  return true;
}

void FrameDriver::refreshTransferFunction() {
  if (!session_.takePresetChanged()) return;
  tfChanged_ = true;
  const WindowLevel& w = session_.window();
  renderer_.setTransferFunction(transferFunctionPreset(session_.preset()).windowed(w.scale, w.shift, w.opacity).lookupTable(q_));
}

FrameRequest FrameDriver::request(const Viewport& vp, int width, int height) const {
  RenderSettings rs;
  rs.width = width;
  rs.height = height;
  rs.strainOverlay = session_.strainOverlay();
  rs.limitHighlight = session_.limitHighlight();
  rs.labelTint = session_.labelTint();
  rs.clip = session_.clip();
  const OrbitCamera& cam = session_.camera();
  FrameRequest req;
  req.params = makeRenderParams(volume_.geometry(), cam.view(), cam.projection(double(vp.width) / vp.height), glm::vec3(cam.eye()), rs);
  return req;
}

void FrameDriver::attachSimulation(FrameRequest& request, bool settled) {
  const bool simulated = settled ? deform_.prepareFrameSettled(request, selection_.handles()) : deform_.prepareFrame(request, selection_.handles());
  selection_.setRigidPreview(!simulated, simulated ? deform_.fineCellMm() : 0.0);
}

void FrameDriver::attachSelection(FrameRequest& request, const Viewport& vp, FrameTiming& ft) {
  selection_.prepareFrame(request, vp);
  if (const auto px = session_.takeClipPickRequest()) {
    // A clip plane goes through the point under the finger: picked in this frame.
    clipPickOffset_ = request.pickPoints.size();
    const glm::dvec2 ndc = vp.toNdc(*px);
    request.pickPoints.emplace_back(float(ndc.x), float(ndc.y));
    clipPickInRequest_ = true;
  }
  ft.cpuMs = selection_.takeStageTimes();
  for (auto& stage : deform_.takeStageTimes()) ft.cpuMs.push_back(std::move(stage));
}

void FrameDriver::recordSimulation(FrameTiming& ft) const {
  ft.simState = deform_.modelState();
  ft.simStateS = deform_.shownInput() > 0 ? deform_.shownSeconds() : -1.0;
  ft.reactions = deform_.shownReactions();
}

bool FrameDriver::newFailure() {
  const std::uint64_t failures = deform_.failures();
  if (failures == failuresSeen_) return false;
  failuresSeen_ = failures;
  return true;
}

FrameQuality FrameDriver::applyFrameBudget(FrameRequest& request, bool eventsApplied, bool fullQuality) {
  // The picture's parameters (its full size included: a resized view changes) apart from the
  // picks and what the budget and the still frame's sum set below.
  gpu::RenderParams p = request.params;
  p.pickCount = 0;
  p.stepScale = 0.0f;
  p.jitterPhase = p.summedFrames = 0;
  p.flags &= ~gpu::kFlagShowSum;
  const bool sameParams = hasLastParams_ && std::memcmp(&p, &lastParams_, sizeof(p)) == 0;
  lastParams_ = p;
  hasLastParams_ = true;
  // A finger still down is part of a gesture in progress (a held drag, a rebuild waited for with
  // the organ held): its frames stay within the budget, as an interaction's frames do until the
  // button is released in desktop viewers; the still frames' refinement starts when the fingers lift.
  const bool touching = !session_.gestures().input().fingers().empty();
  const bool changing = eventsApplied || touching || !sameParams || std::exchange(tfChanged_, false) || request.maskUpload || request.deform || request.deformFine;
  nextQuality_ = budget_.next(changing);
  if (fullQuality) nextQuality_ = FrameQuality{};
  // Full quality: a still picture sums the jitter phases (the renderer sees when it changes; the
  // phases depend only on the frames, so replays stay bit-identical and the settled frame is the
  // same with a budget or without).
  request.stillPhases = nextQuality_.full() ? kStillJitterPhases : 0;
  if (nextQuality_.full()) return nextQuality_;
  const int w = request.params.outputWidth, h = request.params.outputHeight;
  request.params.outputWidth = std::max(1, int(std::lround(w * nextQuality_.scale)));
  request.params.outputHeight = std::max(1, int(std::lround(h * nextQuality_.scale)));
  request.params.stepScale *= float(nextQuality_.stepScale);
  return nextQuality_;
}

std::uint64_t FrameDriver::submit(const FrameRequest& request) {
  const std::uint64_t frame = renderer_.submit(request);
  if (budget_.enabled()) inFlight_.emplace_back(frame, std::exchange(nextQuality_, FrameQuality{}));
  selection_.submitted(frame);
  if (std::exchange(clipPickInRequest_, false)) clipPickFrame_ = frame;
  return frame;
}

void FrameDriver::completed(const FrameResult& result) {
  // The budget learns from the frame's GPU times: the raymarch at the quality it was drawn with,
  // and the rest.
  while (!inFlight_.empty() && inFlight_.front().first < result.frame) inFlight_.pop_front();
  if (!inFlight_.empty() && inFlight_.front().first == result.frame) {
    double ray = 0.0, other = 0.0;
    bool drawn = false;
    for (const auto& t : result.timings) {
      if (t.id == PassId::Raymarch) {
        ray += t.gpuMs;
        drawn = true;
      } else {
        other += t.gpuMs;
      }
    }
    if (drawn) budget_.measured(inFlight_.front().second, ray, other);
    inFlight_.pop_front();
  }
  selection_.onFrameResult(result);
  if (!clipPickFrame_ || result.frame != *clipPickFrame_) return;
  clipPickFrame_.reset();
  const bool hit = clipPickOffset_ < result.picks.size() && result.picks[clipPickOffset_].world.w > 0.5f;
  session_.clipPicked(hit ? std::optional<glm::dvec3>(glm::dvec3(result.picks[clipPickOffset_].world)) : std::nullopt);
}

}  // namespace handson
