#include "vk_swapchain.h"

#include <algorithm>
#include <iostream>

#include "sim/base/error.h"
#include "vk_context.h"

namespace handson::vk {

VkPresentModeKHR parsePresentMode(const std::string& name) {
  if (name == "fifo") return VK_PRESENT_MODE_FIFO_KHR;
  if (name == "mailbox") return VK_PRESENT_MODE_MAILBOX_KHR;
  if (name == "immediate") return VK_PRESENT_MODE_IMMEDIATE_KHR;
  throw Error("unknown present mode '" + name + "' (fifo, mailbox or immediate)");
}

const char* presentModeName(VkPresentModeKHR m) {
  switch (m) {
    case VK_PRESENT_MODE_FIFO_KHR: return "fifo";
    case VK_PRESENT_MODE_MAILBOX_KHR: return "mailbox";
    case VK_PRESENT_MODE_IMMEDIATE_KHR: return "immediate";
    case VK_PRESENT_MODE_FIFO_RELAXED_KHR: return "fifo-relaxed";
    default: return "other";
  }
}

Swapchain::Swapchain(const Context& ctx, VkPresentModeKHR wanted, VkExtent2D size, std::uint32_t framesInFlight)
    : ctx_(ctx), wanted_(wanted) {
  if (!ctx.surface()) throw Error("Vulkan: swapchain without a surface");
  VkDevice dev = ctx.device();
  // Format: 8-bit UNORM BGRA or RGBA (the raymarch writes display-ready values).
  std::uint32_t n = 0;
  vkGetPhysicalDeviceSurfaceFormatsKHR(ctx.physicalDevice(), ctx.surface(), &n, nullptr);
  std::vector<VkSurfaceFormatKHR> formats(n);
  vkGetPhysicalDeviceSurfaceFormatsKHR(ctx.physicalDevice(), ctx.surface(), &n, formats.data());
  if (formats.empty()) throw Error("Vulkan: the window surface offers no formats");
  format_ = formats[0].format;
  colorSpace_ = formats[0].colorSpace;
  for (const auto& f : formats)
    if (f.format == VK_FORMAT_B8G8R8A8_UNORM || f.format == VK_FORMAT_R8G8B8A8_UNORM) {
      format_ = f.format;
      colorSpace_ = f.colorSpace;
      break;
    }
  VkAttachmentDescription att{};
  att.format = format_;
  att.samples = VK_SAMPLE_COUNT_1_BIT;
  att.loadOp = VK_ATTACHMENT_LOAD_OP_LOAD;
  att.storeOp = VK_ATTACHMENT_STORE_OP_STORE;
  att.stencilLoadOp = VK_ATTACHMENT_LOAD_OP_DONT_CARE;
  att.stencilStoreOp = VK_ATTACHMENT_STORE_OP_DONT_CARE;
  att.initialLayout = VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL;  // the frame graph transitions it
  att.finalLayout = VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL;
  VkAttachmentReference ref{0, VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL};
  VkSubpassDescription sub{};
  sub.pipelineBindPoint = VK_PIPELINE_BIND_POINT_GRAPHICS;
  sub.colorAttachmentCount = 1;
  sub.pColorAttachments = &ref;
  VkRenderPassCreateInfo rp{VK_STRUCTURE_TYPE_RENDER_PASS_CREATE_INFO};
  rp.attachmentCount = 1;
  rp.pAttachments = &att;
  rp.subpassCount = 1;
  rp.pSubpasses = &sub;
  check(vkCreateRenderPass(dev, &rp, nullptr, &renderPass_), "vkCreateRenderPass");
  VkSemaphoreCreateInfo sci{VK_STRUCTURE_TYPE_SEMAPHORE_CREATE_INFO};
  acquireSemaphores_.resize(framesInFlight + 1);
  for (auto& s : acquireSemaphores_) check(vkCreateSemaphore(dev, &sci, nullptr, &s), "vkCreateSemaphore");
  if (ctx.presentWait()) {
    const PFN_vkWaitForPresentKHR waitFn = ctx.waitForPresent;
    timer_ = std::make_unique<PresentTimer>([dev, waitFn](VkSwapchainKHR sc, std::uint64_t id, std::uint64_t timeoutNs) {
      return waitFn(dev, sc, id, timeoutNs);
    });
  }
  recreate(size);
}

Swapchain::~Swapchain() {
  VkDevice dev = ctx_.device();
  vkDeviceWaitIdle(dev);
  if (timer_) timer_->drain(std::chrono::milliseconds(200));
  destroyImages();
  if (swapchain_) vkDestroySwapchainKHR(dev, swapchain_, nullptr);
  for (auto s : acquireSemaphores_) vkDestroySemaphore(dev, s, nullptr);
  if (renderPass_) vkDestroyRenderPass(dev, renderPass_, nullptr);
}

void Swapchain::destroyImages() {
  VkDevice dev = ctx_.device();
  for (auto f : framebuffers_) vkDestroyFramebuffer(dev, f, nullptr);
  for (auto v : views_) vkDestroyImageView(dev, v, nullptr);
  for (auto s : renderedSemaphores_) vkDestroySemaphore(dev, s, nullptr);
  framebuffers_.clear();
  views_.clear();
  renderedSemaphores_.clear();
  images_.clear();
}

bool Swapchain::recreate(VkExtent2D size) {
  VkDevice dev = ctx_.device();
  vkDeviceWaitIdle(dev);
  // The waiter lets go of the swapchain before it is retired (oldSwapchain below) or destroyed.
  if (timer_) timer_->drain(std::chrono::milliseconds(200));
  VkSurfaceCapabilitiesKHR caps;
  check(vkGetPhysicalDeviceSurfaceCapabilitiesKHR(ctx_.physicalDevice(), ctx_.surface(), &caps), "vkGetPhysicalDeviceSurfaceCapabilitiesKHR");
  VkExtent2D extent = caps.currentExtent.width != UINT32_MAX ? caps.currentExtent : size;
  extent.width = std::clamp(extent.width, caps.minImageExtent.width, caps.maxImageExtent.width);
  extent.height = std::clamp(extent.height, caps.minImageExtent.height, caps.maxImageExtent.height);
  if (extent.width == 0 || extent.height == 0 || size.width == 0 || size.height == 0) {
    extent_ = {0, 0};
    return false;
  }
  std::uint32_t n = 0;
  vkGetPhysicalDeviceSurfacePresentModesKHR(ctx_.physicalDevice(), ctx_.surface(), &n, nullptr);
  std::vector<VkPresentModeKHR> modes(n);
  vkGetPhysicalDeviceSurfacePresentModesKHR(ctx_.physicalDevice(), ctx_.surface(), &n, modes.data());
  const bool supported = std::find(modes.begin(), modes.end(), wanted_) != modes.end();
  if (!supported && !warned_) {
    std::cerr << "warning: present mode " << presentModeName(wanted_) << " is not supported here; using fifo\n";
    warned_ = true;
  }
  mode_ = supported ? wanted_ : VK_PRESENT_MODE_FIFO_KHR;
  const VkImageUsageFlags usage = VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT | VK_IMAGE_USAGE_TRANSFER_DST_BIT |
                                  (caps.supportedUsageFlags & VK_IMAGE_USAGE_TRANSFER_SRC_BIT);
  minImages_ = std::max(caps.minImageCount + 1, 2u);
  if (caps.maxImageCount) minImages_ = std::min(minImages_, caps.maxImageCount);
  VkSwapchainCreateInfoKHR ci{VK_STRUCTURE_TYPE_SWAPCHAIN_CREATE_INFO_KHR};
  ci.surface = ctx_.surface();
  ci.minImageCount = minImages_;
  ci.imageFormat = format_;
  ci.imageColorSpace = colorSpace_;
  ci.imageExtent = extent;
  ci.imageArrayLayers = 1;
  ci.imageUsage = usage;
  ci.imageSharingMode = VK_SHARING_MODE_EXCLUSIVE;
  ci.preTransform = caps.currentTransform;
  ci.compositeAlpha = (caps.supportedCompositeAlpha & VK_COMPOSITE_ALPHA_OPAQUE_BIT_KHR) ? VK_COMPOSITE_ALPHA_OPAQUE_BIT_KHR
                                                                                          : VkCompositeAlphaFlagBitsKHR(caps.supportedCompositeAlpha & -caps.supportedCompositeAlpha);
  ci.presentMode = mode_;
  ci.clipped = VK_TRUE;
  ci.oldSwapchain = swapchain_;
  VkSwapchainKHR created = VK_NULL_HANDLE;
  check(vkCreateSwapchainKHR(dev, &ci, nullptr, &created), "vkCreateSwapchainKHR");
  destroyImages();
  if (swapchain_) vkDestroySwapchainKHR(dev, swapchain_, nullptr);
  swapchain_ = created;
  extent_ = extent;
  check(vkGetSwapchainImagesKHR(dev, swapchain_, &n, nullptr), "vkGetSwapchainImagesKHR");
  images_.resize(n);
  check(vkGetSwapchainImagesKHR(dev, swapchain_, &n, images_.data()), "vkGetSwapchainImagesKHR");
  VkSemaphoreCreateInfo sci{VK_STRUCTURE_TYPE_SEMAPHORE_CREATE_INFO};
  for (VkImage img : images_) {
    VkImageViewCreateInfo vi{VK_STRUCTURE_TYPE_IMAGE_VIEW_CREATE_INFO};
    vi.image = img;
    vi.viewType = VK_IMAGE_VIEW_TYPE_2D;
    vi.format = format_;
    vi.subresourceRange = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 1, 0, 1};
    VkImageView view;
    check(vkCreateImageView(dev, &vi, nullptr, &view), "vkCreateImageView");
    views_.push_back(view);
    VkFramebufferCreateInfo fi{VK_STRUCTURE_TYPE_FRAMEBUFFER_CREATE_INFO};
    fi.renderPass = renderPass_;
    fi.attachmentCount = 1;
    fi.pAttachments = &view;
    fi.width = extent.width;
    fi.height = extent.height;
    fi.layers = 1;
    VkFramebuffer fb;
    check(vkCreateFramebuffer(dev, &fi, nullptr, &fb), "vkCreateFramebuffer");
    framebuffers_.push_back(fb);
    VkSemaphore s;
    check(vkCreateSemaphore(dev, &sci, nullptr, &s), "vkCreateSemaphore");
    renderedSemaphores_.push_back(s);
  }
  return true;
}

std::optional<Swapchain::Frame> Swapchain::acquire() {
  if (!swapchain_ || extent_.width == 0) return std::nullopt;
  VkSemaphore sem = acquireSemaphores_[nextAcquire_];
  std::uint32_t index = 0;
  const VkResult r = vkAcquireNextImageKHR(ctx_.device(), swapchain_, UINT64_MAX, sem, VK_NULL_HANDLE, &index);
  if (r == VK_ERROR_OUT_OF_DATE_KHR) return std::nullopt;
  if (r != VK_SUBOPTIMAL_KHR) check(r, "vkAcquireNextImageKHR");
  nextAcquire_ = (nextAcquire_ + 1) % std::uint32_t(acquireSemaphores_.size());
  return Frame{index, sem, renderedSemaphores_[index]};
}

bool Swapchain::present(const Frame& f, std::uint64_t tag) {
  VkPresentInfoKHR pi{VK_STRUCTURE_TYPE_PRESENT_INFO_KHR};
  const std::uint64_t id = presentId_ + 1;
  VkPresentIdKHR pid{VK_STRUCTURE_TYPE_PRESENT_ID_KHR};
  pid.swapchainCount = 1;
  pid.pPresentIds = &id;
  if (timer_) pi.pNext = &pid;
  pi.waitSemaphoreCount = 1;
  pi.pWaitSemaphores = &f.rendered;
  pi.swapchainCount = 1;
  pi.pSwapchains = &swapchain_;
  pi.pImageIndices = &f.image;
  const VkResult r = vkQueuePresentKHR(ctx_.queue(), &pi);
  if (timer_ && (r == VK_SUCCESS || r == VK_SUBOPTIMAL_KHR)) {
    presentId_ = id;
    timer_->presented(swapchain_, id, tag);
  }
  if (r == VK_ERROR_OUT_OF_DATE_KHR || r == VK_SUBOPTIMAL_KHR) return false;
  check(r, "vkQueuePresentKHR");
  return true;
}

std::vector<PresentTimer::Shown> Swapchain::takeShown() { return timer_ ? timer_->takeShown() : std::vector<PresentTimer::Shown>{}; }

void Swapchain::settleDisplayTimes(std::chrono::milliseconds timeout) {
  if (timer_) timer_->drain(timeout);
}

std::string Swapchain::presentTimingNote() const {
  if (timer_)
    return "displayed_s is when vkWaitForPresentKHR reported the frame shown (VK_KHR_present_wait); present_s is when vkQueuePresentKHR returned";
  return "display time not measured: this driver offers no VK_KHR_present_wait, so displayed_s is -1 and present_s is when vkQueuePresentKHR returned";
}

}  // namespace handson::vk
