// The soak (app/tools/soak.h): a long session replayed headless must keep resident memory and the
// Vulkan device memory it holds flat, with no validation message. Here a short one (the 10,000-frame
// run is `handson soak`, figures in the README); it still covers several cycles after the warm-up,
// so a leak of a frame's worth of anything (a buffer, a PNG, a mask copy) shows as growth.
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "app/tools/soak.h"
#include "tests/app/run_handson.h"

namespace fs = std::filesystem;

#if defined(__SANITIZE_ADDRESS__)
#define HANDSON_ASAN 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
#define HANDSON_ASAN 1
#endif
#endif

TEST(Soak, TheScriptRepeatsWholeCyclesThatReturnWhereTheyStarted) {
  const handson::SessionScript s = handson::soakScript(400, 20.0);
  EXPECT_GE(s.duration(), 400 / 20.0);
  // Every finger put down is lifted; the events are in time order.
  int down = 0, up = 0;
  for (std::size_t i = 0; i < s.events.size(); ++i) {
    if (i) {
      EXPECT_LE(s.events[i - 1].t, s.events[i].t);
    }
    if (!s.events[i].isTouch) continue;
    down += s.events[i].touch.phase == handson::TouchPhase::Down;
    up += s.events[i].touch.phase == handson::TouchPhase::Up;
  }
  EXPECT_EQ(down, up);
}

TEST(Soak, MemoryAndVulkanAllocationsStayFlatOverManyCycles) {
  const fs::path out = fs::temp_directory_path() / ("handson_soak_" + std::to_string(getpid()));
  fs::remove_all(out);
#ifdef HANDSON_ASAN
  // AddressSanitizer keeps freed memory in quarantine (up to 256 MiB) by design: resident memory
  // grows under it whatever the code does. The run still checks crashes, validation and finiteness.
  const std::string tolerance = " --tolerance 10";
#else
  const std::string tolerance = "";
#endif
  const handson::test::HandsonRun run = handson::test::runHandson("soak --frames 480 --size 48x48 --sample-every 20 --quiet --sim-coarse-tets 300 --sim-fine-tets 19200 "
                                                 "--sim-cache off --out " + out.string() + tolerance, 600);
  const std::string& log = run.output;
  ASSERT_EQ(run.signal, 0) << log;
  EXPECT_EQ(run.status, 0) << log;
  EXPECT_NE(log.find("validation messages: 0"), std::string::npos) << log;
  // The kidney was selected once, moved and put back (undo) every cycle: one handle, at rest.
  EXPECT_NE(log.find("handle 1 active"), std::string::npos) << log;
  EXPECT_NE(log.find("translation 0,0,0 "), std::string::npos) << log;
  EXPECT_EQ(log.find("handle 2 "), std::string::npos) << log;
  // The samples: every 20 frames and the last, with device memory held (the volume, the mask...).
  std::ifstream csv(out / "soak.csv");
  std::string line;
  std::getline(csv, line);
  EXPECT_EQ(line, "frame,resident_mib,vulkan_live_allocations,vulkan_live_mib,validation_messages");
  int rows = 0;
  while (std::getline(csv, line)) {
    ++rows;
    std::istringstream row(line);
    std::string frame, rss, allocations;
    std::getline(row, frame, ',');
    std::getline(row, rss, ',');
    std::getline(row, allocations, ',');
    EXPECT_GT(std::stod(rss), 0.0) << line;
    EXPECT_GT(std::stol(allocations), 0) << line;
  }
  EXPECT_EQ(rows, 480 / 20 + 1);
  fs::remove_all(out);
}
