#include "present_timer.h"

namespace handson::vk {

PresentTimer::PresentTimer(WaitFn wait) : wait_(std::move(wait)) { thread_ = std::thread([this] { run(); }); }

PresentTimer::~PresentTimer() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stop_ = true;
  }
  wake_.notify_all();
  thread_.join();
}

void PresentTimer::presented(VkSwapchainKHR swapchain, std::uint64_t presentId, std::uint64_t tag) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    pending_.push_back({swapchain, presentId, tag, Clock::now()});
  }
  wake_.notify_all();
}

std::vector<PresentTimer::Shown> PresentTimer::takeShown() {
  std::lock_guard<std::mutex> lock(mutex_);
  std::vector<Shown> out;
  out.swap(shown_);
  return out;
}

std::uint64_t PresentTimer::dropped() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return dropped_;
}

void PresentTimer::drain(std::chrono::milliseconds timeout) {
  std::unique_lock<std::mutex> lock(mutex_);
  idle_.wait_for(lock, timeout, [this] { return pending_.empty() && !busy_; });
  if (pending_.empty() && !busy_) return;
  // Give up on the rest once the wait in progress (at most one slice) has returned.
  abandon_ = true;
  idle_.wait(lock, [this] { return !busy_; });
  dropped_ += pending_.size();
  pending_.clear();
  abandon_ = false;
}

void PresentTimer::run() {
  std::unique_lock<std::mutex> lock(mutex_);
  for (;;) {
    wake_.wait(lock, [this] { return stop_ || (!pending_.empty() && !abandon_); });
    if (stop_) return;
    const Pending p = pending_.front();
    busy_ = true;
    lock.unlock();
    const VkResult r = wait_(p.swapchain, p.id, kSliceNs);
    const Clock::time_point now = Clock::now();
    lock.lock();
    busy_ = false;
    if (r == VK_TIMEOUT && now - p.queued < kGiveUp && !abandon_) {
      idle_.notify_all();  // drain() may be waiting to abandon
      continue;            // not shown yet: wait again
    }
    // Shown (a success covers every id up to this one), or never to be known.
    if (!pending_.empty() && pending_.front().id == p.id && pending_.front().swapchain == p.swapchain) pending_.pop_front();
    if (r == VK_SUCCESS || r == VK_SUBOPTIMAL_KHR)
      shown_.push_back({p.tag, now});
    else
      ++dropped_;
    idle_.notify_all();
  }
}

}  // namespace handson::vk
