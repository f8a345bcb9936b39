// What the raymarch and pick passes share: their bindings, the inputs they declare to the frame
// graph and the descriptors they push.
#include "compute_passes.h"
#include "shaders/shared.h"
#include "sim/base/error.h"
#include "vk_context.h"
#include "vk_graph_executor.h"

namespace handson::vk {

GraphExecutor& vulkanExecutor(fg::Executor& e) {
  auto* x = dynamic_cast<GraphExecutor*>(&e);
  if (!x) throw Error("frame graph: a Vulkan pass was executed by a non-Vulkan executor");
  return *x;
}

namespace {
std::vector<VkDescriptorSetLayoutBinding> marchBindings(VkDescriptorType outputType, bool pickInput) {
  std::vector<VkDescriptorSetLayoutBinding> b = {
      {gpu::kBindParams, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 1, VK_SHADER_STAGE_COMPUTE_BIT, nullptr},
      {gpu::kBindVolume, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 1, VK_SHADER_STAGE_COMPUTE_BIT, nullptr},
      {gpu::kBindTf, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 1, VK_SHADER_STAGE_COMPUTE_BIT, nullptr},
      {gpu::kBindOccupancy, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 1, VK_SHADER_STAGE_COMPUTE_BIT, nullptr},
      {gpu::kBindOutput, outputType, 1, VK_SHADER_STAGE_COMPUTE_BIT, nullptr},
      {gpu::kBindMask, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 1, VK_SHADER_STAGE_COMPUTE_BIT, nullptr},
      {gpu::kBindHandles, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 1, VK_SHADER_STAGE_COMPUTE_BIT, nullptr},
  };
  if (pickInput) b.push_back({gpu::kBindPickInput, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 1, VK_SHADER_STAGE_COMPUTE_BIT, nullptr});
  else {
    b.push_back({gpu::kBindStrain, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 1, VK_SHADER_STAGE_COMPUTE_BIT, nullptr});
    b.push_back({gpu::kBindLabels, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 1, VK_SHADER_STAGE_COMPUTE_BIT, nullptr});
    b.push_back({gpu::kBindStrainLimit, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 1, VK_SHADER_STAGE_COMPUTE_BIT, nullptr});
    b.push_back({gpu::kBindJitter, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 1, VK_SHADER_STAGE_COMPUTE_BIT, nullptr});
    b.push_back({gpu::kBindAccum, VK_DESCRIPTOR_TYPE_STORAGE_IMAGE, 1, VK_SHADER_STAGE_COMPUTE_BIT, nullptr});
  }
  return b;
}
}  // namespace

std::vector<VkDescriptorSetLayoutBinding> marchBindingsFor(bool pick) {
  return marchBindings(pick ? VK_DESCRIPTOR_TYPE_STORAGE_BUFFER : VK_DESCRIPTOR_TYPE_STORAGE_IMAGE, pick);
}

PassResources marchResources(const MarchInputs& in, const Sampler& sampler) {
  PassResources r;
  r.buffer(gpu::kBindParams, in.params, fg::Access::StorageRead)
      .sampled(gpu::kBindVolume, in.volume, sampler)
      .buffer(gpu::kBindTf, in.tf, fg::Access::StorageRead)
      .buffer(gpu::kBindOccupancy, in.occupancy, fg::Access::StorageRead)
      .sampled(gpu::kBindMask, in.mask, sampler)
      .buffer(gpu::kBindHandles, in.handles, fg::Access::StorageRead);
  return r;
}

}  // namespace handson::vk
