// The frame sequence (app/session/frame_driver): one call runs a frame for the window and the
// replay alike. Its submissions go to a recording renderer, so the tests see what a frame hands
// over and in which order; the selection and the simulation run on a real renderer (lavapipe,
// validation on), as they do in the app.
#include <gtest/gtest.h>

#include <chrono>
#include <cstring>
#include <memory>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "app/session/frame_driver.h"
#include "app/session/session_parts.h"
#include "render/render_params.h"
#include "render/transfer_function.h"
#include "interaction/camera.h"
#include "interaction/label_map.h"
#include "interaction/view_adjust.h"
#include "sim/phantom.h"
#include "tests/app/session/phantom_on_gpu.h"

using namespace handson;

namespace {

// A renderer that records what the driver asks of it, in order ("tf", "submit"), and keeps the
// requests' parameters.
class RecordingRenderer final : public FrameRenderer {
 public:
  explicit RecordingRenderer(std::vector<std::string>& calls) : calls_(calls) {}
  void setTransferFunction(const TfTable&) override { calls_.push_back("tf"); }
  std::uint64_t submit(const FrameRequest& r) override {
    calls_.push_back("submit");
    submitted.push_back(r.params);
    masks.push_back(r.maskUpload != nullptr);
    if (r.maskUpload) uploads.push_back(*r.maskUpload);
    deforms.push_back(r.deform != nullptr || r.deformFine != nullptr);
    picks.push_back(r.pickPoints.size());
    readbacks.push_back(r.readbackImage);
    stillRequested.push_back(r.stillPhases);
    return submitted.size();
  }
  int stillPhasesShown() const override { return 0; }
  std::vector<gpu::RenderParams> submitted;
  std::vector<bool> masks, deforms, readbacks;
  std::vector<MaskUpload> uploads;
  std::vector<std::size_t> picks;
  std::vector<int> stillRequested;

 private:
  std::vector<std::string>& calls_;
};

// The renderer: the controllers' (their GPU passes and uploads).
struct DriverScene : test::PhantomOnGpu {
  std::unique_ptr<Session> session;
  SessionParts parts;
  std::vector<std::string> calls;
  RecordingRenderer frames{calls};
  std::unique_ptr<FrameDriver> driver;
  const Viewport vp{64, 48};

  DriverScene() {
    session = std::make_unique<Session>(phantom.ct.geometry(), vp, "ct-abdomen");
    SessionOptions o;
    o.quiet = true;
    o.sim.enabled = false;
    o.selectionBackend = SelectionBackend::Cpu;
    parts = makeSessionParts(o, phantom.ct, q, *session, *renderer, nullptr);
    driver = std::make_unique<FrameDriver>(phantom.ct, q, *session, frames, *parts.selection, *parts.deform);
  }
  FrameInput input() const {
    FrameInput in;
    in.view = vp;
    in.width = vp.width;
    in.height = vp.height;
    return in;
  }
};

}  // namespace

TEST(FrameDriver, AFrameWithNothingToDoSubmitsTheSamePictureAndNothingElse) {
  DriverScene s;
  FrameTiming ft0, ft1;
  const FrameOutcome first = s.driver->frame(s.input(), ft0);
  s.calls.clear();
  const FrameOutcome second = s.driver->frame(s.input(), ft1);
  // One submission and no other call (the transfer function is not set again); the same picture.
  ASSERT_EQ(s.calls, std::vector<std::string>({"submit"}));
  EXPECT_EQ(first.frame, 1u);
  EXPECT_EQ(second.frame, 2u);
  EXPECT_EQ(std::memcmp(&s.frames.submitted[0], &s.frames.submitted[1], sizeof(gpu::RenderParams)), 0);
  // Nothing attached: no mask upload, no simulation state, no picks, no image read back.
  EXPECT_FALSE(s.frames.masks[1]);
  EXPECT_FALSE(s.frames.deforms[1]);
  EXPECT_EQ(s.frames.picks[1], 0u);
  EXPECT_FALSE(s.frames.readbacks[1]);
  // No input, no refusal, no failure; without a budget, full quality at the asked size, the
  // still picture summing its jitter phases.
  EXPECT_EQ(ft1.inputCount, 0);
  EXPECT_LT(ft1.inputFirst, 0.0);
  EXPECT_TRUE(second.refused.empty());
  EXPECT_FALSE(second.newFailure);
  EXPECT_FALSE(second.exportImage);
  EXPECT_TRUE(second.quality.full());
  EXPECT_EQ(second.width, s.vp.width);
  EXPECT_EQ(second.height, s.vp.height);
  EXPECT_EQ(s.frames.stillRequested[1], kStillJitterPhases);
  EXPECT_EQ(ft1.frame, 2u);
  EXPECT_LE(ft1.cpuStart, ft1.cpuEnd);
  EXPECT_LE(ft1.cpuEnd, ft1.submit);
}

TEST(FrameDriver, TheSequenceAppliesTheInputThenThePanelsThenMakesAndSubmitsTheRequest) {
  DriverScene s;
  FrameTiming ft0;
  s.driver->frame(s.input(), ft0);
  const gpu::RenderParams before = s.frames.submitted.back();
  s.calls.clear();
  // A one-finger drag in navigate mode orbits; the panels see the finger down (the input applied
  // before them) and answer with a preset change and an action the session refuses.
  FrameInput in = s.input();
  in.events.push_back({touchEvent(0.0, TouchPhase::Down, 1, {20.0, 24.0}), 0.5});
  in.events.push_back({touchEvent(0.05, TouchPhase::Move, 1, {40.0, 24.0}), 0.25});
  std::size_t fingersSeen = 0;
  in.panels = [&] {
    s.calls.push_back("panels");
    fingersSeen = s.session->gestures().input().fingers().size();
    return std::vector<ScriptEvent>{uiEvent(0.1, UiAction::SetPreset, "ct-bone"), uiEvent(0.1, UiAction::SetMode, "no-such-mode")};
  };
  in.beforeSubmit = [&] { s.calls.push_back("before-submit"); };
  bool exportAsked = false;
  in.exportImage = [&] {
    exportAsked = true;
    return true;
  };
  s.driver->setFrameBudget(33.0);
  FrameTiming ft;
  const FrameOutcome out = s.driver->frame(in, ft);
  EXPECT_EQ(s.calls, std::vector<std::string>({"panels", "tf", "before-submit", "submit"}));
  EXPECT_EQ(fingersSeen, 1u);
  EXPECT_EQ(s.session->preset(), "ct-bone");
  // The refused action comes back; the input is counted with its arrival times.
  ASSERT_EQ(out.refused.size(), 1u);
  EXPECT_EQ(out.refused[0].value, "no-such-mode");
  EXPECT_EQ(ft.inputCount, 2);
  EXPECT_DOUBLE_EQ(ft.inputFirst, 0.25);
  EXPECT_DOUBLE_EQ(ft.inputLast, 0.5);
  // The orbit is in the request; the export's image is read back at full quality though the
  // picture changes under a budget.
  EXPECT_NE(std::memcmp(&before, &s.frames.submitted.back(), sizeof(gpu::RenderParams)), 0);
  EXPECT_TRUE(exportAsked);
  EXPECT_TRUE(out.exportImage);
  EXPECT_TRUE(s.frames.readbacks.back());
  EXPECT_TRUE(out.quality.full());
  // The next frame, the finger still down and no export: the budget's frame, drawn smaller.
  FrameTiming ft2;
  const FrameOutcome next = s.driver->frame(s.input(), ft2);
  EXPECT_FALSE(next.exportImage);
  EXPECT_EQ(next.quality.scale < 1.0 || next.quality.stepScale > 1.0, !next.quality.full());
}

TEST(FrameDriver, EventsWithoutAnArrivalTimeAreStampedAsTheyAreApplied) {
  // A replay's script events carry no arrival time: the timing log takes when each was applied.
  DriverScene s;
  FrameInput in = s.input();
  in.events = {{uiEvent(0.0, UiAction::SetMode, "select"), -1.0}, {uiEvent(0.0, UiAction::SetMode, "navigate"), -1.0}};
  const double before = s.driver->now();
  FrameTiming ft;
  s.driver->frame(in, ft);
  EXPECT_EQ(ft.inputCount, 2);
  EXPECT_GE(ft.inputFirst, before);
  EXPECT_GE(ft.inputLast, ft.inputFirst);
  EXPECT_LE(ft.inputLast, ft.cpuEnd);
}

// Where a Clip-mode finger grabs the face of the box [-r, r]^3 (none: nullopt).
std::optional<glm::dvec2> boxFaceHandle(const Session& s, const Viewport& vp, double r) {
  for (int axis = 0; axis < 3; ++axis)
    for (bool high : {false, true}) {
      const BoxFace f{axis, high};
      const auto px = projectToPixel(s.camera(), vp, faceCentre(glm::dvec3(-r), glm::dvec3(r), f));
      if (!px) continue;
      const auto grabbed = boxFaceNear(glm::dvec3(-r), glm::dvec3(r), s.camera(), vp, *px);
      if (grabbed && grabbed->axis == axis && grabbed->high == high) return px;
    }
  return std::nullopt;
}

TEST(FrameDriver, AClipDragThatSettledIsFramedOnlyWhereTheCallerFollowsIt) {
  // The window frames a clip its own gestures changed once the finger lifts (followClip); a
  // played or replayed script carries that framing as an action, so its frames let the drag go.
  for (const bool follow : {false, true}) {
    DriverScene s;
    FrameTiming ft;
    ASSERT_TRUE(s.session->apply(uiEvent(0.0, UiAction::SetMode, "clip")));
    ASSERT_TRUE(s.session->apply(uiEvent(0.0, UiAction::SetClipBox, "-60,-60,-60,60,60,60")));
    const auto handle = boxFaceHandle(*s.session, s.vp, 60.0);
    ASSERT_TRUE(handle.has_value());
    const OrbitCamera start = s.session->camera();
    FrameInput in = s.input();
    in.followClip = follow;
    in.events = {{touchEvent(1.0, TouchPhase::Down, 7, *handle), 1.0}, {touchEvent(1.1, TouchPhase::Move, 7, *handle + glm::dvec2(10, 6)), 1.1},
                 {touchEvent(1.2, TouchPhase::Up, 7, *handle + glm::dvec2(10, 6)), 1.2}};
    in.sessionClock = 1.2;
    s.driver->frame(in, ft);
    // Frames later, the framing (if any) has ended.
    FrameInput later = s.input();
    later.followClip = true;
    later.sessionClock = 1.2 + 2.0 * Session::kFramingSeconds;
    s.driver->frame(later, ft);
    const bool moved = s.session->camera().distance != start.distance || s.session->camera().target != start.target;
    EXPECT_EQ(moved, follow) << (follow ? "followed: framed" : "let go, and not framed by a later frame either");
  }
}

namespace {

// The first voxel of a label, as "I,J,K".
std::string firstVoxelOf(const Volume& labels, int label) {
  for (std::size_t v = 0; v < labels.voxelCount(); ++v)
    if (labels.value(v) == float(label)) {
      const Eigen::Vector3i p = labels.geometry().voxelOf(std::uint32_t(v));
      return std::to_string(p.x()) + "," + std::to_string(p.y()) + "," + std::to_string(p.z());
    }
  return "";
}

// The phantom's liver and right kidney as handles 1 and 2 (label-handle actions in one frame), with
// edits in the background or not.
struct LabelledScene {
  DriverScene s;
  LabelMap labels = labelsOnGrid(s.phantom.labels, s.phantom.ct.geometry());
  SelectionController& sel = *s.parts.selection;
  FrameTiming ft;
  FrameInput in = s.input();
  explicit LabelledScene(bool background) {
    sel.setLabels(&labels);
    sel.setEditsInBackground(background);
    for (int label : {int(label::kLiver), int(label::kKidneyRight)})
      in.events.push_back({uiEvent(0.0, UiAction::LabelHandle, firstVoxelOf(s.phantom.labels, label)), 0.0});
    s.driver->frame(in, ft);
  }
  FrameOutcome frame(std::vector<FrameInput::Event> events) {
    in.events = std::move(events);
    return s.driver->frame(in, ft);
  }
  // Frames with no input until the edits are in (at most 3 s).
  void untilEditsAreIn() {
    for (int n = 0; n < 600 && sel.editing(); ++n) {
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
      frame({});
    }
    EXPECT_FALSE(sel.editing());
  }
};

struct EditedSession {
  std::vector<Handle> handles;
  bool canUndo = false, canRedo = false;
  std::vector<std::uint8_t> uploaded;  // the mask as the frames uploaded it
  bool editingAfterItsFrame = false;
  std::size_t handlesAfterItsFrame = 0;
};

// The liver and the right kidney made handles; then, in one frame, their union and an undo;
// frames until the edits are in.
EditedSession editSession(bool background) {
  LabelledScene l(background);
  const FrameOutcome edited = l.frame({{uiEvent(0.1, UiAction::HandleUnion, "1,2"), 0.1}, {uiEvent(0.1, UiAction::Undo), 0.1}});
  EXPECT_TRUE(edited.refused.empty());
  EditedSession out;
  out.editingAfterItsFrame = l.sel.editing();
  out.handlesAfterItsFrame = l.sel.handles().handles().size();
  l.untilEditsAreIn();
  DriverScene& s = l.s;
  SelectionController& sel = l.sel;
  l.frame({});  // the mask of what landed last
  out.handles = sel.handles().handles();
  out.canUndo = sel.handles().canUndo();
  out.canRedo = sel.handles().canRedo();
  out.uploaded.assign(s.q.data.size(), 0);
  const Eigen::Vector3i d = s.q.geometry.dims;
  for (const MaskUpload& u : s.frames.uploads)
    for (int k = 0; k < u.dims.z(); ++k)
      for (int j = 0; j < u.dims.y(); ++j)
        for (int i = 0; i < u.dims.x(); ++i)
          out.uploaded[std::size_t(u.min.x() + i) + std::size_t(d.x()) * (std::size_t(u.min.y() + j) + std::size_t(d.y()) * std::size_t(u.min.z() + k))] =
              u.ids[std::size_t(i) + std::size_t(u.dims.x()) * (std::size_t(j) + std::size_t(u.dims.y()) * std::size_t(k))];
  return out;
}

}  // namespace

TEST(FrameDriver, AnEditInTheBackgroundLandsAtALaterFrameAndTheEditsBehindItFollowInOrder) {
  // The window's edits (app/session/selection_controller.h): the union is made on a worker, so
  // the frame that makes it shows the handles as they were; the undo that came in the same frame
  // waits behind it (made at once, it would take back the kidney's handle and the union would
  // then land on top of it). Once in: the handles, their history and the mask the frames uploaded
  // are those of the same actions made in the frame that makes them: the union undone.
  const EditedSession now = editSession(false);
  const EditedSession later = editSession(true);
  EXPECT_FALSE(now.editingAfterItsFrame);
  EXPECT_EQ(now.handlesAfterItsFrame, 2u);  // the union made and undone
  EXPECT_TRUE(later.editingAfterItsFrame);
  EXPECT_EQ(later.handlesAfterItsFrame, 2u);
  ASSERT_EQ(now.handles.size(), 2u);
  ASSERT_EQ(later.handles.size(), now.handles.size());
  std::vector<std::uint8_t> painted(now.uploaded.size(), 0);
  for (std::size_t i = 0; i < now.handles.size(); ++i) {
    EXPECT_EQ(later.handles[i].id, now.handles[i].id);
    EXPECT_EQ(later.handles[i].voxels, now.handles[i].voxels);
    for (std::uint32_t v : now.handles[i].voxels) painted[v] = std::uint8_t(now.handles[i].id);
  }
  EXPECT_TRUE(now.canRedo);
  EXPECT_EQ(later.canUndo, now.canUndo);
  EXPECT_EQ(later.canRedo, now.canRedo);
  EXPECT_EQ(now.uploaded, painted);
  EXPECT_EQ(later.uploaded, painted);
}

TEST(FrameDriver, AnEditRefusedInTheBackgroundOrBehindOneSaysSoInThePanel) {
  // A union of a handle with itself is refused at once, with the note; a delete of a handle that
  // does not exist, waiting behind a union in the background, is accepted when it comes and its
  // refusal shows once it is made.
  LabelledScene l(true);
  const SelectionController& sel = l.sel;
  EXPECT_EQ(l.frame({{uiEvent(0.1, UiAction::HandleUnion, "1,1"), 0.1}}).refused.size(), 1u);
  EXPECT_NE(sel.correctionNote().find("Union refused"), std::string::npos) << sel.correctionNote();
  // Both accepted: the delete waits.
  EXPECT_TRUE(l.frame({{uiEvent(0.2, UiAction::HandleUnion, "1,2"), 0.2}, {uiEvent(0.2, UiAction::HandleDelete, "7"), 0.2}}).refused.empty());
  l.untilEditsAreIn();
  EXPECT_EQ(sel.handles().handles().size(), 1u);
  EXPECT_EQ(sel.correctionNote(), "handle-delete 7 was refused");
}

TEST(FrameDriver, AGrabOfAHandleWaitsForAnEditInTheBackground) {
  // A grab answered while a union is being made in the background would put its undo step before
  // the union's: it is refused with a note and the handle stays; once the union is in, the same
  // grab anchors and a drag moves the handle. The grab's pick is answered by hand (the recording
  // renderer draws nothing): handle 1 under the finger.
  LabelledScene l(true);
  const SelectionController& sel = l.sel;
  l.frame({{uiEvent(0.1, UiAction::SetMode, "manipulate"), 0.1}});
  auto grabAndDrag = [&](double t, std::vector<FrameInput::Event> first) {
    first.push_back({touchEvent(t, TouchPhase::Down, 1, {32.0, 24.0}), t});
    FrameResult picked;
    picked.frame = l.frame(std::move(first)).frame;
    gpu::PickResult hit{};
    hit.world = glm::vec4(0.0f, 0.0f, 0.0f, 1.0f);
    hit.voxel = glm::ivec4(0, 0, 0, 1);
    picked.picks.push_back(hit);
    l.s.driver->completed(picked);
    l.frame({{touchEvent(t + 0.05, TouchPhase::Move, 1, {40.0, 24.0}), t + 0.05}});
    l.frame({{touchEvent(t + 0.1, TouchPhase::Up, 1, {40.0, 24.0}), t + 0.1}});
  };
  grabAndDrag(0.2, {{uiEvent(0.2, UiAction::HandleUnion, "1,2"), 0.2}});  // the union, then the finger, in one frame
  EXPECT_NE(sel.manipulationNote().find("being edited"), std::string::npos) << sel.manipulationNote();
  l.untilEditsAreIn();
  ASSERT_EQ(sel.handles().handles().size(), 1u);
  EXPECT_TRUE(sel.handles().handles()[0].pose.isIdentity());
  grabAndDrag(1.0, {});
  EXPECT_EQ(sel.manipulationNote().find("being edited"), std::string::npos) << sel.manipulationNote();
  EXPECT_FALSE(sel.handles().handles()[0].pose.isIdentity());
}
