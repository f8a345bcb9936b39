#include "app/session/frame_driver.h"

#include "render/transfer_function.h"

#include <utility>

namespace handson {

void FrameDriver::refreshTransferFunction() {
  if (!session_.takePresetChanged()) return;
  const WindowLevel& w = session_.window();
  renderer_.setTransferFunction(transferFunctionPreset(session_.preset()).windowed(w.scale, w.shift, w.opacity).lookupTable(q_));
}

FrameRequest FrameDriver::request(const Viewport& vp, int width, int height) const {
  RenderSettings rs;
  rs.width = width;
  rs.height = height;
  rs.strainOverlay = session_.strainOverlay();
  rs.labelTint = session_.labelTint();
  rs.clip = session_.clip();
  const OrbitCamera& cam = session_.camera();
  FrameRequest req;
  req.params = makeRenderParams(volume_.geometry(), cam.view(), cam.projection(double(vp.width) / vp.height), glm::vec3(cam.eye()), rs);
  return req;
}

void FrameDriver::attachSimulation(FrameRequest& request, bool settled) {
  const bool simulated = settled ? deform_.prepareFrameSettled(request, selection_.handles()) : deform_.prepareFrame(request, selection_.handles());
  selection_.setRigidPreview(!simulated);
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

std::uint64_t FrameDriver::submit(const FrameRequest& request) {
  const std::uint64_t frame = renderer_.submit(request);
  selection_.submitted(frame);
  if (std::exchange(clipPickInRequest_, false)) clipPickFrame_ = frame;
  return frame;
}

void FrameDriver::completed(const FrameResult& result) {
  selection_.onFrameResult(result);
  if (!clipPickFrame_ || result.frame != *clipPickFrame_) return;
  clipPickFrame_.reset();
  const bool hit = clipPickOffset_ < result.picks.size() && result.picks[clipPickOffset_].world.w > 0.5f;
  session_.clipPicked(hit ? std::optional<glm::dvec3>(glm::dvec3(result.picks[clipPickOffset_].world)) : std::nullopt);
}

}  // namespace handson
