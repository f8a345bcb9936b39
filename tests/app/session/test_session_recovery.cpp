// The handles file and the recovery save (app/session/session_recovery.h).
#include <gtest/gtest.h>
#include <unistd.h>

#include <Eigen/Geometry>
#include <filesystem>
#include <fstream>

#include "app/session/session.h"
#include "app/session/session_recovery.h"
#include "sim/base/error.h"

using namespace handson;
namespace fs = std::filesystem;

namespace {

HandleSet twoHandles() {
  HandleSet set;
  // Runs and single voxels, on a 10 x 10 x 10 grid.
  EXPECT_EQ(set.add({3, 4, 5, 6, 50, 999}), 1);
  EXPECT_EQ(set.add({100, 101, 102, 200}), 2);
  RigidTransform pose;
  pose.R = Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  pose.t = {1.5, -2.25, 1e-7};
  EXPECT_TRUE(set.setPose(1, pose, true));
  EXPECT_TRUE(set.setStatus(2, HandleStatus::Fixed));
  return set;
}

std::string errorOf(const std::string& text) {
  try {
    parseHandles(text, "h.json");
  } catch (const Error& e) {
    return e.what();
  }
  return "(accepted)";
}

}  // namespace

TEST(SessionRecovery, HandlesRoundTripExactly) {
  const HandleSet set = twoHandles();
  const SavedHandles back = parseHandles(formatHandles(set, {2, 1}, {10, 10, 10}));
  EXPECT_EQ(back.dims, Eigen::Vector3i(10, 10, 10));
  EXPECT_EQ(back.picked, (std::vector<int>{2, 1}));
  ASSERT_EQ(back.handles.size(), 2u);
  for (std::size_t i = 0; i < 2; ++i) {
    const Handle& a = set.handles()[i];
    const Handle& b = back.handles[i];
    EXPECT_EQ(a.id, b.id);
    EXPECT_EQ(a.status, b.status);
    EXPECT_EQ(a.voxels, b.voxels);
    // JSON numbers are written with 17 significant digits: the pose comes back bit for bit.
    EXPECT_EQ(a.pose.R, b.pose.R);
    EXPECT_EQ(a.pose.t, b.pose.t);
  }
}

TEST(SessionRecovery, BrokenHandlesFilesAreRefusedWithTheReason) {
  const std::string good = formatHandles(twoHandles(), {}, {10, 10, 10});
  auto edited = [&](const std::string& from, const std::string& to) {
    std::string s = good;
    const auto at = s.find(from);
    EXPECT_NE(at, std::string::npos) << from;
    if (at != std::string::npos) s.replace(at, from.size(), to);
    return s;
  };
  EXPECT_NE(errorOf("{").find("not valid JSON"), std::string::npos);
  EXPECT_NE(errorOf(R"({"format": "handson-session"})").find("not a handles file"), std::string::npos);
  EXPECT_NE(errorOf(edited("\"version\": 1", "\"version\": 2")).find("unsupported version"), std::string::npos);
  EXPECT_NE(errorOf(edited("\"id\": 2", "\"id\": 1")).find("appears twice"), std::string::npos);
  EXPECT_NE(errorOf(edited("\"id\": 2", "\"id\": 300")).find("outside 1..254"), std::string::npos);
  EXPECT_NE(errorOf(edited("\"status\": \"fixed\"", "\"status\": \"glued\"")).find("unknown status"), std::string::npos);
  // A run past the grid's end (999 + 2 > 1000 voxels) and a count that does not match.
  const std::string past = errorOf(edited("[\n     999,\n     1\n    ]", "[\n     999,\n     2\n    ]"));
  EXPECT_TRUE(past.find("inside the grid") != std::string::npos || past.find("does not match") != std::string::npos) << past;
  EXPECT_NE(errorOf(edited("\"voxels\": 6", "\"voxels\": 7")).find("does not match"), std::string::npos);
  // The second handle's first run moved onto the first handle's voxels.
  EXPECT_NE(errorOf(edited("[\n     100,\n     3\n    ]", "[\n     3,\n     3\n    ]")).find("two handles"), std::string::npos);
  EXPECT_NE(errorOf(edited("\"dims\": [\n  10,", "\"dims\": [\n  0,")).find("dims"), std::string::npos);
  EXPECT_NE(errorOf(edited("\"picked\": []", "\"picked\": [7]")).find("picked"), std::string::npos);
  // A pose that is not a rotation (a scaled identity) and one with a null (NaN written by a broken writer).
  const std::string scaled = edited("\"rotation\": [\n    1.0,", "\"rotation\": [\n    2.0,");
  EXPECT_NE(errorOf(scaled).find("not a finite rigid motion"), std::string::npos) << scaled;
  EXPECT_NE(errorOf(edited("\"translation\": [\n    0.0,", "\"translation\": [\n    null,")).find("non-number"), std::string::npos);
}

TEST(SessionRecovery, SavesTheScriptAndTheHandlesAndSaysWhereOrWhyNot) {
  const fs::path dir = fs::temp_directory_path() / ("handson_recovery_" + std::to_string(getpid()));
  fs::remove_all(dir);
  VolumeGeometry g;
  g.dims = {10, 10, 10};
  Session session(g, {64, 64}, "ct-abdomen");
  SessionScript header;
  session.startRecording(header);
  ScriptEvent e;
  e.t = 0.5;
  e.isTouch = false;
  e.action = UiAction::SetMode;
  e.value = "select";
  ASSERT_TRUE(session.apply(e));
  const HandleSet set = twoHandles();
  const std::string said = saveRecovery(session, set, {1}, g.dims, (dir / "sub").string());
  EXPECT_NE(said.find("recovery-session.json"), std::string::npos) << said;
  EXPECT_NE(said.find("recovery-handles.json"), std::string::npos) << said;
  const SessionScript script = readSessionScript((dir / "sub" / "recovery-session.json").string());
  ASSERT_EQ(script.events.size(), 1u);
  EXPECT_EQ(script.events[0].value, "select");
  const SavedHandles saved = readHandles((dir / "sub" / "recovery-handles.json").string());
  EXPECT_EQ(saved.handles.size(), 2u);
  EXPECT_EQ(saved.picked, std::vector<int>{1});
  // A second save replaces both files whole; no temporary file is left beside them.
  EXPECT_NE(saveRecovery(session, HandleSet{}, {}, g.dims, (dir / "sub").string()).find("0 handles"), std::string::npos);
  EXPECT_TRUE(readHandles((dir / "sub" / "recovery-handles.json").string()).handles.empty());
  for (const auto& f : fs::directory_iterator(dir / "sub")) EXPECT_EQ(f.path().string().find(".tmp-"), std::string::npos) << f.path();
  // Where nothing can be written (a file in the way of the directory), it says so and does not throw.
  std::ofstream(dir / "file") << "x";
  const std::string refused = saveRecovery(session, set, {}, g.dims, (dir / "file" / "sub").string());
  EXPECT_NE(refused.find("could not be saved"), std::string::npos) << refused;
  fs::remove_all(dir);
}
