#include "app/frame_driver.h"

#include "render/transfer_function.h"

namespace handson {

void FrameDriver::refreshTransferFunction() {
  if (session_.takePresetChanged()) renderer_.setTransferFunction(transferFunctionPreset(session_.preset()).lookupTable(q_));
}

FrameRequest FrameDriver::request(const Viewport& vp, int width, int height) const {
  RenderSettings rs;
  rs.width = width;
  rs.height = height;
  rs.strainOverlay = session_.strainOverlay();
  rs.labelTint = session_.labelTint();
  const Session::Clip& clip = session_.clip();
  rs.clipBox = clip.box;
  rs.clipMin = clip.lo;
  rs.clipMax = clip.hi;
  rs.clipPlane = clip.plane;
  rs.clipNormal = clip.normal;
  rs.clipOffset = clip.offset;
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
  return frame;
}

}  // namespace handson
