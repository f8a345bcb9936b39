// The present timer's bookkeeping, without a GPU: a fake presentation engine stands in for
// vkWaitForPresentKHR (shown up to an id; waits time out in short slices like the real one).
#include <gtest/gtest.h>

#include <atomic>
#include <thread>

#include "render/present_timer.h"

using handson::vk::PresentTimer;
using namespace std::chrono_literals;

namespace {

struct FakeEngine {
  std::atomic<std::uint64_t> shownUpTo{0};
  std::atomic<bool> outOfDate{false};
  std::atomic<int> calls{0};
  VkResult wait(std::uint64_t id, std::uint64_t timeoutNs) {
    ++calls;
    const auto until = std::chrono::steady_clock::now() + std::chrono::nanoseconds(std::min<std::uint64_t>(timeoutNs, 5'000'000));
    while (std::chrono::steady_clock::now() < until) {
      if (outOfDate) return VK_ERROR_OUT_OF_DATE_KHR;
      if (shownUpTo >= id) return VK_SUCCESS;
      std::this_thread::sleep_for(200us);
    }
    return VK_TIMEOUT;
  }
};

// Collects what the timer reports until `count` presents were shown or 2 s passed.
std::vector<PresentTimer::Shown> collect(PresentTimer& t, std::size_t count) {
  std::vector<PresentTimer::Shown> all;
  const auto end = std::chrono::steady_clock::now() + 2s;
  while (all.size() < count && std::chrono::steady_clock::now() < end) {
    for (const auto& s : t.takeShown()) all.push_back(s);
    std::this_thread::sleep_for(1ms);
  }
  return all;
}

VkSwapchainKHR fakeSwapchain() { return reinterpret_cast<VkSwapchainKHR>(std::uintptr_t(0x1234)); }

}  // namespace

TEST(PresentTimer, ReportsEachPresentWhenTheEngineShowsItInOrder) {
  FakeEngine engine;
  PresentTimer timer([&](VkSwapchainKHR, std::uint64_t id, std::uint64_t ns) { return engine.wait(id, ns); });
  for (std::uint64_t id = 1; id <= 3; ++id) timer.presented(fakeSwapchain(), id, 100 + id);
  std::this_thread::sleep_for(20ms);
  EXPECT_TRUE(timer.takeShown().empty()) << "nothing shown yet";
  const auto before = std::chrono::steady_clock::now();
  engine.shownUpTo = 2;
  auto shown = collect(timer, 2);
  ASSERT_EQ(shown.size(), 2u);
  EXPECT_EQ(shown[0].tag, 101u);
  EXPECT_EQ(shown[1].tag, 102u);
  EXPECT_GE(shown[0].at, before) << "timed when the wait returned, not when queued";
  EXPECT_LE(shown[0].at, shown[1].at);
  engine.shownUpTo = 3;
  shown = collect(timer, 1);
  ASSERT_EQ(shown.size(), 1u);
  EXPECT_EQ(shown[0].tag, 103u);
  EXPECT_EQ(timer.dropped(), 0u);
}

TEST(PresentTimer, AnOutOfDateSwapchainDropsThePresentInsteadOfGuessing) {
  FakeEngine engine;
  PresentTimer timer([&](VkSwapchainKHR, std::uint64_t id, std::uint64_t ns) { return engine.wait(id, ns); });
  engine.outOfDate = true;
  timer.presented(fakeSwapchain(), 1, 7);
  timer.drain(1s);
  EXPECT_TRUE(timer.takeShown().empty());
  EXPECT_EQ(timer.dropped(), 1u);
}

TEST(PresentTimer, DrainGivesUpOnPresentsNeverShownAndLetsGoOfTheSwapchain) {
  FakeEngine engine;  // shows nothing (a hidden window)
  PresentTimer timer([&](VkSwapchainKHR, std::uint64_t id, std::uint64_t ns) { return engine.wait(id, ns); });
  for (std::uint64_t id = 1; id <= 3; ++id) timer.presented(fakeSwapchain(), id, id);
  const auto t0 = std::chrono::steady_clock::now();
  timer.drain(30ms);
  EXPECT_LT(std::chrono::steady_clock::now() - t0, 30ms + std::chrono::nanoseconds(PresentTimer::kSliceNs) + 200ms);
  EXPECT_EQ(timer.dropped(), 3u);
  // After drain() the swapchain may be destroyed: the waiter must not call into it again.
  const int calls = engine.calls;
  std::this_thread::sleep_for(30ms);
  EXPECT_EQ(engine.calls, calls);
  // And the timer goes on with the next swapchain.
  engine.shownUpTo = 10;
  timer.presented(fakeSwapchain(), 10, 42);
  const auto shown = collect(timer, 1);
  ASSERT_EQ(shown.size(), 1u);
  EXPECT_EQ(shown[0].tag, 42u);
}

TEST(PresentTimer, StopsPromptlyWithPresentsPending) {
  FakeEngine engine;
  const auto t0 = std::chrono::steady_clock::now();
  {
    PresentTimer timer([&](VkSwapchainKHR, std::uint64_t id, std::uint64_t ns) { return engine.wait(id, ns); });
    timer.presented(fakeSwapchain(), 1, 1);
    std::this_thread::sleep_for(10ms);
  }
  EXPECT_LT(std::chrono::steady_clock::now() - t0, 1s);
}
