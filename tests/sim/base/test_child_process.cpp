// The one run-in-a-child helper: frames and raw bytes come through in order, and every way a child
// can end - an exit status, a crash, a hang past the deadline, an exception - is told apart.
#include <gtest/gtest.h>

#include <chrono>
#include <csignal>
#include <cstdlib>
#include <thread>

#include "sim/base/child_process.h"
#include "sim/base/error.h"

using namespace handson;

TEST(ChildProcess, FramesAndRawBytesArriveInOrder) {
  std::vector<std::pair<int, std::string>> frames;
  std::vector<std::uint32_t> raw(1 << 22);  // 16 MiB: more than a pipe holds, read while written
  const ChildEnd end = runInChild(
      [](ChildWriter& w) {
        for (int k = 0; k < 3; ++k) w.frame(std::uint8_t(k + 1), "frame " + std::to_string(k));
        std::vector<std::uint32_t> v(1 << 22);
        for (std::size_t i = 0; i < v.size(); ++i) v[i] = std::uint32_t(i * 2654435761u);
        w.frame(9, "");
        return w.raw(v.data(), v.size() * 4) ? 7 : 1;
      },
      [&](ChildReader& r) {
        std::uint8_t kind = 0;
        std::string payload;
        while (r.frame(kind, payload)) {
          if (kind == 9) {
            ASSERT_TRUE(r.raw(raw.data(), raw.size() * 4));
            break;
          }
          frames.emplace_back(kind, payload);
        }
      },
      10.0, "test");
  EXPECT_EQ(end.exitCode, 7);
  EXPECT_EQ(end.signal, 0);
  EXPECT_FALSE(end.timedOut);
  ASSERT_EQ(frames.size(), 3u);
  EXPECT_EQ(frames[2], std::make_pair(3, std::string("frame 2")));
  for (std::size_t i = 0; i < raw.size(); i += 4099) ASSERT_EQ(raw[i], std::uint32_t(i * 2654435761u)) << i;
}

TEST(ChildProcess, ACrashAHangAndAnExceptionAreToldApart) {
  const auto nothing = [](ChildReader& r) {
    std::uint8_t k;
    std::string p;
    while (r.frame(k, p)) {
    }
  };
  const ChildEnd crash = runInChild([](ChildWriter&) -> int { std::abort(); }, nothing, 10.0, "test");
  EXPECT_EQ(crash.signal, SIGABRT);
  EXPECT_FALSE(crash.clean());
  EXPECT_NE(signalName(crash.signal).find("abort"), std::string::npos);
  const auto t0 = std::chrono::steady_clock::now();
  const ChildEnd hang = runInChild(
      [](ChildWriter&) {
        std::this_thread::sleep_for(std::chrono::seconds(30));
        return 0;
      },
      nothing, 0.3, "test");
  EXPECT_TRUE(hang.timedOut);
  EXPECT_EQ(hang.signal, 0) << "the deadline's kill is not a crash";
  EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(), 5.0);
  const ChildEnd thrown = runInChild([](ChildWriter&) -> int { throw std::runtime_error("x"); }, nothing, 10.0, "test");
  EXPECT_EQ(thrown.exitCode, 4);
  const ChildEnd ok = runInChild([](ChildWriter&) { return 0; }, nothing, 0.0, "test");
  EXPECT_TRUE(ok.clean());
  // The parent's own exception kills and reaps the child, and propagates.
  EXPECT_THROW(runInChild(
                   [](ChildWriter&) {
                     std::this_thread::sleep_for(std::chrono::seconds(30));
                     return 0;
                   },
                   [](ChildReader&) { throw Error("parent gave up"); }, 0.0, "test"),
               Error);
}
