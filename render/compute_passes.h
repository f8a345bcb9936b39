#pragma once
// The compute passes of the frame graph. Each pass owns its pipeline and adds itself to a graph
// by declaring what it reads and writes; the graph places the barriers. Implementations live in
// one file per pass (raymarch_pass.cpp, pick_pass.cpp, brick_pass.cpp).
#include "frame_graph.h"
#include "pass_resources.h"
#include "vk_resources.h"

namespace handson::vk {

class Context;
class GraphExecutor;

/// Resources shared by the raymarch and pick passes.
struct MarchInputs {
  fg::ResourceHandle params;     ///< uniform buffer, gpu::RenderParams
  fg::ResourceHandle volume;     ///< 3D R16_UNORM image, sampled
  fg::ResourceHandle tf;         ///< storage buffer, vec4[kTfEntries]
  fg::ResourceHandle occupancy;  ///< storage buffer, uint per brick
  fg::ResourceHandle mask;       ///< 3D R8_UNORM image of handle ids, sampled (texelFetch)
  fg::ResourceHandle handles;    ///< storage buffer, vec4 tint per handle id
  fg::ResourceHandle strain;     ///< 3D R32 float strain (raymarch only; a 1-voxel zero image when none)
  fg::ResourceHandle labels;     ///< 3D R16_UNORM organ labels (raymarch only; a 1-voxel zero image when none)
  fg::ResourceHandle overLimit;  ///< 3D R32 float strain over its tissue's limit (raymarch only; a 1-voxel zero image when none)
  fg::ResourceHandle jitter;     ///< storage buffer, uint[kJitterTile²] blue-noise ranks (raymarch only; render/blue_noise.h)
  fg::ResourceHandle accum;      ///< 2D RGBA32F storage image, a still frame's running sum (raymarch only; 1x1 when not accumulating)
};

/// Direct volume rendering into an RGBA8 storage image (shaders/raymarch.comp).
class RaymarchPass {
 public:
  explicit RaymarchPass(const Context& ctx);
  /// `nearest`: the strain, label and limit images' sampler (texelFetch only).
  /// `showOnly`: the frame only shows a complete still-frame sum (kFlagShowSum; no
  /// ray is marched), timed as "still-frame" rather than "raymarch" so that frame budgets do not
  /// take its time for a raymarch's.
  void add(fg::FrameGraph& graph, const MarchInputs& in, fg::ResourceHandle output, const Sampler& sampler, const Sampler& nearest,
           bool showOnly = false);

 private:
  const Context& ctx_;
  ComputePipeline pipeline_;
};

/// GPU depth picking of a list of NDC points (shaders/pick.comp).
class PickPass {
 public:
  explicit PickPass(const Context& ctx);
  /// points: storage buffer vec4[count] (xy = NDC); results: storage buffer gpu::PickResult[count].
  void add(fg::FrameGraph& graph, const MarchInputs& in, fg::ResourceHandle points, fg::ResourceHandle results,
           std::uint32_t count, const Sampler& sampler);

 private:
  const Context& ctx_;
  ComputePipeline pipeline_;
};

/// Per-brick min/max of the volume for empty-space skipping (shaders/brick_minmax.comp).
class BrickPass {
 public:
  explicit BrickPass(const Context& ctx);
  /// ranges: storage buffer uvec2[brick count].
  void add(fg::FrameGraph& graph, fg::ResourceHandle volume, fg::ResourceHandle ranges, const Image& volumeImage,
           const Sampler& sampler);

 private:
  const Context& ctx_;
  ComputePipeline pipeline_;
};

/// Copies an image or buffer into a host-visible buffer (a side-effect pass: never culled).
void addReadbackPass(fg::FrameGraph& graph, PassId id, fg::ResourceHandle src, fg::ResourceHandle hostBuffer);

/// The GraphExecutor behind an fg::Executor (passes are recorded only by the Vulkan backend).
GraphExecutor& vulkanExecutor(fg::Executor& e);

// Shared by the raymarch and pick passes (march_inputs.cpp).
std::vector<VkDescriptorSetLayoutBinding> marchBindingsFor(bool pick);
/// The inputs the raymarch and the pick share, each with its binding and access (`sampler` for
/// the volume and the mask).
PassResources marchResources(const MarchInputs& in, const Sampler& sampler);

}  // namespace handson::vk
