#pragma once
// When each presented frame reached the screen, for latency studies (VK_KHR_present_wait).
//
// vkQueuePresentKHR only hands an image to the presentation engine; when it returns, nothing has
// been shown yet. With VK_KHR_present_id each present carries an increasing id, and
// vkWaitForPresentKHR(id) returns once that present (or a later one) has been shown: "as close as
// possible to the presentation of the first pixel" (the extension's words). A waiter thread waits
// for each queued id in order and notes the steady-clock time at which the wait returned. The spec
// lets vkWaitForPresentKHR run beside acquire and present on the same swapchain; only destroying
// the swapchain must not overlap it, so drain() comes first.
//
// In mailbox mode a replaced image is never shown: its wait returns when its replacement is.
#include <vulkan/vulkan.h>

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <functional>
#include <mutex>
#include <thread>
#include <vector>

namespace handson::vk {

class PresentTimer {
 public:
  using Clock = std::chrono::steady_clock;
  /// vkWaitForPresentKHR for one swapchain and id, with a timeout in nanoseconds.
  using WaitFn = std::function<VkResult(VkSwapchainKHR swapchain, std::uint64_t presentId, std::uint64_t timeoutNs)>;
  struct Shown {
    std::uint64_t tag = 0;  ///< the caller's name for the present (the frame number)
    Clock::time_point at;   ///< when the wait for it returned
  };
  /// Each wait is cut into slices of this length, so drain() never waits long on a swapchain.
  static constexpr std::uint64_t kSliceNs = 50'000'000;
  /// A present not shown after this long is given up on (a hidden or occluded window).
  static constexpr std::chrono::milliseconds kGiveUp{2000};

  explicit PresentTimer(WaitFn wait);
  ~PresentTimer();
  PresentTimer(const PresentTimer&) = delete;
  PresentTimer& operator=(const PresentTimer&) = delete;

  /// A present was queued on `swapchain` with `presentId` (increasing per swapchain).
  void presented(VkSwapchainKHR swapchain, std::uint64_t presentId, std::uint64_t tag);
  /// The presents seen on screen since the last call, oldest first.
  std::vector<Shown> takeShown();
  /// Waits until every queued present was seen or given up on, at most `timeout`; then gives up
  /// on the rest. Afterwards the waiter no longer touches any swapchain queued so far: call it
  /// before destroying or retiring one.
  void drain(std::chrono::milliseconds timeout);
  /// Presents whose display time could not be known (out of date, surface lost, given up on).
  std::uint64_t dropped() const;

 private:
  struct Pending {
    VkSwapchainKHR swapchain;
    std::uint64_t id, tag;
    Clock::time_point queued;
  };
  void run();

  WaitFn wait_;
  mutable std::mutex mutex_;
  std::condition_variable wake_, idle_;
  std::deque<Pending> pending_;
  std::vector<Shown> shown_;
  std::uint64_t dropped_ = 0;
  bool busy_ = false, abandon_ = false, stop_ = false;
  std::thread thread_;
};

}  // namespace handson::vk
