#pragma once
// Descriptor types and set layouts shared by the deformation passes (deform_*_pass.cpp); the
// binding numbers are named in shaders/shared.h.
#include <vulkan/vulkan.h>

#include <cstdint>
#include <initializer_list>
#include <utility>
#include <vector>

namespace handson::vk::deform {

inline VkDescriptorSetLayoutBinding binding(std::uint32_t b, VkDescriptorType type) { return {b, type, 1, VK_SHADER_STAGE_COMPUTE_BIT, nullptr}; }
// The parameters are a read-only storage buffer, not a uniform buffer: lavapipe (Mesa 22.3) inlines
// uniform-buffer values that steer loops into the shader and compiles a new variant every time the
// buffer is bound — every frame — keeping each one until the device is destroyed.
constexpr VkDescriptorType kParams = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
constexpr VkDescriptorType kSsbo = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
constexpr VkDescriptorType kSampled = VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER;
constexpr VkDescriptorType kStorageImage = VK_DESCRIPTOR_TYPE_STORAGE_IMAGE;

/// A push-descriptor set layout from (binding, type) pairs; the bindings are named in shaders/shared.h.
inline std::vector<VkDescriptorSetLayoutBinding> bindings(std::initializer_list<std::pair<std::uint32_t, VkDescriptorType>> slots) {
  std::vector<VkDescriptorSetLayoutBinding> out;
  for (const auto& [b, t] : slots) out.push_back(binding(b, t));
  return out;
}

}  // namespace handson::vk::deform
