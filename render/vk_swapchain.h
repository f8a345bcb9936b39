#pragma once
// The window's swapchain: images, views, the UI render pass and framebuffers, acquire and present
// with their semaphores, recreation on resize. Present modes fifo (vsync), mailbox and immediate;
// an unsupported request falls back to fifo, which every driver has. Where the device offers
// VK_KHR_present_wait (Context::presentWait), each present is timed on screen (present_timer.h).
#include <vulkan/vulkan.h>

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "present_timer.h"

namespace handson::vk {

class Context;

VkPresentModeKHR parsePresentMode(const std::string& name);  ///< throws handson::Error on unknown names
const char* presentModeName(VkPresentModeKHR m);

class Swapchain {
 public:
  struct Frame {
    std::uint32_t image = 0;
    VkSemaphore acquired = VK_NULL_HANDLE;  ///< signalled when the image may be written
    VkSemaphore rendered = VK_NULL_HANDLE;  ///< to signal when rendering is done (present waits)
  };

  Swapchain(const Context& ctx, VkPresentModeKHR wanted, VkExtent2D size, std::uint32_t framesInFlight);
  ~Swapchain();
  Swapchain(const Swapchain&) = delete;
  Swapchain& operator=(const Swapchain&) = delete;

  /// Rebuilds for a new window size (waits for the device). Returns false for a zero size
  /// (minimised window): acquire() must not be called until a later recreate() succeeds.
  bool recreate(VkExtent2D size);
  /// Next image, or nullopt if the swapchain is out of date (recreate, then try again).
  std::optional<Frame> acquire();
  /// Returns false if the swapchain became out of date or suboptimal (recreate). `tag` names the
  /// present in takeShown() (the frame number).
  bool present(const Frame& f, std::uint64_t tag = 0);
  /// Whether presents are timed on screen (VK_KHR_present_wait); else takeShown() stays empty.
  bool timesDisplay() const { return timer_ != nullptr; }
  /// The presents shown on screen since the last call, oldest first, by tag.
  std::vector<PresentTimer::Shown> takeShown();
  /// Waits (at most `timeout`) for the display times of the presents queued so far.
  void settleDisplayTimes(std::chrono::milliseconds timeout);
  /// How present times are known here, for the timing log's header.
  std::string presentTimingNote() const;

  VkFormat format() const { return format_; }
  VkExtent2D extent() const { return extent_; }
  VkPresentModeKHR presentMode() const { return mode_; }
  std::uint32_t imageCount() const { return std::uint32_t(images_.size()); }
  std::uint32_t minImageCount() const { return minImages_; }
  VkImage image(std::uint32_t i) const { return images_.at(i); }
  VkRenderPass uiRenderPass() const { return renderPass_; }
  VkFramebuffer framebuffer(std::uint32_t i) const { return framebuffers_.at(i); }
  bool valid() const { return swapchain_ != VK_NULL_HANDLE; }

 private:
  void destroyImages();
  const Context& ctx_;
  VkPresentModeKHR wanted_, mode_ = VK_PRESENT_MODE_FIFO_KHR;
  VkSwapchainKHR swapchain_ = VK_NULL_HANDLE;
  VkFormat format_ = VK_FORMAT_UNDEFINED;
  VkColorSpaceKHR colorSpace_ = VK_COLOR_SPACE_SRGB_NONLINEAR_KHR;
  VkExtent2D extent_{0, 0};
  std::uint32_t minImages_ = 2;
  VkRenderPass renderPass_ = VK_NULL_HANDLE;
  std::vector<VkImage> images_;
  std::vector<VkImageView> views_;
  std::vector<VkFramebuffer> framebuffers_;
  std::vector<VkSemaphore> acquireSemaphores_, renderedSemaphores_;
  std::uint32_t nextAcquire_ = 0;
  bool warned_ = false;
  std::unique_ptr<PresentTimer> timer_;  ///< null without VK_KHR_present_wait
  std::uint64_t presentId_ = 0;
};

}  // namespace handson::vk
