#pragma once
// A compute pass's resources, each named once: its shader binding (shaders/shared.h), the graph
// resource and how the pass uses it. `declare` gives the frame graph the pass's reads and writes
// (hence its barriers) and `push` writes the pass's descriptors, both from the same list, so a
// resource cannot be bound without being declared or declared with another access than it is bound
// for.
//
//   const PassResources r = PassResources()
//       .buffer(gpu::kBindParams, in.params, fg::Access::StorageRead)
//       .sampled(gpu::kBindVolume, in.volume, linear)
//       .storageImage(gpu::kBindOutput, output, fg::Access::StorageWrite);
//   graph.addPass(PassId::Raymarch, [&](fg::PassBuilder& b) { r.declare(b); },
//                 [r, ...](fg::Executor& e) { ...bind the pipeline; r.push(ctx, x, pipeline); dispatch... });
#include <vulkan/vulkan.h>

#include <cstdint>
#include <vector>

#include "frame_graph.h"

namespace handson::vk {

class Context;
class ComputePipeline;
class GraphExecutor;
class Sampler;

class PassResources {
 public:
  /// A storage buffer at `binding`, used as `access` (a read, or a write: StorageWrite,
  /// StorageReadWrite).
  PassResources& buffer(std::uint32_t binding, fg::ResourceHandle h, fg::Access access);
  /// An image read through `sampler` at `binding` (fg::Access::Sampled, shader-read-only layout).
  PassResources& sampled(std::uint32_t binding, fg::ResourceHandle h, const Sampler& sampler);
  /// A storage image at `binding` (general layout), used as `access`.
  PassResources& storageImage(std::uint32_t binding, fg::ResourceHandle h, fg::Access access);
  /// One more use of a resource with no descriptor of its own (a buffer of indirect dispatch
  /// arguments, bound as a storage buffer too).
  PassResources& use(fg::ResourceHandle h, fg::Access access);

  /// The pass's reads and writes, in the order named.
  void declare(fg::PassBuilder& b) const;
  /// The pass's descriptors, pushed for `pipeline` on the executor's command buffer.
  void push(const Context& ctx, const GraphExecutor& x, const ComputePipeline& pipeline) const;

 private:
  enum class Kind : std::uint8_t { Buffer, Sampled, StorageImage, UseOnly };
  struct Entry {
    Kind kind;
    std::uint32_t binding;
    fg::ResourceHandle handle;
    fg::Access access;
    VkSampler sampler;
  };
  std::vector<Entry> entries_;
};

}  // namespace handson::vk
