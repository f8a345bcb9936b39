// The session's framing of the clip: "frame-clip" moves the camera over Session::kFramingSeconds
// on the events' clock to the view that shows the clipped part of the volume, a touch stops it,
// "camera-back" returns.
#include <gtest/gtest.h>

#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>

#include "app/session/session.h"
#include "sim/phantom.h"
#include "tests/app/run_handson.h"

using namespace handson;

namespace {

VolumeGeometry grid() {
  VolumeGeometry g;
  g.dims = {128, 128, 64};
  g.spacing = {1.5, 1.5, 3.0};
  g.origin = {-96, -96, -96};
  return g;
}

bool same(const OrbitCamera& a, const OrbitCamera& b) {
  return a.target == b.target && a.distance == b.distance && a.azimuth == b.azimuth && a.elevation == b.elevation && a.roll == b.roll;
}

}  // namespace

TEST(SessionFraming, FrameClipMovesTheCameraToTheClippedRegionAndBack) {
  const VolumeGeometry g = grid();
  const Viewport vp{640, 400};
  Session s(g, vp, "ct-abdomen");
  const OrbitCamera start = s.camera();
  EXPECT_FALSE(s.apply(uiEvent(0.5, UiAction::FrameClip))) << "nothing clipped: nothing to frame";
  EXPECT_FALSE(s.apply(uiEvent(0.5, UiAction::CameraBack))) << "no framing to go back from";
  ASSERT_TRUE(s.apply(uiEvent(1.0, UiAction::SetClipBox, "10,-30,-40,40,0,-10")));
  ASSERT_TRUE(s.apply(uiEvent(1.0, UiAction::FrameClip)));
  const OrbitCamera want = *frameClip(start, g, s.clip(), FramingView{vp.width, vp.height});
  s.advance(1.0);
  EXPECT_TRUE(same(s.camera(), start)) << "the move starts where the camera was";
  s.advance(1.0 + 0.5 * Session::kFramingSeconds);
  EXPECT_FALSE(same(s.camera(), start));
  EXPECT_FALSE(same(s.camera(), want));
  EXPECT_TRUE(s.cameraMoving());
  s.advance(1.0 + Session::kFramingSeconds);
  EXPECT_TRUE(same(s.camera(), want)) << describeCamera(s.camera()) << "\n" << describeCamera(want);
  EXPECT_FALSE(s.cameraMoving());
  // The box fills at least 60 % of the view's shorter side, seen from the same direction.
  const auto b = projectedPointsBox(s.camera(), clippedVolumeCorners(g, clipHalfSpaces(s.clip())), vp.width, vp.height);
  ASSERT_TRUE(b.has_value());
  EXPECT_GE(std::max((*b)[2] - (*b)[0], (*b)[3] - (*b)[1]), 0.6 * vp.height);
  EXPECT_EQ(s.camera().azimuth, start.azimuth);
  // One gesture back: the camera before the framing, moved to the same way.
  ASSERT_TRUE(s.canGoBack());
  ASSERT_TRUE(s.apply(uiEvent(3.0, UiAction::CameraBack)));
  EXPECT_FALSE(s.canGoBack());
  s.advance(3.0 + Session::kFramingSeconds);
  EXPECT_TRUE(same(s.camera(), start));
}

TEST(SessionFraming, AFingerStopsTheMoveWhereItIsAndAClipThatLeavesNothingIsNotFramed) {
  // The finger stops the move where it is at the finger's time, whatever frames came before: the
  // camera then is the move's at that time, live and in a replay alike.
  const VolumeGeometry g = grid();
  Session s(g, Viewport{400, 400}, "ct-abdomen");
  const OrbitCamera start = s.camera();
  ASSERT_TRUE(s.apply(uiEvent(0.0, UiAction::SetClipPlane, "1,0,0,20")));
  ASSERT_TRUE(s.apply(uiEvent(0.0, UiAction::FrameClip)));
  const CameraMove move{start, *frameClip(start, g, s.clip(), FramingView{400, 400}), 0.0, Session::kFramingSeconds};
  s.advance(0.1);
  EXPECT_TRUE(same(s.camera(), move.at(0.1)));
  ASSERT_TRUE(s.apply(touchEvent(0.12, TouchPhase::Down, 1, {200, 200})));
  EXPECT_FALSE(s.cameraMoving());
  EXPECT_TRUE(same(s.camera(), move.at(0.12))) << "stopped at the finger's time, not the last frame's";
  s.advance(1.0);
  EXPECT_TRUE(same(s.camera(), move.at(0.12))) << "the finger's gesture acts on the camera shown";
  ASSERT_TRUE(s.apply(touchEvent(0.2, TouchPhase::Up, 1, {200, 200})));
  // A framing and a finger within one frame (no advance between): the camera still moved.
  ASSERT_TRUE(s.apply(uiEvent(1.0, UiAction::CameraBack)));
  ASSERT_TRUE(s.apply(touchEvent(1.1, TouchPhase::Down, 2, {200, 200})));
  EXPECT_FALSE(same(s.camera(), move.at(0.12)));
  EXPECT_FALSE(same(s.camera(), start));
  ASSERT_TRUE(s.apply(touchEvent(1.2, TouchPhase::Up, 2, {200, 200})));
  // A plane past the volume's end leaves nothing, one through its corner a point: both refused,
  // the camera unchanged.
  for (const char* plane : {"1,0,0,5000", "1,1,1,285"}) {
    ASSERT_TRUE(s.apply(uiEvent(2.0, UiAction::SetClipPlane, plane)));
    EXPECT_FALSE(s.apply(uiEvent(2.0, UiAction::FrameClip))) << plane;
    EXPECT_FALSE(s.cameraMoving());
  }
}

TEST(SessionFraming, AClipDragThatChangesTheClipAsksToBeFramedOnceItEnds) {
  // The window frames the clip when a Clip-mode drag that changed it ends (a recorded action).
  const VolumeGeometry g = grid();
  const Viewport vp{400, 400};
  Session s(g, vp, "ct-abdomen");
  ASSERT_TRUE(s.apply(uiEvent(0.0, UiAction::SetMode, "clip")));
  ASSERT_TRUE(s.apply(uiEvent(0.0, UiAction::SetClipBox, "-60,-60,-60,60,60,60")));
  // Drag from the middle of a face of the box as seen (the nearest face handle is under the finger).
  std::optional<glm::dvec2> handle;
  for (int axis = 0; axis < 3 && !handle; ++axis)
    for (bool high : {false, true}) {
      const BoxFace f{axis, high};
      const auto px = projectToPixel(s.camera(), vp, faceCentre(glm::dvec3(-60), glm::dvec3(60), f));
      if (!px) continue;
      const auto grabbed = boxFaceNear(glm::dvec3(-60), glm::dvec3(60), s.camera(), vp, *px);
      if (grabbed && grabbed->axis == axis && grabbed->high == high) {
        handle = px;
        break;
      }
    }
  ASSERT_TRUE(handle.has_value());
  ASSERT_TRUE(s.apply(touchEvent(1.0, TouchPhase::Down, 7, *handle)));
  EXPECT_FALSE(s.takeClipSettled());
  ASSERT_TRUE(s.apply(touchEvent(1.1, TouchPhase::Move, 7, *handle + glm::dvec2(30, 20))));
  EXPECT_FALSE(s.takeClipSettled()) << "not while the finger is down";
  ASSERT_TRUE(s.apply(touchEvent(1.2, TouchPhase::Up, 7, *handle + glm::dvec2(30, 20))));
  EXPECT_TRUE(s.takeClipSettled());
  EXPECT_FALSE(s.takeClipSettled()) << "once";
  // A tap that changes nothing asks for nothing.
  ASSERT_TRUE(s.apply(touchEvent(2.0, TouchPhase::Down, 8, *handle)));
  ASSERT_TRUE(s.apply(touchEvent(2.1, TouchPhase::Up, 8, *handle)));
  EXPECT_FALSE(s.takeClipSettled());
}

TEST(SessionFraming, AReplayedFramingMovesTheCameraAsRecordedAndTheAutomaticWindowFitsTheClippedTissue) {
  // `handson replay` of a clip box around the phantom's right kidney, framed and its window fitted:
  // the camera ends where frameClip puts it (the script's viewport, the whole of it free), the
  // window is ct-abdomen's fitted to the box's soft tissue, and "camera-back" returns to the
  // script's camera. "auto-window" where the clip leaves no soft tissue (a box in the air in front
  // of the body) is refused.
  namespace fs = std::filesystem;
  const fs::path dir = fs::temp_directory_path() / ("handson_framing_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  const std::string head = R"({"format": "handson-session", "version": 1, "volume": {"source": "phantom"}, "viewport": [512, 384],
    "preset": "ct-abdomen", "mode": "navigate",
    "camera": {"target": [0, 0, 0], "distance": 900, "azimuth_deg": 90, "elevation_deg": 0, "roll_deg": 0, "fov_deg": 35}, "events": [
      {"t": 0.1, "ui": "set-clip-box", "value": "-40,-120,-100,40,-30,0"}, {"t": 0.1, "ui": "frame-clip"}, {"t": 0.1, "ui": "auto-window"})";
  std::ofstream(dir / "framed.json") << head << "]}";
  std::ofstream(dir / "back.json") << head << R"(, {"t": 0.6, "ui": "camera-back"},
      {"t": 0.7, "ui": "set-clip-box", "value": "-40,-400,-100,40,-390,0"}, {"t": 0.7, "ui": "auto-window"}]})";
  const std::string replay = " --fps 10 --size 64x48 --sim off --print-handles --print-camera";
  const auto framed = handson::test::runHandson("replay " + (dir / "framed.json").string() + replay + " --quiet");
  ASSERT_EQ(framed.status, 0) << framed.output;
  EXPECT_FALSE(framed.has("refused")) << framed.output;
  EXPECT_TRUE(framed.has("window ct-abdomen scale ")) << framed.output;
  // The expected camera: the script's, framed onto the box.
  OrbitCamera start;
  start.distance = 900.0;
  start.azimuth = glm::radians(90.0);
  ClipRegion clip;
  ASSERT_EQ(parseClipBox("-40,-120,-100,40,-30,0", clip), "");
  const OrbitCamera want = *frameClip(start, handson::makePhantom().ct.geometry(), clip, FramingView{512, 384});
  double distance = 0.0;
  const auto at = framed.output.find("distance=");
  ASSERT_NE(at, std::string::npos) << framed.output;
  ASSERT_EQ(std::sscanf(framed.output.c_str() + at, "distance=%lf", &distance), 1);
  EXPECT_NEAR(distance, want.distance, 1e-6 * want.distance) << framed.output;
  EXPECT_LT(distance, 600.0);
  const auto back = handson::test::runHandson("replay " + (dir / "back.json").string() + replay);
  ASSERT_EQ(back.status, 0) << back.output;
  EXPECT_TRUE(back.has("refused at t=0.7 s: auto-window")) << back.output;
  EXPECT_TRUE(back.has("distance=900 ")) << back.output;
  fs::remove_all(dir);
}

TEST(SessionFraming, AnAutomaticWindowFollowsTheRegionUntilTheWindowIsSetByHand) {
  Session s(grid(), Viewport{400, 400}, "ct-abdomen");
  EXPECT_TRUE(s.windowFollowsRegion()) << "the preset's own window";
  s.setAutomaticWindow(WindowLevel{0.8, -60.0, 1.0});
  EXPECT_TRUE(s.takePresetChanged());
  EXPECT_TRUE(s.windowFollowsRegion());
  ASSERT_TRUE(s.apply(uiEvent(0.0, UiAction::SetWindow, "1.2,10,1")));
  EXPECT_FALSE(s.windowFollowsRegion()) << "set by hand";
  ASSERT_TRUE(s.apply(uiEvent(0.1, UiAction::ResetWindow)));
  EXPECT_TRUE(s.windowFollowsRegion());
  s.setAutomaticWindow(WindowLevel{0.8, -60.0, 1.0});
  ASSERT_TRUE(s.apply(uiEvent(0.2, UiAction::SetPreset, "ct-soft-tissue")));
  EXPECT_TRUE(s.window().identity()) << "a new preset starts from its own window";
}
