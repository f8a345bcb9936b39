// The app in a real window, run under xvfb-run by ctest. Xvfb has no touch device
// (SDL_GetNumTouchDevices() is 0 there), so multi-touch is injected with SDL_PushEvent as SDL's
// own finger events, and a one-finger drag comes from xdotool's mouse with SDL_MOUSE_TOUCH_EVENTS=1.
#include <gtest/gtest.h>

#include <SDL2/SDL.h>
#include <sys/wait.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <tuple>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "app/io/png_io.h"
#include "app/platform/viewer.h"
#include "app/session/session.h"
#include "app/session/session_recovery.h"
#include "app/session/session_script.h"
#include "interaction/camera.h"
#include "sim/base/error.h"
#include "sim/phantom.h"

using namespace handson;
namespace fs = std::filesystem;

namespace {

constexpr SDL_TouchID kTouch = 77;

void pushFinger(Uint32 type, SDL_FingerID id, float x, float y) {
  SDL_Event e{};
  e.type = type;
  e.tfinger.touchId = kTouch;
  e.tfinger.fingerId = id;
  e.tfinger.x = x;
  e.tfinger.y = y;
  e.tfinger.pressure = 1.0f;
  ASSERT_EQ(SDL_PushEvent(&e), 1) << SDL_GetError();
}

ViewerOptions smallWindow() {
  ViewerOptions o;
  o.width = 640;
  o.height = 480;
  o.quiet = true;
  o.validation = true;
  o.sim.refineSteps = 0;  // the tests' held poses not refined (the window's default: 2)
  return o;
}

class Window : public ::testing::Test {
 protected:
  void SetUp() override {
    if (!displayAvailable()) GTEST_SKIP() << "no display: run under xvfb-run (ctest does)";
  }
};

}  // namespace

TEST_F(Window, InjectedTwoFingerPinchZoomsAndTwistRolls) {
  Viewer v(smallWindow());
  ASSERT_TRUE(v.step());
  const OrbitCamera start = v.session().camera();
  // Pinch open: fingers 0.2 apart -> 0.4 apart, about the window centre.
  pushFinger(SDL_FINGERDOWN, 1, 0.4f, 0.5f);
  pushFinger(SDL_FINGERDOWN, 2, 0.6f, 0.5f);
  ASSERT_TRUE(v.step());
  pushFinger(SDL_FINGERMOTION, 1, 0.3f, 0.5f);
  pushFinger(SDL_FINGERMOTION, 2, 0.7f, 0.5f);
  ASSERT_TRUE(v.step());
  const OrbitCamera zoomed = v.session().camera();
  EXPECT_NEAR(zoomed.distance, start.distance / 2.0, start.distance * 1e-3);
  EXPECT_NEAR(zoomed.roll, start.roll, 1e-6);
  // Twist: rotate the pair by 30 degrees clockwise on screen (pixels, so the aspect matters).
  const double a = glm::radians(30.0), r = 0.2 * 640;
  const float x1 = float((320 - r * std::cos(a)) / 640), y1 = float((240 - r * std::sin(a)) / 480);
  const float x2 = float((320 + r * std::cos(a)) / 640), y2 = float((240 + r * std::sin(a)) / 480);
  pushFinger(SDL_FINGERMOTION, 1, x1, y1);
  pushFinger(SDL_FINGERMOTION, 2, x2, y2);
  ASSERT_TRUE(v.step());
  EXPECT_NEAR(v.session().camera().roll, start.roll - a, 1e-3);
  EXPECT_NEAR(v.session().camera().distance, zoomed.distance, zoomed.distance * 1e-3);
  pushFinger(SDL_FINGERUP, 1, x1, y1);
  pushFinger(SDL_FINGERUP, 2, x2, y2);
  // Hostile input through the real event path: an up without a down, NaN, far outside.
  pushFinger(SDL_FINGERUP, 9, 0.5f, 0.5f);
  pushFinger(SDL_FINGERDOWN, 10, std::nanf(""), 0.5f);
  pushFinger(SDL_FINGERDOWN, 11, 50.0f, -30.0f);
  pushFinger(SDL_FINGERUP, 11, 50.0f, -30.0f);
  ASSERT_TRUE(v.step());
  EXPECT_TRUE(v.session().gestures().input().fingers().empty());
  EXPECT_TRUE(std::isfinite(v.session().camera().distance));
  EXPECT_EQ(v.finish(), 0);  // zero validation messages
}

TEST_F(Window, TouchesOnTheUiDoNotMoveTheCamera) {
  Viewer v(smallWindow());
  ASSERT_TRUE(v.step());
  const double az = v.session().camera().azimuth;
  // The mode bar is at the top left.
  pushFinger(SDL_FINGERDOWN, 1, 0.05f, 0.05f);
  ASSERT_TRUE(v.step());
  pushFinger(SDL_FINGERMOTION, 1, 0.3f, 0.3f);
  pushFinger(SDL_FINGERUP, 1, 0.3f, 0.3f);
  ASSERT_TRUE(v.step());
  EXPECT_EQ(v.session().camera().azimuth, az);
  EXPECT_EQ(v.finish(), 0);
}

TEST_F(Window, ScreenshotOfTheWindowIsNotEmpty) {
  const fs::path shot = fs::temp_directory_path() / ("handson_shot_" + std::to_string(getpid()) + ".png");
  ViewerOptions o = smallWindow();
  o.frames = 3;
  o.screenshot = shot.string();
  Viewer v(o);
  while (v.step()) {
  }
  EXPECT_EQ(v.finish(), 0);
  int w = 0, h = 0;
  const auto px = readPng(shot.string(), w, h);
  EXPECT_EQ(w, 640);
  EXPECT_EQ(h, 480);
  // The phantom (reddish) and the UI (blue buttons) are both there.
  std::size_t red = 0, blue = 0;
  for (std::size_t i = 0; i < px.size(); i += 4) {
    red += px[i] > 100 && px[i] > px[i + 2] + 30;
    blue += px[i + 2] > 150 && px[i + 2] > px[i] + 60;
  }
  EXPECT_GT(red, 500u);
  EXPECT_GT(blue, 500u);
  fs::remove(shot);
}

TEST_F(Window, TheDefaultViewFramesTheVolumeInTheAreaThePanelsLeaveFree) {
  // At two window sizes: the volume's box on screen (its 8 corners projected by the session's camera)
  // meets no panel (the frame-time overlay included) and lies inside the window, filling the free
  // area, and the screenshot agrees: every pixel of the phantom's colour outside the panels lies
  // inside that box (2 px of rasterization slack).
  for (const auto& [w, h] : {std::pair{1200, 760}, std::pair{800, 600}}) {
    SCOPED_TRACE(std::to_string(w) + "x" + std::to_string(h));
    const fs::path shot = fs::temp_directory_path() / ("handson_frame_" + std::to_string(getpid()) + ".png");
    ViewerOptions o = smallWindow();
    o.width = w;
    o.height = h;
    o.frames = 4;
    o.screenshot = shot.string();
    Viewer v(o);
    while (v.step()) {
    }
    const Viewport vp = v.drawableSize();
    const auto panels = v.uiPanels();
    const VolumeGeometry g = makePhantom().ct.geometry();
    const auto box = projectedVolumeBox(v.session().camera(), g, vp.width, vp.height);
    ASSERT_TRUE(box.has_value());
    const auto& b = *box;
    EXPECT_GE(b[0], 0.0);
    EXPECT_GE(b[1], 0.0);
    EXPECT_LE(b[2], vp.width);
    EXPECT_LE(b[3], vp.height);
    ASSERT_GE(panels.size(), 3u);
    for (const auto& p : panels) EXPECT_FALSE(b[0] < p[2] && b[2] > p[0] && b[1] < p[3] && b[3] > p[1]) << p[0] << "," << p[1] << "," << p[2] << "," << p[3];
    // It fills the free area (92 % in its tighter dimension: OrbitCamera::framingIn), which the
    // session records for replays.
    const ScreenArea f = v.session().freeArea();
    ASSERT_FALSE(f.whole());
    const double fill = std::max((b[2] - b[0]) / ((f.x1 - f.x0) * vp.width), (b[3] - b[1]) / ((f.y1 - f.y0) * vp.height));
    EXPECT_NEAR(fill, 0.92, 0.01);
    EXPECT_EQ(f, v.session().script().freeArea.value_or(ScreenArea{}));
    EXPECT_EQ(v.finish(), 0);
    int sw = 0, sh = 0;
    const auto px = readPng(shot.string(), sw, sh);
    ASSERT_EQ(sw, vp.width);
    std::size_t inside = 0, outside = 0;
    for (int y = 0; y < sh; ++y)
      for (int x = 0; x < sw; ++x) {
        const std::size_t i = 4 * (std::size_t(y) * std::size_t(sw) + std::size_t(x));
        if (!(px[i] > 100 && px[i] > px[i + 2] + 30)) continue;  // the phantom's reds
        bool onPanel = false;
        for (const auto& p : panels) onPanel |= x >= p[0] && x <= p[2] && y >= p[1] && y <= p[3];
        if (onPanel) continue;
        const bool in = x >= b[0] - 2 && x <= b[2] + 2 && y >= b[1] - 2 && y <= b[3] + 2;
        (in ? inside : outside) += 1;
      }
    EXPECT_GT(inside, 2000u);
    EXPECT_EQ(outside, 0u);
    fs::remove(shot);
  }
}

TEST_F(Window, XdotoolMouseDragArrivesAsOneFingerAndOrbits) {
  if (std::system("command -v xdotool > /dev/null") != 0) GTEST_SKIP() << "xdotool is not installed";
  const fs::path dir = fs::temp_directory_path() / ("handson_xdo_" + std::to_string(getpid()));
  fs::create_directories(dir);
  const std::string script = (dir / "drag.sh").string();
  std::ofstream(script) << "#!/bin/sh\n"
                        << "SDL_MOUSE_TOUCH_EVENTS=1 " << HANDSON_EXE
                        << " view --size 800x600 --frames 2000 --quiet --print-camera --validation --record " << (dir / "rec.json").string()
                        << " > " << (dir / "out.txt").string() << " 2>&1 &\n"
                        << "APP=$!\n"
                        << "W=$(timeout 60 xdotool search --sync --name '^Handson$' | head -1)\n"
                        << "sleep 1\n"
                        << "xdotool mousemove --window $W 250 350 mousedown 1\n"
                        << "for x in 270 290 310 330 350 370 390 410; do xdotool mousemove --window $W $x 350; sleep 0.1; done\n"
                        << "xdotool mouseup 1\nsleep 0.5\nxdotool key --window $W Escape\nwait $APP\n";
  ASSERT_EQ(std::system(("sh " + script).c_str()), 0);
  std::ifstream in(dir / "out.txt");
  const std::string out((std::istreambuf_iterator<char>(in)), {});
  const auto pos = out.find("camera azimuth_deg=");
  ASSERT_NE(pos, std::string::npos) << out;
  const double az = std::stod(out.substr(pos + 19));
  // 160 px of drag in a 600 px high window: 160 / 600 * 180 = 48 degrees more than the default 25.
  EXPECT_NEAR(az, 25.0 + 48.0, 1.0) << out;
  EXPECT_EQ(out.find("validation"), std::string::npos) << out;
  fs::remove_all(dir);
}

TEST_F(Window, ResizingRecreatesTheSwapchainAndKeepsRendering) {
  const fs::path shot = fs::temp_directory_path() / ("handson_resize_" + std::to_string(getpid()) + ".png");
  ViewerOptions o = smallWindow();
  o.frames = 6;
  o.screenshot = shot.string();
  Viewer v(o);
  ASSERT_TRUE(v.step());
  SDL_SetWindowSize(v.window(), 400, 300);
  while (v.step()) {
  }
  EXPECT_EQ(v.finish(), 0);
  int w = 0, h = 0;
  readPng(shot.string(), w, h);
  EXPECT_EQ(w, 400);
  EXPECT_EQ(h, 300);
  EXPECT_EQ(v.session().gestures().viewport().width, 400);
  fs::remove(shot);
}

TEST_F(Window, TheExportButtonsActionWritesTheSessionTheVolumeAndAScreenshot) {
  // The Export button applies {"ui": "export"} through the session (recorded, replayable); played
  // here from a script: the session so far, the volume as shown (nothing simulated: the input) and
  // the rendered image land in the export directory once that frame has finished.
  const fs::path dir = fs::temp_directory_path() / ("handson_uiexport_" + std::to_string(getpid()));
  fs::create_directories(dir);
  std::ofstream(dir / "export.json") << R"({"format": "handson-session", "version": 1, "viewport": [640, 480],
    "events": [{"t": 0.0, "ui": "set-preset", "value": "ct-bone"}, {"t": 0.01, "ui": "export"}]})";
  ViewerOptions o = smallWindow();
  o.play = (dir / "export.json").string();
  o.frames = 8;
  o.exportDir = (dir / "out").string();
  Viewer v(o);
  while (v.step()) {
  }
  EXPECT_EQ(v.finish(), 0);
  for (const char* f : {"session-01.json", "deformed-01.nii.gz", "screenshot-01.png"}) EXPECT_TRUE(fs::exists(dir / "out" / f)) << f;
  EXPECT_FALSE(fs::exists(dir / "out" / "mesh-01.vtu")) << "nothing simulated: no mesh";
  const SessionScript s = readSessionScript((dir / "out" / "session-01.json").string());
  ASSERT_GE(s.events.size(), 2u);
  EXPECT_EQ(s.events[0].action, UiAction::SetPreset);
  EXPECT_EQ(s.events.back().action, UiAction::Export);
  int w = 0, h = 0;
  EXPECT_FALSE(readPng((dir / "out" / "screenshot-01.png").string(), w, h).empty());
  EXPECT_GT(w, 0);
  fs::remove_all(dir);
}

TEST_F(Window, ALostDeviceEndsTheSessionWithAClearMessageAndItsScriptAndHandlesSaved) {
  // The 40th queue submission (setup and the first frames done) reports VK_ERROR_DEVICE_LOST, as
  // does every later one: step() throws the message, and the session so far is in the export
  // directory, replayable. (HANDSON_FAULT: render/vk_context.h.)
  const fs::path dir = fs::temp_directory_path() / ("handson_uilost_" + std::to_string(getpid()));
  fs::create_directories(dir);
  std::ofstream(dir / "play.json") << R"({"format": "handson-session", "version": 1, "viewport": [640, 480],
    "events": [{"t": 0.0, "ui": "set-preset", "value": "ct-bone"}, {"t": 0.01, "ui": "set-mode", "value": "select"}]})";
  ViewerOptions o = smallWindow();
  o.play = (dir / "play.json").string();
  o.frames = 200;
  o.exportDir = (dir / "out").string();
  setenv("HANDSON_FAULT", "device-lost:40", 1);
  std::string message;
  {
    Viewer v(o);
    unsetenv("HANDSON_FAULT");
    try {
      while (v.step()) {
      }
      ADD_FAILURE() << "the session ran to its end";
    } catch (const Error& e) {
      message = e.what();
    }
  }  // the viewer tears down after the failure without crashing
  unsetenv("HANDSON_FAULT");
  EXPECT_NE(message.find("VK_ERROR_DEVICE_LOST"), std::string::npos) << message;
  EXPECT_NE(message.find("the session so far is saved"), std::string::npos) << message;
  const SessionScript s = readSessionScript((dir / "out" / "recovery-session.json").string());
  ASSERT_GE(s.events.size(), 2u);
  EXPECT_EQ(s.events[0].action, UiAction::SetPreset);
  EXPECT_TRUE(readHandles((dir / "out" / "recovery-handles.json").string()).handles.empty());
  fs::remove_all(dir);
}

TEST_F(Window, TheTimingLogSaysWhetherItMeasuredWhenEachFrameWasShown) {
  // With VK_KHR_present_wait each frame's display time is logged (after its submit); without it
  // (lavapipe under Xvfb) the header says so and displayed_s is -1 throughout, never a guess.
  const fs::path csvPath = fs::temp_directory_path() / ("handson_present_" + std::to_string(getpid()) + ".csv");
  ViewerOptions o = smallWindow();
  o.frames = 6;
  o.timings = csvPath.string();
  Viewer v(o);
  while (v.step()) {
  }
  EXPECT_EQ(v.finish(), 0);
  std::ifstream in(csvPath);
  std::string line, notes;
  while (std::getline(in, line) && line.rfind("# ", 0) == 0) notes += line + "\n";
  EXPECT_NE(notes.find("SDL 2 gives touches no device timestamp"), std::string::npos) << notes;
  const bool measured = notes.find("vkWaitForPresentKHR reported the frame shown") != std::string::npos;
  EXPECT_TRUE(measured || notes.find("display time not measured: this driver offers no VK_KHR_present_wait") != std::string::npos) << notes;
  std::vector<std::string> names;
  for (std::stringstream hs(line); std::getline(hs, line, ',');) names.push_back(line);
  const auto at = [&](const char* n) { return std::size_t(std::find(names.begin(), names.end(), n) - names.begin()); };
  ASSERT_LT(at("displayed_s"), names.size());
  int rows = 0, shown = 0;
  while (std::getline(in, line)) {
    std::vector<double> f;
    for (std::stringstream ls(line); std::getline(ls, line, ',');) f.push_back(std::atof(line.c_str()));
    ASSERT_GT(f.size(), at("displayed_s"));
    ++rows;
    const double displayed = f[at("displayed_s")];
    if (!measured) {
      EXPECT_EQ(displayed, -1.0);
    }
    if (displayed >= 0.0) {
      ++shown;
      EXPECT_GE(displayed, f[at("submit_s")]) << "shown after it was submitted";
    }
  }
  EXPECT_EQ(rows, 6);
  if (measured) {
    EXPECT_GE(shown, 3) << "most frames' display times came back";
  }
  fs::remove(csvPath);
}

TEST_F(Window, ThePanelsLeaveThePictureAtATouchTablesSizeAndInASmallWindow) {
  // The panels (the frame-time overlay included) as first laid out, folded as a new window folds
  // them: at 1280x800 they cover at most 15 % of the window, at 512x512 at most 25 %, and never its
  // centre, where the organ is framed. Measured: 11.7 % and 23.8 % (before the folds: ~35 % and most
  // of the 512 px window).
  for (const auto& [w, h, most] : {std::tuple{1280, 800, 0.15}, std::tuple{512, 512, 0.25}}) {
    SCOPED_TRACE(std::to_string(w) + "x" + std::to_string(h));
    ViewerOptions o = smallWindow();
    o.width = w;
    o.height = h;
    o.frames = 3;
    Viewer v(o);
    while (v.step()) {
    }
    const Viewport vp = v.drawableSize();
    const auto panels = v.uiPanels();
    ASSERT_GE(panels.size(), 3u) << "the mode bar, the presets and handles, the overlay";
    std::vector<char> covered(std::size_t(vp.width) * std::size_t(vp.height), 0);
    for (const auto& p : panels)
      for (int y = std::max(0, int(p[1])); y < std::min(vp.height, int(std::ceil(p[3]))); ++y)
        for (int x = std::max(0, int(p[0])); x < std::min(vp.width, int(std::ceil(p[2]))); ++x) covered[std::size_t(y) * std::size_t(vp.width) + std::size_t(x)] = 1;
    const double share = double(std::count(covered.begin(), covered.end(), 1)) / double(covered.size());
    std::printf("%dx%d: the panels cover %.1f %% of the window\n", w, h, 100.0 * share);
    EXPECT_LE(share, most);
    EXPECT_FALSE(covered[std::size_t(vp.height / 2) * std::size_t(vp.width) + std::size_t(vp.width / 2)]) << "the centre";
    EXPECT_EQ(v.finish(), 0);
  }
}

namespace {
struct PlayedHandle {
  std::size_t voxels = 0;
  Eigen::Vector3d t{0, 0, 0};
  double degrees = 0;
};
// The first handle `replay --print-handles` prints for a script (--sim off).
PlayedHandle replayedHandle(const fs::path& script) {
  PlayedHandle h;
  const std::string cmd = std::string(HANDSON_EXE) + " replay " + script.string() + " --fps 10 --size 128x128 --quiet --sim off --print-handles";
  FILE* pipe = popen(cmd.c_str(), "r");
  if (!pipe) return h;
  char line[512];
  while (std::fgets(line, sizeof(line), pipe)) {
    const char* t = std::strstr(line, "translation ");
    if (std::sscanf(line, "handle 1 %*s %zu voxels", &h.voxels) == 1 && t &&
        std::sscanf(t, "translation %lf,%lf,%lf rotation_deg %lf", &h.t.x(), &h.t.y(), &h.t.z(), &h.degrees) == 4)
      break;
  }
  while (std::fgets(line, sizeof(line), pipe)) {
  }
  if (pclose(pipe) != 0) h.voxels = 0;
  return h;
}
}  // namespace

TEST_F(Window, APlayedScriptStartsFromItsCameraAndModeAndLandsOnTheSameAnatomyAtAnySize) {
  // `view --play` starts from the script's camera, mode and preset, and maps its 512x512 viewport to
  // the window about the centres by the heights' ratio (the camera's field of view is vertical), so
  // each of the paper's scenario scripts pinch-selects its organ and moves it as `replay` of the
  // script does, at 1280x800 as at the script's 512x512: the same voxels within 2 %, the translation within
  // 2 mm and the turn within 2 degrees (the frames' timing splits a drag's moves differently).
  // Measured: the same voxel counts, translations within 0.1 mm. Before: the default view, the
  // pinch on other anatomy, no handle. The full session (two handles, union, difference, undo,
  // redo, a reset of the camera, an export) too: its reset frames as at the script's 512x512, not
  // the window's aspect, and the manipulation's fit weighs pixels alike on both axes (at 1280x800
  // the kidney had moved 3.7 mm further in depth).
  // The three-finger turn and the vessel's pinch are in the full session too (measured alone as well:
  // 28.6 degrees; 1,409 voxels moved 27.0 mm, equal to replay's); played here: two scenario scripts
  // and the full session, to keep the window suite short.
  for (const char* name : {"kidney-translate-two-fingers.json", "kidney-rotate-in-plane.json", "full-session.json"}) {
    const bool full = std::string(name) == "full-session.json";
    const fs::path script = fs::path(HANDSON_SOURCE_DIR) / "assets/gestures" / name;
    const PlayedHandle replayed = replayedHandle(script);
    ASSERT_GT(replayed.voxels, 0u) << name << ": replay printed its handle";
    // At the script's own size the mapping is the identity: one script there, all at 1280x800.
    std::vector<std::pair<int, int>> sizes{{1280, 800}};
    if (std::string(name) == "kidney-translate-two-fingers.json") sizes.insert(sizes.begin(), {512, 512});
    for (const auto& [w, h] : sizes) {
      SCOPED_TRACE(std::string(name) + " at " + std::to_string(w) + "x" + std::to_string(h));
      ViewerOptions o = smallWindow();
      o.width = w;
      o.height = h;
      o.play = script.string();
      o.sim.enabled = false;
      o.exportDir = (fs::temp_directory_path() / ("handson_play_" + std::to_string(getpid()))).string();
      Viewer v(o);
      while (v.step()) {
      }
      if (!full) {
        EXPECT_NEAR(v.session().camera().azimuth, M_PI / 2, 1e-6) << "the script's camera (azimuth 90 degrees), kept: the drags move the organ";
        ASSERT_EQ(v.handles().handles().size(), 1u) << "the pinch made one handle";
      } else {
        ASSERT_EQ(v.handles().handles().size(), 2u) << "the kidney and the vessel";
      }
      const Handle& handle = v.handles().handles().front();
      const double degrees = Eigen::AngleAxisd(handle.pose.R).angle() * 180.0 / M_PI;
      std::printf("%s, %dx%d: %zu voxels moved %.1f, %.1f, %.1f mm, turned %.1f degrees (replay: %zu, %.1f, %.1f, %.1f, %.1f)\n", name, w, h,
                  handle.voxels.size(), handle.pose.t.x(), handle.pose.t.y(), handle.pose.t.z(), degrees, replayed.voxels, replayed.t.x(),
                  replayed.t.y(), replayed.t.z(), replayed.degrees);
      EXPECT_NEAR(double(handle.voxels.size()), double(replayed.voxels), 0.02 * double(replayed.voxels));
      EXPECT_LT((handle.pose.t - replayed.t).norm(), 2.0);
      EXPECT_NEAR(degrees, replayed.degrees, 2.0);
      EXPECT_EQ(v.finish(), 0);
      fs::remove_all(o.exportDir);
    }
  }
}

namespace {
// Each timing-log row's input count and sim_state.
std::vector<std::pair<int, std::string>> inputAndSimState(const fs::path& csv) {
  std::ifstream in(csv);
  std::string line;
  std::vector<std::string> names;
  std::vector<std::pair<int, std::string>> rows;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    std::vector<std::string> cells;
    std::stringstream s(line);
    for (std::string c; std::getline(s, c, ',');) cells.push_back(c);
    if (names.empty()) {
      names = cells;
      continue;
    }
    const auto col = [&](const char* n) { return std::size_t(std::find(names.begin(), names.end(), n) - names.begin()); };
    if (col("input_count") < cells.size() && col("sim_state") < cells.size()) rows.emplace_back(std::stoi(cells[col("input_count")]), cells[col("sim_state")]);
  }
  return rows;
}
}  // namespace

TEST_F(Window, APlayedDragWaitsForTheSimulationToBuildAndMovesTheTissue) {
  // The kidney script pinches at 0-0.6 s, makes the handle active at 0.8 and drags from 1.0 s; the
  // model builds after the handle becomes active, and the drag (40 mm: past half the padding) makes
  // it rebuild around the moved kidney. With the script's clock stopped while the simulation builds
  // (until the first frame drawn with the model), the drag's input frames meet a model, and the
  // played pose is replay's. Before: every drag frame had sim_state "building" and the tissue did
  // not deform while the organ moved; with this test's model and the clock running regardless
  // (--play-wait off), 7 of the drag's 14 input frames were. A small model (3,000 coarse, 81,000
  // fine tets) keeps the builds short (under a second each).
  const fs::path script = fs::path(HANDSON_SOURCE_DIR) / "assets/gestures/kidney-translate-two-fingers.json";
  const PlayedHandle replayed = replayedHandle(script);
  ASSERT_GT(replayed.voxels, 0u);
  const fs::path log = fs::temp_directory_path() / ("handson_played_drag_" + std::to_string(getpid()) + ".csv");
  ViewerOptions o = smallWindow();
  o.width = o.height = 512;
  o.play = script.string();
  o.timings = log.string();
  o.sim.sim.coarseTets = 3000;
  o.sim.sim.fineTets = 81000;
  o.sim.refineSteps = 0;
  o.exportDir = (fs::temp_directory_path() / ("handson_played_drag_" + std::to_string(getpid()))).string();
  {
    Viewer v(o);
    while (v.step()) {
    }
    ASSERT_EQ(v.handles().handles().size(), 1u);
    const Handle& handle = v.handles().handles().front();
    EXPECT_NEAR(double(handle.voxels.size()), double(replayed.voxels), 0.02 * double(replayed.voxels));
    EXPECT_LT((handle.pose.t - replayed.t).norm(), 2.0) << "the played drag ends where replay's does";
    EXPECT_EQ(v.finish(), 0);
  }
  int withModel = 0, building = 0;
  for (const auto& [inputs, state] : inputAndSimState(log))
    if (inputs > 0 && state != "off" && state != "") (state == "building" ? building : withModel) += 1;
  std::printf("drag input frames: %d with the model, %d while it (re)built\n", withModel, building);
  EXPECT_GE(withModel, 3) << "the drag met the model";
  // A frame whose own events start a build logs "building" (the pinch's last frame, which makes
  // the handle, and the move that takes the kidney out of the region); the next ones wait.
  EXPECT_LE(building, 2);
  fs::remove(log);
  fs::remove_all(o.exportDir);
}

TEST_F(Window, NoPanelCoversAnotherWithTheStrainBarAndTheLimitHighlightShown) {
  // The strain overlay's colour bar and the frame-time overlay share the bottom left corner: the
  // overlay sits above the bar. Before, the bar was drawn over the overlay's last lines (seen in
  // a screenshot at 1000x620: the two texts on top of each other).
  for (const auto& [w, h] : {std::pair{1280, 800}, std::pair{1000, 620}, std::pair{512, 512}}) {
    SCOPED_TRACE(std::to_string(w) + "x" + std::to_string(h));
    ViewerOptions o = smallWindow();
    o.width = w;
    o.height = h;
    o.frames = 3;
    o.sim.enabled = false;
    Viewer v(o);
    v.session().apply(uiEvent(0.0, UiAction::ToggleStrain, ""));
    v.session().apply(uiEvent(0.0, UiAction::ToggleLimits, ""));
    while (v.step()) {
    }
    const auto panels = v.uiPanels();
    ASSERT_GE(panels.size(), 4u) << "the mode bar, the colour bar, the presets and handles, the overlay";
    for (std::size_t a = 0; a < panels.size(); ++a)
      for (std::size_t b = a + 1; b < panels.size(); ++b) {
        const double dx = std::min(panels[a][2], panels[b][2]) - std::max(panels[a][0], panels[b][0]);
        const double dy = std::min(panels[a][3], panels[b][3]) - std::max(panels[a][1], panels[b][1]);
        EXPECT_FALSE(dx > 0.5 && dy > 0.5) << "panels " << a << " and " << b << " overlap by " << dx << " x " << dy << " px";
      }
    EXPECT_EQ(v.finish(), 0);
  }
}
