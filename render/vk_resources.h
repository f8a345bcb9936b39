#pragma once
// Move-only RAII wrappers for the Vulkan objects the passes use: buffers, 2D/3D images with a view,
// samplers and compute pipelines with one push-descriptor set. Creation failures throw.
#include <vulkan/vulkan.h>

#include <cstdint>
#include <span>
#include <utility>
#include <vector>

#include "frame_graph.h"

namespace handson::vk {

class Context;

VkFormat toVkFormat(fg::Format f);
std::uint32_t formatBytes(fg::Format f);

/// Device memory allocated through Buffer and Image, across every context of this process: what a
/// soak watches for growth (`handson soak`).
struct DeviceMemoryStats {
  std::int64_t liveAllocations = 0;   ///< vkAllocateMemory calls not yet freed
  std::int64_t liveBytes = 0;         ///< their total size
  std::uint64_t totalAllocations = 0; ///< every vkAllocateMemory call so far
};
DeviceMemoryStats deviceMemoryStats();

/// Moves a handle out, leaving the null handle behind (for move constructors).
template <class T> T take(T& h) { return std::exchange(h, T{}); }

class Buffer {
 public:
  enum class Memory { Device, HostVisible };
  Buffer() = default;
  Buffer(const Context& ctx, VkDeviceSize size, VkBufferUsageFlags usage, Memory memory);
  ~Buffer();
  Buffer(Buffer&& o) noexcept { *this = std::move(o); }
  Buffer& operator=(Buffer&& o) noexcept;
  Buffer(const Buffer&) = delete;
  Buffer& operator=(const Buffer&) = delete;

  VkBuffer handle() const { return buffer_; }
  VkDeviceSize size() const { return size_; }
  /// Host pointer (HostVisible only). Coherent memory is preferred; invalidate() covers the rest.
  void* mapped() const { return mapped_; }
  void invalidate() const;
  void flush() const;

 private:
  void destroy();
  VkDevice device_ = VK_NULL_HANDLE;
  VkBuffer buffer_ = VK_NULL_HANDLE;
  VkDeviceMemory memory_ = VK_NULL_HANDLE;
  VkDeviceSize size_ = 0;
  void* mapped_ = nullptr;
  bool coherent_ = true;
};

class Image {
 public:
  Image() = default;
  /// A 2D image if depth == 1 and !force3D, else 3D. Checks format support and size limits.
  Image(const Context& ctx, const fg::ImageDesc& desc, VkImageUsageFlags usage, bool force3D = false);
  ~Image();
  Image(Image&& o) noexcept { *this = std::move(o); }
  Image& operator=(Image&& o) noexcept;
  Image(const Image&) = delete;
  Image& operator=(const Image&) = delete;

  VkImage handle() const { return image_; }
  VkImageView view() const { return view_; }
  const fg::ImageDesc& desc() const { return desc_; }
  bool is3D() const { return is3D_; }

 private:
  void destroy();
  VkDevice device_ = VK_NULL_HANDLE;
  VkImage image_ = VK_NULL_HANDLE;
  VkImageView view_ = VK_NULL_HANDLE;
  VkDeviceMemory memory_ = VK_NULL_HANDLE;
  fg::ImageDesc desc_{};
  bool is3D_ = false;
};

class Sampler {
 public:
  Sampler() = default;
  /// Linear (or nearest) filtering, clamp to edge, no mipmaps.
  Sampler(const Context& ctx, bool linear);
  ~Sampler();
  Sampler(Sampler&& o) noexcept { *this = std::move(o); }
  Sampler& operator=(Sampler&& o) noexcept;
  Sampler(const Sampler&) = delete;
  Sampler& operator=(const Sampler&) = delete;
  VkSampler handle() const { return sampler_; }

 private:
  VkDevice device_ = VK_NULL_HANDLE;
  VkSampler sampler_ = VK_NULL_HANDLE;
};

/// A compute pipeline whose set 0 is a push-descriptor set.
class ComputePipeline {
 public:
  ComputePipeline() = default;
  /// `specialization[i]` is the value of the shader's `constant_id = i` (32-bit constants).
  ComputePipeline(const Context& ctx, std::span<const std::uint32_t> spirv,
                  const std::vector<VkDescriptorSetLayoutBinding>& bindings, std::uint32_t pushConstantBytes,
                  const std::vector<std::uint32_t>& specialization = {});
  ~ComputePipeline();
  ComputePipeline(ComputePipeline&& o) noexcept { *this = std::move(o); }
  ComputePipeline& operator=(ComputePipeline&& o) noexcept;
  ComputePipeline(const ComputePipeline&) = delete;
  ComputePipeline& operator=(const ComputePipeline&) = delete;

  VkPipeline pipeline() const { return pipeline_; }
  VkPipelineLayout layout() const { return layout_; }

 private:
  void destroy();
  VkDevice device_ = VK_NULL_HANDLE;
  VkDescriptorSetLayout setLayout_ = VK_NULL_HANDLE;
  VkPipelineLayout layout_ = VK_NULL_HANDLE;
  VkPipeline pipeline_ = VK_NULL_HANDLE;
};

/// Descriptor writes for a push-descriptor set, built fluently and pushed with one call.
class DescriptorWriter {
 public:
  DescriptorWriter& buffer(std::uint32_t binding, VkDescriptorType type, VkBuffer buffer, VkDeviceSize range = VK_WHOLE_SIZE);
  DescriptorWriter& sampledImage(std::uint32_t binding, VkImageView view, VkSampler sampler, VkImageLayout layout);
  DescriptorWriter& storageImage(std::uint32_t binding, VkImageView view);
  void push(const Context& ctx, VkCommandBuffer cmd, const ComputePipeline& pipeline);

 private:
  std::vector<VkDescriptorBufferInfo> buffers_;
  std::vector<VkDescriptorImageInfo> images_;
  struct Entry {
    std::uint32_t binding;
    VkDescriptorType type;
    int buffer = -1, image = -1;
  };
  std::vector<Entry> entries_;
};

/// Records a buffer -> image copy of a whole image (tightly packed).
void copyBufferToImage(VkCommandBuffer cmd, VkBuffer src, const Image& dst);
/// Records an image -> buffer copy of a whole image (tightly packed).
void copyImageToBuffer(VkCommandBuffer cmd, const Image& src, VkBuffer dst);
/// Records one global memory dependency (for command sequences recorded outside the graph).
void memoryBarrier(VkCommandBuffer cmd, VkPipelineStageFlags2 srcStage, VkAccessFlags2 srcAccess, VkPipelineStageFlags2 dstStage,
                   VkAccessFlags2 dstAccess);
/// Records a single image layout transition with a full barrier (for uploads outside the graph).
void transitionImage(VkCommandBuffer cmd, VkImage image, VkImageLayout from, VkImageLayout to);

/// Uploads bytes to a device-local buffer or image through a staging buffer, waiting for completion.
void uploadToBuffer(const Context& ctx, const Buffer& dst, const void* data, VkDeviceSize bytes);
/// Copies the first `bytes` of a device buffer to host memory, waiting for completion.
void downloadFromBuffer(const Context& ctx, const Buffer& src, void* dst, VkDeviceSize bytes);
/// Uploads a whole image, leaving it in `finalLayout`.
void uploadToImage(const Context& ctx, const Image& dst, const void* data, VkDeviceSize bytes, VkImageLayout finalLayout);
/// Reads a whole image (in SHADER_READ_ONLY_OPTIMAL layout, left so) into `dst`, synchronously.
void downloadFromImage(const Context& ctx, const Image& img, void* dst, VkDeviceSize bytes);

}  // namespace handson::vk
