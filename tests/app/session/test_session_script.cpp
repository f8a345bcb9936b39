#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>

#include "app/session/latency_log.h"
#include "app/session/replay.h"
#include "app/session/session.h"
#include "app/session/session_script.h"
#include "sim/base/error.h"

using namespace handson;

namespace {
const char* kGood = R"({
  "format": "handson-session", "version": 1,
  "volume": {"source": "file", "path": "ct.nii.gz"},
  "viewport": [640, 480], "preset": "ct-bone", "mode": "navigate",
  "camera": {"target": [1, 2, 3], "distance": 300, "azimuth_deg": 10, "elevation_deg": 5, "roll_deg": 2, "fov_deg": 40},
  "events": [
    {"t": 0.0, "touch": "down", "id": 4, "x": 10, "y": 20, "pressure": 0.5},
    {"t": 0.1, "touch": "move", "id": 4, "x": 11.5, "y": 20},
    {"t": 0.1, "ui": "set-mode", "value": "select"},
    {"t": 0.2, "touch": "up", "id": 4, "x": 11.5, "y": 20},
    {"t": 0.3, "ui": "reset-camera"}
  ]
})";
}  // namespace

TEST(SessionScript, ParsesFormatsAndRoundTrips) {
  const SessionScript s = parseSessionScript(kGood);
  EXPECT_EQ(s.volumeSource, "file");
  EXPECT_EQ(s.volumePath, "ct.nii.gz");
  EXPECT_EQ(s.viewport.width, 640);
  EXPECT_EQ(s.preset, "ct-bone");
  ASSERT_TRUE(s.camera.has_value());
  EXPECT_EQ(s.camera->target, glm::dvec3(1, 2, 3));
  ASSERT_EQ(s.events.size(), 5u);
  EXPECT_EQ(s.events[0].touch.phase, TouchPhase::Down);
  EXPECT_EQ(s.events[0].touch.pressure, 0.5);
  EXPECT_EQ(s.events[1].touch.px, glm::dvec2(11.5, 20));
  EXPECT_FALSE(s.events[2].isTouch);
  EXPECT_EQ(s.events[2].value, "select");
  EXPECT_DOUBLE_EQ(s.duration(), 0.3);
  EXPECT_FALSE(s.freeArea.has_value());
  SessionScript withArea = s;
  withArea.freeArea = ScreenArea{0.01, 0.2, 0.66, 0.9};
  const SessionScript areaBack = parseSessionScript(formatSessionScript(withArea));
  ASSERT_TRUE(areaBack.freeArea.has_value());
  EXPECT_EQ(*areaBack.freeArea, *withArea.freeArea);
  const SessionScript again = parseSessionScript(formatSessionScript(s));
  EXPECT_EQ(formatSessionScript(again), formatSessionScript(s));
  ASSERT_EQ(again.events.size(), s.events.size());
  for (std::size_t i = 0; i < s.events.size(); ++i) {
    EXPECT_EQ(again.events[i].t, s.events[i].t);
    EXPECT_EQ(again.events[i].touch.px, s.events[i].touch.px);
    EXPECT_EQ(again.events[i].action, s.events[i].action);
  }
}

TEST(SessionScript, RejectsBadScriptsWithClearMessages) {
  const std::pair<const char*, const char*> bad[] = {
      {"not json", "not valid JSON"},
      {"[]", "JSON object"},
      {R"({"format": "other", "version": 1})", "not a handson session"},
      {R"({"format": "handson-session", "version": 99, "viewport": [1, 1], "events": []})", "version 99"},
      {R"({"format": "handson-session", "version": 1, "events": []})", "viewport"},
      {R"({"format": "handson-session", "version": 1, "viewport": [9, 9], "free_area": [0.5, 0.1, 0.52, 0.9], "events": []})", "free_area"},
      {R"({"format": "handson-session", "version": 1, "viewport": [9, 9], "free_area": [0, 0, 1.5, 1], "events": []})", "free_area"},
      {R"({"format": "handson-session", "version": 1, "viewport": [0, 10], "events": []})", "viewport width"},
      {R"({"format": "handson-session", "version": 1, "viewport": [10, 10], "events": [{"t": 1, "touch": "down", "id": 1, "x": 0, "y": 0}, {"t": 0.5, "touch": "up", "id": 1, "x": 0, "y": 0}]})",
       "must not decrease"},
      {R"({"format": "handson-session", "version": 1, "viewport": [10, 10], "events": [{"t": 0, "touch": "hover", "id": 1, "x": 0, "y": 0}]})",
       "unknown touch phase"},
      {R"({"format": "handson-session", "version": 1, "viewport": [10, 10], "events": [{"t": 0, "touch": "down", "id": 1.5, "x": 0, "y": 0}]})",
       "integer"},
      {R"({"format": "handson-session", "version": 1, "viewport": [10, 10], "events": [{"t": 0, "ui": "explode"}]})", "unknown UI action"},
      {R"({"format": "handson-session", "version": 1, "viewport": [10, 10], "events": [{"t": 0, "ui": "set-mode", "value": "dance"}]})",
       "unknown mode"},
      {R"({"format": "handson-session", "version": 1, "viewport": [10, 10], "events": [{"t": 0, "ui": "set-interface", "value": "velcro"}]})",
       "sliding or glued"},
      {R"({"format": "handson-session", "version": 1, "viewport": [10, 10], "events": [{"t": 0, "ui": "cut", "value": "0,0,0,1,0,0,1,1,0"}]})",
       "twelve numbers"},
      {R"({"format": "handson-session", "version": 1, "viewport": [10, 10], "events": [{"t": 0, "ui": "cut", "value": "0,0,0,1,0,0,1,1,0,0,1,5"}]})",
       "one plane"},
      {R"({"format": "handson-session", "version": 1, "viewport": [10, 10], "events": [{"t": 0, "touch": "down", "ui": "x", "id": 1, "x": 0, "y": 0}]})",
       "exactly one"},
      {R"({"format": "handson-session", "version": 1, "viewport": [10, 10], "camera": {"target": [0, 0], "distance": 1, "azimuth_deg": 0, "elevation_deg": 0}, "events": []})",
       "camera.target"},
      // Found by fuzz_script: a number too large for a double escaped as the JSON library's own
      // out_of_range exception instead of this parser's error.
      {"333333333333e333333-", "not valid JSON"},
      {R"({"format": "handson-session", "version": 1e999, "events": []})", "not valid JSON"},
  };
  for (const auto& [text, mention] : bad) {
    try {
      parseSessionScript(text, "test.json");
      ADD_FAILURE() << "accepted: " << text;
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find(mention), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find("test.json"), std::string::npos) << e.what();
    }
  }
  EXPECT_THROW(readSessionScript("/nonexistent/script.json"), Error);
}

TEST(SessionScript, BuiltInDemoIsValidAndNavigates) {
  const SessionScript s = builtInDemoScript();
  EXPECT_GT(s.events.size(), 100u);
  VolumeGeometry g;
  g.dims = {100, 80, 60};
  g.spacing = {2, 2, 2};
  Session session(g, s.viewport, "ct-abdomen");
  const OrbitCamera before = session.camera();
  for (const auto& e : s.events) EXPECT_TRUE(session.apply(e));
  EXPECT_GT(session.camera().azimuth, before.azimuth);        // the orbit drag went right
  EXPECT_LT(session.camera().distance, before.distance);      // the pinch spread the fingers
  EXPECT_NE(session.camera().roll, before.roll);              // and twisted them
}

TEST(Session, UiActionsAndRecording) {
  VolumeGeometry g;
  g.dims = {10, 10, 10};
  Session s(g, {200, 100}, "ct-abdomen");
  s.startRecording(SessionScript{});
  ScriptEvent preset;
  preset.isTouch = false;
  preset.action = UiAction::SetPreset;
  preset.value = "ct-bone";
  EXPECT_TRUE(s.apply(preset));
  EXPECT_TRUE(s.takePresetChanged());
  EXPECT_FALSE(s.takePresetChanged());
  preset.value = "nonsense";
  EXPECT_FALSE(s.apply(preset));  // refused and not recorded
  ScriptEvent mode = preset;
  mode.action = UiAction::SetMode;
  mode.value = "manipulate";
  EXPECT_TRUE(s.apply(mode));
  EXPECT_EQ(s.gestures().mode(), InteractionMode::Manipulate);
  EXPECT_EQ(s.script().events.size(), 2u);
  EXPECT_EQ(s.script().viewport.width, 200);
  // The strain overlay toggles and is recorded; a script carrying the action parses back.
  ScriptEvent strain = preset;
  strain.action = UiAction::ToggleStrain;
  strain.value.clear();
  EXPECT_FALSE(s.strainOverlay());
  EXPECT_TRUE(s.apply(strain));
  EXPECT_TRUE(s.strainOverlay());
  EXPECT_TRUE(s.apply(strain));
  EXPECT_FALSE(s.strainOverlay());
  EXPECT_EQ(s.script().events.size(), 4u);
  const SessionScript back = parseSessionScript(formatSessionScript(s.script()));
  ASSERT_EQ(back.events.size(), 4u);
  EXPECT_EQ(back.events[3].action, UiAction::ToggleStrain);
  // So does the limit highlight.
  ScriptEvent limits = strain;
  limits.action = UiAction::ToggleLimits;
  EXPECT_FALSE(s.limitHighlight());
  EXPECT_TRUE(s.apply(limits));
  EXPECT_TRUE(s.limitHighlight());
  EXPECT_FALSE(s.strainOverlay());
  EXPECT_EQ(s.script().events.size(), 5u);
  const SessionScript back2 = parseSessionScript(formatSessionScript(s.script()));
  ASSERT_EQ(back2.events.size(), 5u);
  EXPECT_EQ(back2.events[4].action, UiAction::ToggleLimits);
}

TEST(LatencyLog, PercentilesAndSummary) {
  EXPECT_EQ(percentile({}, 0.5), 0.0);
  EXPECT_EQ(percentile({5, 1, 3}, 0.5), 3.0);
  std::vector<double> v;
  for (int i = 1; i <= 100; ++i) v.push_back(i);
  EXPECT_EQ(percentile(v, 0.95), 95.0);
  EXPECT_EQ(percentile(v, 0.99), 99.0);
  EXPECT_EQ(percentile(v, 1.0), 100.0);
  LatencyLog log;
  for (int i = 0; i < 10; ++i) {
    FrameTiming f;
    f.frame = std::uint64_t(i);
    f.cpuStart = i * 0.1;
    f.present = i * 0.1 + 0.05;
    f.inputFirst = i % 2 ? i * 0.1 - 0.01 : -1.0;
    f.waitMs = 25.0;
    log.add(f);
  }
  log.setGpuTimes(3, {{"raymarch", 4.5}});
  EXPECT_EQ(log.frames()[3].gpuMs.size(), 1u);
  const std::string s = log.summary();
  EXPECT_NE(s.find("10 frames"), std::string::npos) << s;
  EXPECT_NE(s.find("median 50.0 ms"), std::string::npos) << s;
  EXPECT_NE(s.find("median 60.0 ms"), std::string::npos) << s;  // latency: 50 ms + 10 ms before the frame
  EXPECT_NE(s.find("waiting 50.0 %"), std::string::npos) << s;
}

TEST(LatencyLog, DisplayTimesAndNotesReachTheCsv) {
  LatencyLog log;
  for (int i = 1; i <= 4; ++i) {
    FrameTiming f;
    f.frame = std::uint64_t(i);
    f.cpuStart = i * 0.1;
    f.present = i * 0.1 + 0.05;
    f.inputFirst = i * 0.1 - 0.01;
    log.add(f);
  }
  // Display times arrive after the frames were logged; frame 4's never does.
  for (int i = 1; i <= 3; ++i) log.setDisplayed(std::uint64_t(i), i * 0.1 + 0.07);
  log.setDisplayed(99, 5.0);  // an unknown frame changes nothing
  EXPECT_DOUBLE_EQ(log.frames()[0].displayLatencyMs(), 80.0);  // 10 ms before the frame + 70 ms
  EXPECT_LT(log.frames()[3].displayLatencyMs(), 0.0);
  const std::string s = log.summary();
  EXPECT_NE(s.find("input-to-display latency (3 frames) median 80.0 ms"), std::string::npos) << s;
  log.setNotes({"clock: a test", "display: by hand"});
  const auto path = std::filesystem::temp_directory_path() / "handson_latency_notes.csv";
  log.writeCsv(path.string());
  std::ifstream in(path);
  std::string line;
  std::getline(in, line);
  EXPECT_EQ(line, "# clock: a test");
  std::getline(in, line);
  EXPECT_EQ(line, "# display: by hand");
  std::getline(in, line);
  EXPECT_EQ(line.rfind("frame,input_count,input_first_s,input_last_s,cpu_start_s,cpu_end_s,submit_s,present_s,displayed_s,frame_ms,"
                       "input_to_submit_ms,input_to_present_ms,input_to_display_ms,wait_ms",
                       0),
            0u)
      << line;
  std::getline(in, line);
  EXPECT_NE(line.find(",0.170000,"), std::string::npos) << line;  // frame 1 shown at 0.17 s
  EXPECT_NE(line.find(",80.000000,"), std::string::npos) << line;
  for (int i = 0; i < 3; ++i) std::getline(in, line);
  EXPECT_NE(line.find(",-1.000000,"), std::string::npos) << "frame 4: not shown, -1: " << line;
  std::filesystem::remove(path);
}
