// Failure handling of a running session (#9): a Vulkan allocation that fails, a device that is
// lost, a simulation that does not converge, a volume larger than the memory allowed. Each must
// end in a clear message (never a crash: the process exits with 1, not a signal), keep what the
// user did (the recovery script and handles, readable), and leave no half-written export.
// Faults are injected through HANDSON_FAULT (render/vk_context.h) into the real binary.
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>

#include "app/io/nifti_io.h"
#include "app/session/session_recovery.h"
#include "app/session/session_script.h"
#include "sim/base/error.h"
#include "tests/app/run_handson.h"

namespace fs = std::filesystem;

namespace {

using RunResult = handson::test::HandsonRun;

RunResult run(const std::string& env, const std::string& args) { return handson::test::runHandson(args, 300, env); }

std::string slurp(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), {}};
}

class FailureHandling : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("handson_failures_" + std::to_string(getpid()) + "_" +
                                        ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    // The two-finger kidney drag (simulated) with an export after it.
    std::string text = slurp(fs::path(HANDSON_SOURCE_DIR) / "assets/gestures/kidney-translate-two-fingers.json");
    const auto end = text.rfind("\n  ]");
    ASSERT_NE(end, std::string::npos);
    text.insert(end, ",\n    {\"t\": 2.3, \"ui\": \"export\"}");
    std::ofstream(dir_ / "drag-export.json") << text;
  }
  void TearDown() override { fs::remove_all(dir_); }

  std::string replay(const fs::path& out, const std::string& extra = "") const {
    return "replay " + (dir_ / "drag-export.json").string() + " --fps 10 --size 48x48 --quiet --validation --print-handles " +
           "--sim-coarse-tets 300 --sim-fine-tets 19200 --sim-cache off --export-dir " + out.string() + " " + extra;
  }

  /// No temporary file anywhere under `out`, and every export there reads back whole.
  static void expectNoPartialFiles(const fs::path& out, const std::string& context) {
    if (!fs::exists(out)) return;
    for (const auto& f : fs::recursive_directory_iterator(out)) {
      const std::string name = f.path().filename().string();
      EXPECT_EQ(name.find(".tmp-"), std::string::npos) << "a temporary file was left: " << f.path() << "\n" << context;
      try {
        if (name.size() > 7 && name.substr(name.size() - 7) == ".nii.gz") handson::readNifti(f.path().string());
        if (name.rfind("session-", 0) == 0 || name == "recovery-session.json") handson::readSessionScript(f.path().string());
        if (name.rfind("handles-", 0) == 0 || name == "recovery-handles.json") handson::readHandles(f.path().string());
      } catch (const handson::Error& e) {
        ADD_FAILURE() << f.path() << " does not read back: " << e.what() << "\n" << context;
      }
    }
  }

  fs::path dir_;
};

}  // namespace

TEST_F(FailureHandling, EveryVulkanAllocationThatFailsGivesAClearMessageAndKeepsTheSession) {
  // The N-th vkAllocateMemory fails (setup, the selection, the simulation's buffers, the uploads
  // and readbacks of frames, the export). Each run either ends with exit status 1 and the message
  // (once the session has started, its script and handles saved), or carries on: the simulation
  // or the export reports the failure and the session goes on, or the allocation was retried
  // (host-visible memory falls back from coherent to non-coherent) and the result is the clean
  // run's. N = 1..12 (the setup) then every 13th to the last allocation; HANDSON_FULL_FAULT_SWEEP=1
  // tries every N (94 allocations on lavapipe, the figures in the README).
  const RunResult clean = run("", replay(dir_ / "clean"));
  ASSERT_EQ(clean.status, 0) << clean.output;
  const auto handleLine = [](const std::string& out) {
    const auto at = out.find("handle 1 ");
    return at == std::string::npos ? std::string() : out.substr(at, out.find('\n', at) - at);
  };
  ASSERT_FALSE(handleLine(clean.output).empty()) << clean.output;
  const bool full = std::getenv("HANDSON_FULL_FAULT_SWEEP") != nullptr;
  int fatal = 0, reported = 0, recovered = 0, n = 1;
  for (; n <= 400; n += (full || n < 12) ? 1 : 13) {
    const fs::path out = dir_ / ("out" + std::to_string(n));
    const RunResult r = run("HANDSON_FAULT=alloc:" + std::to_string(n), replay(out));
    const std::string context = "alloc:" + std::to_string(n) + "\n" + r.output;
    if (!r.has("injected fault")) {  // past the last allocation: a clean run
      EXPECT_EQ(r.status, 0) << context;
      break;
    }
    ASSERT_NE(r.status, -1) << "crashed: " << context;
    if (r.status != 0) {
      ++fatal;
      EXPECT_EQ(r.status, 1) << context;
      EXPECT_TRUE(r.has("vkAllocateMemory failed (VK_ERROR_OUT_OF_DEVICE_MEMORY") && r.has("out of memory")) << context;
      if (r.has("the session so far is saved")) {
        handson::readSessionScript((out / "recovery-session.json").string());
        handson::readHandles((out / "recovery-handles.json").string());
      } else {
        // Only before the session exists (loading, the renderer's setup): nothing to lose yet.
        EXPECT_FALSE(fs::exists(out)) << context;
      }
    } else if (r.has("simulation failed") || r.has("export failed")) {
      ++reported;
    } else {
      ++recovered;
      EXPECT_EQ(handleLine(r.output), handleLine(clean.output)) << context;
      EXPECT_TRUE(r.has("exported to")) << context;
    }
    expectNoPartialFiles(out, context);
  }
  EXPECT_LT(n, 400) << "the replay never ran clean";
  EXPECT_GT(fatal, 0);
  EXPECT_GT(reported, 0);
  std::cout << "allocations tried up to " << n - 1 << ": " << fatal << " fatal (session saved, or not started yet), " << reported
            << " reported by the simulation or the export, " << recovered << " recovered\n";
}

TEST_F(FailureHandling, ALostDeviceEndsTheReplayWithTheSessionSaved) {
  // The device is lost at the N-th submission (and stays lost): at once, during the selection,
  // during the simulated drag and at the end.
  for (int n : {1, 4, 12, 22}) {
    const fs::path out = dir_ / ("out" + std::to_string(n));
    const RunResult r = run("HANDSON_FAULT=device-lost:" + std::to_string(n), replay(out));
    const std::string context = "device-lost:" + std::to_string(n) + "\n" + r.output;
    ASSERT_EQ(r.status, 1) << context;
    EXPECT_TRUE(r.has("VK_ERROR_DEVICE_LOST") && r.has("the GPU device was lost")) << context;
    if (n > 4) {
      EXPECT_TRUE(r.has("the session so far is saved")) << context;
      const handson::SessionScript s = handson::readSessionScript((out / "recovery-session.json").string());
      EXPECT_GT(s.events.size(), 0u) << context;
      handson::readHandles((out / "recovery-handles.json").string());
    }
    expectNoPartialFiles(out, context);
  }
}

TEST_F(FailureHandling, ASolveThatDoesNotConvergeIsReportedAndTheSessionGoesOnSaved) {
  // One coarse iteration a pose and none while it is held: the drag's solves stop unconverged.
  const fs::path out = dir_ / "out";
  const RunResult r = run("", replay(out, "--sim-iterations 1 --sim-idle-iterations 0"));
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_TRUE(r.has("did not converge (1 iteration,")) << r.output;
  EXPECT_TRUE(r.has("showing the last state it reached")) << r.output;
  EXPECT_TRUE(r.has("the session so far is saved")) << r.output;
  const handson::SavedHandles saved = handson::readHandles((out / "recovery-handles.json").string());
  ASSERT_EQ(saved.handles.size(), 1u);
  EXPECT_TRUE(saved.handles[0].pose.t.allFinite());
  // The session went on to its export.
  EXPECT_TRUE(fs::exists(out / "session-01.json")) << r.output;
  expectNoPartialFiles(out, r.output);
  // With the default budget the same drag converges: no such report.
  const RunResult clean = run("", replay(dir_ / "clean"));
  ASSERT_EQ(clean.status, 0) << clean.output;
  EXPECT_FALSE(clean.has("did not converge")) << clean.output;
  EXPECT_FALSE(fs::exists(dir_ / "clean" / "recovery-session.json"));
}

TEST_F(FailureHandling, AVolumeLargerThanTheMemoryAllowedIsRefusedBeforeItIsLoaded) {
  const fs::path ct = dir_ / "phantom.nii.gz";
  RunResult r = run("", "phantom -o " + ct.string() + " --spacing 3");
  ASSERT_EQ(r.status, 0) << r.output;
  // Host memory: a cap below the volume's size.
  r = run("HANDSON_MEMORY_LIMIT_MB=1", "replay --volume " + ct.string() + " --size 48x48 --fps 2 --quiet");
  ASSERT_EQ(r.status, 1) << r.output;
  EXPECT_TRUE(r.has("more than the 1 MiB this process may use (HANDSON_MEMORY_LIMIT_MB)")) << r.output;
  EXPECT_TRUE(r.has("handson resample --voxels")) << r.output;
  // GPU memory: a device too small for the textures (a cap standing in for a small GPU).
  r = run("HANDSON_GPU_MEMORY_LIMIT_MB=1", "replay --volume " + ct.string() + " --size 48x48 --fps 2 --quiet");
  ASSERT_EQ(r.status, 1) << r.output;
  EXPECT_TRUE(r.has("MiB of GPU memory to render and deform, more than the 1 MiB of")) << r.output;
  // Within both, it runs.
  r = run("HANDSON_MEMORY_LIMIT_MB=4000 HANDSON_GPU_MEMORY_LIMIT_MB=4000", "replay --volume " + ct.string() + " --size 48x48 --fps 2 --quiet");
  EXPECT_EQ(r.status, 0) << r.output;
}

TEST_F(FailureHandling, AMalformedFaultSpecificationIsRefused) {
  const RunResult r = run("HANDSON_FAULT=alloc:zero", "replay --size 32x32 --fps 1 --quiet");
  EXPECT_EQ(r.status, 1) << r.output;
  EXPECT_TRUE(r.has("is not alloc:N or device-lost:N")) << r.output;
}
