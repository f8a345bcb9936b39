#pragma once
// The window's swapchain: images, views, the UI render pass and framebuffers, acquire and present
// with their semaphores, recreation on resize. Present modes fifo (vsync), mailbox and immediate;
// an unsupported request falls back to fifo, which every driver has.
#include <vulkan/vulkan.h>

#include <optional>
#include <string>
#include <vector>

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
  /// Returns false if the swapchain became out of date or suboptimal (recreate).
  bool present(const Frame& f);

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
};

}  // namespace handson::vk
