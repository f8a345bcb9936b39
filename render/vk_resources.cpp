#include "vk_resources.h"

#include <cstring>
#include <mutex>
#include <unordered_map>
#include <sstream>

#include "sim/base/error.h"
#include "vk_context.h"

namespace handson::vk {

VkFormat toVkFormat(fg::Format f) {
  switch (f) {
    case fg::Format::R8Unorm: return VK_FORMAT_R8_UNORM;
    case fg::Format::R16Unorm: return VK_FORMAT_R16_UNORM;
    case fg::Format::R16Sfloat: return VK_FORMAT_R16_SFLOAT;
    case fg::Format::R32Sfloat: return VK_FORMAT_R32_SFLOAT;
    case fg::Format::R32Uint: return VK_FORMAT_R32_UINT;
    case fg::Format::Rgba8Unorm: return VK_FORMAT_R8G8B8A8_UNORM;
    case fg::Format::Rgba16Sfloat: return VK_FORMAT_R16G16B16A16_SFLOAT;
    case fg::Format::Rgba32Sfloat: return VK_FORMAT_R32G32B32A32_SFLOAT;
  }
  return VK_FORMAT_UNDEFINED;
}

std::uint32_t formatBytes(fg::Format f) {
  switch (f) {
    case fg::Format::R8Unorm: return 1;
    case fg::Format::R16Unorm:
    case fg::Format::R16Sfloat: return 2;
    case fg::Format::R32Sfloat:
    case fg::Format::R32Uint:
    case fg::Format::Rgba8Unorm: return 4;
    case fg::Format::Rgba16Sfloat: return 8;
    case fg::Format::Rgba32Sfloat: return 16;
  }
  return 0;
}

namespace {

// The live allocations, for deviceMemoryStats(): a map rather than counters kept by each owner, so
// that a free is matched to exactly the size allocated.
struct MemoryRegistry {
  std::mutex mutex;
  std::unordered_map<VkDeviceMemory, VkDeviceSize> live;
  std::int64_t liveBytes = 0;
  std::uint64_t total = 0;
};

MemoryRegistry& registry() {
  static MemoryRegistry r;
  return r;
}

VkDeviceMemory allocate(const Context& ctx, const VkMemoryRequirements& req, VkMemoryPropertyFlags want,
                        VkMemoryPropertyFlags* got) {
  VkMemoryAllocateInfo ai{VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO};
  ai.allocationSize = req.size;
  ai.memoryTypeIndex = ctx.findMemoryType(req.memoryTypeBits, want);
  if (got) *got = want;
  VkDeviceMemory mem = VK_NULL_HANDLE;
  check(ctx.injectedFault(FaultSite::AllocateMemory) ? VK_ERROR_OUT_OF_DEVICE_MEMORY
                                                     : vkAllocateMemory(ctx.device(), &ai, nullptr, &mem),
        "vkAllocateMemory");
  MemoryRegistry& r = registry();
  const std::lock_guard lock(r.mutex);
  r.live[mem] = req.size;
  r.liveBytes += std::int64_t(req.size);
  ++r.total;
  return mem;
}

void freeMemory(VkDevice device, VkDeviceMemory mem) {
  if (!mem) return;
  vkFreeMemory(device, mem, nullptr);
  MemoryRegistry& r = registry();
  const std::lock_guard lock(r.mutex);
  if (const auto it = r.live.find(mem); it != r.live.end()) {
    r.liveBytes -= std::int64_t(it->second);
    r.live.erase(it);
  }
}

}  // namespace

DeviceMemoryStats deviceMemoryStats() {
  MemoryRegistry& r = registry();
  const std::lock_guard lock(r.mutex);
  return {std::int64_t(r.live.size()), r.liveBytes, r.total};
}

// ---------------------------------------------------------------------------------------------- Buffer

Buffer::Buffer(const Context& ctx, VkDeviceSize size, VkBufferUsageFlags usage, Memory memory) : device_(ctx.device()), size_(size) {
  if (size == 0) throw Error("Vulkan: zero-sized buffer");
  VkBufferCreateInfo ci{VK_STRUCTURE_TYPE_BUFFER_CREATE_INFO};
  ci.size = size;
  ci.usage = usage;
  ci.sharingMode = VK_SHARING_MODE_EXCLUSIVE;
  check(vkCreateBuffer(device_, &ci, nullptr, &buffer_), "vkCreateBuffer");
  try {
    VkMemoryRequirements req;
    vkGetBufferMemoryRequirements(device_, buffer_, &req);
    if (memory == Memory::HostVisible) {
      try {
        memory_ = allocate(ctx, req, VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT | VK_MEMORY_PROPERTY_HOST_COHERENT_BIT, nullptr);
        coherent_ = true;
      } catch (const Error&) {
        memory_ = allocate(ctx, req, VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT, nullptr);
        coherent_ = false;
      }
    } else {
      memory_ = allocate(ctx, req, VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT, nullptr);
    }
    check(vkBindBufferMemory(device_, buffer_, memory_, 0), "vkBindBufferMemory");
    if (memory == Memory::HostVisible) check(vkMapMemory(device_, memory_, 0, VK_WHOLE_SIZE, 0, &mapped_), "vkMapMemory");
  } catch (...) {
    destroy();
    throw;
  }
}

Buffer::~Buffer() { destroy(); }

Buffer& Buffer::operator=(Buffer&& o) noexcept {
  if (this != &o) {
    destroy();
    device_ = take(o.device_);
    buffer_ = take(o.buffer_);
    memory_ = take(o.memory_);
    size_ = take(o.size_);
    mapped_ = take(o.mapped_);
    coherent_ = o.coherent_;
  }
  return *this;
}

void Buffer::destroy() {
  if (!device_) return;
  if (buffer_) vkDestroyBuffer(device_, buffer_, nullptr);
  freeMemory(device_, memory_);  // unmaps implicitly
  buffer_ = VK_NULL_HANDLE;
  memory_ = VK_NULL_HANDLE;
  mapped_ = nullptr;
}

void Buffer::invalidate() const {
  if (coherent_ || !mapped_) return;
  VkMappedMemoryRange r{VK_STRUCTURE_TYPE_MAPPED_MEMORY_RANGE};
  r.memory = memory_;
  r.size = VK_WHOLE_SIZE;
  vkInvalidateMappedMemoryRanges(device_, 1, &r);
}

void Buffer::flush() const {
  if (coherent_ || !mapped_) return;
  VkMappedMemoryRange r{VK_STRUCTURE_TYPE_MAPPED_MEMORY_RANGE};
  r.memory = memory_;
  r.size = VK_WHOLE_SIZE;
  vkFlushMappedMemoryRanges(device_, 1, &r);
}

// ----------------------------------------------------------------------------------------------- Image

Image::Image(const Context& ctx, const fg::ImageDesc& desc, VkImageUsageFlags usage, bool force3D)
    : device_(ctx.device()), desc_(desc), is3D_(force3D || desc.depth > 1) {
  const VkFormat format = toVkFormat(desc.format);
  const auto& lim = ctx.properties().limits;
  const std::uint32_t maxDim = is3D_ ? lim.maxImageDimension3D : lim.maxImageDimension2D;
  if (desc.width == 0 || desc.height == 0 || desc.depth == 0 || desc.width > maxDim || desc.height > maxDim ||
      desc.depth > maxDim) {
    std::ostringstream msg;
    msg << "Vulkan: image of " << desc.width << "x" << desc.height << "x" << desc.depth
        << " exceeds this device's limit of " << maxDim << " per dimension";
    throw Error(msg.str());
  }
  VkImageFormatProperties fp;
  VkResult r = vkGetPhysicalDeviceImageFormatProperties(ctx.physicalDevice(), format, is3D_ ? VK_IMAGE_TYPE_3D : VK_IMAGE_TYPE_2D,
                                                        VK_IMAGE_TILING_OPTIMAL, usage, 0, &fp);
  if (r == VK_ERROR_FORMAT_NOT_SUPPORTED) throw Error("Vulkan: image format/usage not supported on this device");
  check(r, "vkGetPhysicalDeviceImageFormatProperties");
  if ((usage & VK_IMAGE_USAGE_SAMPLED_BIT) && (desc.format == fg::Format::R16Unorm || desc.format == fg::Format::R8Unorm)) {
    VkFormatProperties p;
    vkGetPhysicalDeviceFormatProperties(ctx.physicalDevice(), format, &p);
    if (!(p.optimalTilingFeatures & VK_FORMAT_FEATURE_SAMPLED_IMAGE_FILTER_LINEAR_BIT))
      throw Error("Vulkan: linear filtering of the volume format is not supported on this device");
  }

  VkImageCreateInfo ci{VK_STRUCTURE_TYPE_IMAGE_CREATE_INFO};
  ci.imageType = is3D_ ? VK_IMAGE_TYPE_3D : VK_IMAGE_TYPE_2D;
  ci.format = format;
  ci.extent = {desc.width, desc.height, desc.depth};
  ci.mipLevels = 1;
  ci.arrayLayers = 1;
  ci.samples = VK_SAMPLE_COUNT_1_BIT;
  ci.tiling = VK_IMAGE_TILING_OPTIMAL;
  ci.usage = usage;
  ci.sharingMode = VK_SHARING_MODE_EXCLUSIVE;
  ci.initialLayout = VK_IMAGE_LAYOUT_UNDEFINED;
  check(vkCreateImage(device_, &ci, nullptr, &image_), "vkCreateImage");
  try {
    VkMemoryRequirements req;
    vkGetImageMemoryRequirements(device_, image_, &req);
    memory_ = allocate(ctx, req, VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT, nullptr);
    check(vkBindImageMemory(device_, image_, memory_, 0), "vkBindImageMemory");
    VkImageViewCreateInfo vi{VK_STRUCTURE_TYPE_IMAGE_VIEW_CREATE_INFO};
    vi.image = image_;
    vi.viewType = is3D_ ? VK_IMAGE_VIEW_TYPE_3D : VK_IMAGE_VIEW_TYPE_2D;
    vi.format = format;
    vi.subresourceRange = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 1, 0, 1};
    check(vkCreateImageView(device_, &vi, nullptr, &view_), "vkCreateImageView");
  } catch (...) {
    destroy();
    throw;
  }
}

Image::~Image() { destroy(); }

Image& Image::operator=(Image&& o) noexcept {
  if (this != &o) {
    destroy();
    device_ = take(o.device_);
    image_ = take(o.image_);
    view_ = take(o.view_);
    memory_ = take(o.memory_);
    desc_ = o.desc_;
    is3D_ = o.is3D_;
  }
  return *this;
}

void Image::destroy() {
  if (!device_) return;
  if (view_) vkDestroyImageView(device_, view_, nullptr);
  if (image_) vkDestroyImage(device_, image_, nullptr);
  freeMemory(device_, memory_);
  view_ = VK_NULL_HANDLE;
  image_ = VK_NULL_HANDLE;
  memory_ = VK_NULL_HANDLE;
}

// --------------------------------------------------------------------------------------------- Sampler

Sampler::Sampler(const Context& ctx, bool linear) : device_(ctx.device()) {
  VkSamplerCreateInfo ci{VK_STRUCTURE_TYPE_SAMPLER_CREATE_INFO};
  ci.magFilter = ci.minFilter = linear ? VK_FILTER_LINEAR : VK_FILTER_NEAREST;
  ci.mipmapMode = VK_SAMPLER_MIPMAP_MODE_NEAREST;
  ci.addressModeU = ci.addressModeV = ci.addressModeW = VK_SAMPLER_ADDRESS_MODE_CLAMP_TO_EDGE;
  ci.maxLod = 0.0f;
  check(vkCreateSampler(device_, &ci, nullptr, &sampler_), "vkCreateSampler");
}

Sampler::~Sampler() {
  if (device_ && sampler_) vkDestroySampler(device_, sampler_, nullptr);
}

Sampler& Sampler::operator=(Sampler&& o) noexcept {
  if (this != &o) {
    if (device_ && sampler_) vkDestroySampler(device_, sampler_, nullptr);
    device_ = take(o.device_);
    sampler_ = take(o.sampler_);
  }
  return *this;
}

// ------------------------------------------------------------------------------------- ComputePipeline

ComputePipeline::ComputePipeline(const Context& ctx, std::span<const std::uint32_t> spirv,
                                 const std::vector<VkDescriptorSetLayoutBinding>& bindings, std::uint32_t pushConstantBytes,
                                 const std::vector<std::uint32_t>& specialization)
    : device_(ctx.device()) {
  if (pushConstantBytes > ctx.properties().limits.maxPushConstantsSize)
    throw Error("Vulkan: push constants exceed the device limit");
  VkShaderModule module = VK_NULL_HANDLE;
  try {
    VkDescriptorSetLayoutCreateInfo dl{VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO};
    dl.flags = VK_DESCRIPTOR_SET_LAYOUT_CREATE_PUSH_DESCRIPTOR_BIT_KHR;
    dl.bindingCount = std::uint32_t(bindings.size());
    dl.pBindings = bindings.data();
    check(vkCreateDescriptorSetLayout(device_, &dl, nullptr, &setLayout_), "vkCreateDescriptorSetLayout");
    VkPushConstantRange pcr{VK_SHADER_STAGE_COMPUTE_BIT, 0, pushConstantBytes};
    VkPipelineLayoutCreateInfo pl{VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO};
    pl.setLayoutCount = 1;
    pl.pSetLayouts = &setLayout_;
    pl.pushConstantRangeCount = pushConstantBytes ? 1 : 0;
    pl.pPushConstantRanges = &pcr;
    check(vkCreatePipelineLayout(device_, &pl, nullptr, &layout_), "vkCreatePipelineLayout");
    VkShaderModuleCreateInfo sm{VK_STRUCTURE_TYPE_SHADER_MODULE_CREATE_INFO};
    sm.codeSize = spirv.size_bytes();
    sm.pCode = spirv.data();
    check(vkCreateShaderModule(device_, &sm, nullptr, &module), "vkCreateShaderModule");
    VkComputePipelineCreateInfo ci{VK_STRUCTURE_TYPE_COMPUTE_PIPELINE_CREATE_INFO};
    ci.stage = {VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO};
    ci.stage.stage = VK_SHADER_STAGE_COMPUTE_BIT;
    ci.stage.module = module;
    ci.stage.pName = "main";
    std::vector<VkSpecializationMapEntry> entries;
    for (std::uint32_t i = 0; i < specialization.size(); ++i) entries.push_back({i, i * 4, 4});
    const VkSpecializationInfo si{std::uint32_t(entries.size()), entries.data(), specialization.size() * 4, specialization.data()};
    if (!specialization.empty()) ci.stage.pSpecializationInfo = &si;
    ci.layout = layout_;
    check(vkCreateComputePipelines(device_, VK_NULL_HANDLE, 1, &ci, nullptr, &pipeline_), "vkCreateComputePipelines");
  } catch (...) {
    if (module) vkDestroyShaderModule(device_, module, nullptr);
    destroy();
    throw;
  }
  vkDestroyShaderModule(device_, module, nullptr);
}

ComputePipeline::~ComputePipeline() { destroy(); }

ComputePipeline& ComputePipeline::operator=(ComputePipeline&& o) noexcept {
  if (this != &o) {
    destroy();
    device_ = take(o.device_);
    setLayout_ = take(o.setLayout_);
    layout_ = take(o.layout_);
    pipeline_ = take(o.pipeline_);
  }
  return *this;
}

void ComputePipeline::destroy() {
  if (!device_) return;
  if (pipeline_) vkDestroyPipeline(device_, pipeline_, nullptr);
  if (layout_) vkDestroyPipelineLayout(device_, layout_, nullptr);
  if (setLayout_) vkDestroyDescriptorSetLayout(device_, setLayout_, nullptr);
  pipeline_ = VK_NULL_HANDLE;
  layout_ = VK_NULL_HANDLE;
  setLayout_ = VK_NULL_HANDLE;
}

// ------------------------------------------------------------------------------------ DescriptorWriter

DescriptorWriter& DescriptorWriter::buffer(std::uint32_t binding, VkDescriptorType type, VkBuffer buf, VkDeviceSize range) {
  buffers_.push_back({buf, 0, range});
  entries_.push_back({binding, type, int(buffers_.size() - 1), -1});
  return *this;
}

DescriptorWriter& DescriptorWriter::sampledImage(std::uint32_t binding, VkImageView view, VkSampler sampler, VkImageLayout layout) {
  images_.push_back({sampler, view, layout});
  entries_.push_back({binding, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, -1, int(images_.size() - 1)});
  return *this;
}

DescriptorWriter& DescriptorWriter::storageImage(std::uint32_t binding, VkImageView view) {
  images_.push_back({VK_NULL_HANDLE, view, VK_IMAGE_LAYOUT_GENERAL});
  entries_.push_back({binding, VK_DESCRIPTOR_TYPE_STORAGE_IMAGE, -1, int(images_.size() - 1)});
  return *this;
}

void DescriptorWriter::push(const Context& ctx, VkCommandBuffer cmd, const ComputePipeline& pipeline) {
  std::vector<VkWriteDescriptorSet> writes;
  writes.reserve(entries_.size());
  for (const auto& e : entries_) {
    VkWriteDescriptorSet w{VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET};
    w.dstBinding = e.binding;
    w.descriptorCount = 1;
    w.descriptorType = e.type;
    if (e.buffer >= 0) w.pBufferInfo = &buffers_[std::size_t(e.buffer)];
    if (e.image >= 0) w.pImageInfo = &images_[std::size_t(e.image)];
    writes.push_back(w);
  }
  ctx.cmdPushDescriptorSet(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, pipeline.layout(), 0, std::uint32_t(writes.size()), writes.data());
}

// ------------------------------------------------------------------------------------- copies, uploads

namespace {
VkBufferImageCopy wholeImageRegion(const Image& img) {
  VkBufferImageCopy r{};
  r.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
  r.imageExtent = {img.desc().width, img.desc().height, img.desc().depth};
  return r;
}
}  // namespace

void copyBufferToImage(VkCommandBuffer cmd, VkBuffer src, const Image& dst) {
  const VkBufferImageCopy r = wholeImageRegion(dst);
  vkCmdCopyBufferToImage(cmd, src, dst.handle(), VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, 1, &r);
}

void copyImageToBuffer(VkCommandBuffer cmd, const Image& src, VkBuffer dst) {
  const VkBufferImageCopy r = wholeImageRegion(src);
  vkCmdCopyImageToBuffer(cmd, src.handle(), VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, dst, 1, &r);
}

void transitionImage(VkCommandBuffer cmd, VkImage image, VkImageLayout from, VkImageLayout to) {
  VkImageMemoryBarrier2 b{VK_STRUCTURE_TYPE_IMAGE_MEMORY_BARRIER_2};
  b.srcStageMask = VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT;
  b.srcAccessMask = VK_ACCESS_2_MEMORY_WRITE_BIT;
  b.dstStageMask = VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT;
  b.dstAccessMask = VK_ACCESS_2_MEMORY_READ_BIT | VK_ACCESS_2_MEMORY_WRITE_BIT;
  b.oldLayout = from;
  b.newLayout = to;
  b.srcQueueFamilyIndex = b.dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
  b.image = image;
  b.subresourceRange = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 1, 0, 1};
  VkDependencyInfo dep{VK_STRUCTURE_TYPE_DEPENDENCY_INFO};
  dep.imageMemoryBarrierCount = 1;
  dep.pImageMemoryBarriers = &b;
  vkCmdPipelineBarrier2(cmd, &dep);
}

void uploadToBuffer(const Context& ctx, const Buffer& dst, const void* data, VkDeviceSize bytes) {
  Buffer staging(ctx, bytes, VK_BUFFER_USAGE_TRANSFER_SRC_BIT, Buffer::Memory::HostVisible);
  std::memcpy(staging.mapped(), data, bytes);
  staging.flush();
  ctx.submitAndWait([&](VkCommandBuffer cmd) {
    VkBufferCopy c{0, 0, bytes};
    vkCmdCopyBuffer(cmd, staging.handle(), dst.handle(), 1, &c);
    // The copy made available to whatever later work reads or overwrites the buffer (the fence
    // orders the host; this orders the device).
    memoryBarrier(cmd, VK_PIPELINE_STAGE_2_COPY_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT, VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT,
                  VK_ACCESS_2_MEMORY_READ_BIT | VK_ACCESS_2_MEMORY_WRITE_BIT);
  });
}

void downloadFromBuffer(const Context& ctx, const Buffer& src, void* dst, VkDeviceSize bytes) {
  Buffer host(ctx, bytes, VK_BUFFER_USAGE_TRANSFER_DST_BIT, Buffer::Memory::HostVisible);
  ctx.submitAndWait([&](VkCommandBuffer cmd) {
    // Earlier submissions (a frame's passes writing this buffer) finish their writes before the copy.
    memoryBarrier(cmd, VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT, VK_ACCESS_2_MEMORY_WRITE_BIT, VK_PIPELINE_STAGE_2_COPY_BIT, VK_ACCESS_2_TRANSFER_READ_BIT);
    VkBufferCopy c{0, 0, bytes};
    vkCmdCopyBuffer(cmd, src.handle(), host.handle(), 1, &c);
    memoryBarrier(cmd, VK_PIPELINE_STAGE_2_COPY_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT, VK_PIPELINE_STAGE_2_HOST_BIT, VK_ACCESS_2_HOST_READ_BIT);
  });
  host.invalidate();
  std::memcpy(dst, host.mapped(), bytes);
}

void memoryBarrier(VkCommandBuffer cmd, VkPipelineStageFlags2 srcStage, VkAccessFlags2 srcAccess, VkPipelineStageFlags2 dstStage,
                   VkAccessFlags2 dstAccess) {
  VkMemoryBarrier2 m{VK_STRUCTURE_TYPE_MEMORY_BARRIER_2};
  m.srcStageMask = srcStage;
  m.srcAccessMask = srcAccess;
  m.dstStageMask = dstStage;
  m.dstAccessMask = dstAccess;
  VkDependencyInfo dep{VK_STRUCTURE_TYPE_DEPENDENCY_INFO};
  dep.memoryBarrierCount = 1;
  dep.pMemoryBarriers = &m;
  vkCmdPipelineBarrier2(cmd, &dep);
}

void uploadToImage(const Context& ctx, const Image& dst, const void* data, VkDeviceSize bytes, VkImageLayout finalLayout) {
  Buffer staging(ctx, bytes, VK_BUFFER_USAGE_TRANSFER_SRC_BIT, Buffer::Memory::HostVisible);
  std::memcpy(staging.mapped(), data, bytes);
  staging.flush();
  ctx.submitAndWait([&](VkCommandBuffer cmd) {
    transitionImage(cmd, dst.handle(), VK_IMAGE_LAYOUT_UNDEFINED, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL);
    copyBufferToImage(cmd, staging.handle(), dst);
    transitionImage(cmd, dst.handle(), VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, finalLayout);
  });
}

void downloadFromImage(const Context& ctx, const Image& img, void* dst, VkDeviceSize bytes) {
  Buffer host(ctx, bytes, VK_BUFFER_USAGE_TRANSFER_DST_BIT, Buffer::Memory::HostVisible);
  ctx.submitAndWait([&](VkCommandBuffer cmd) {
    transitionImage(cmd, img.handle(), VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL);
    copyImageToBuffer(cmd, img, host.handle());
    transitionImage(cmd, img.handle(), VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL);
  });
  host.invalidate();
  std::memcpy(dst, host.mapped(), bytes);
}

}  // namespace handson::vk
