#include "compute_passes.h"
#include "shaders/shared.h"
#include "shaders/spirv.h"
#include "sim/base/error.h"
#include "vk_context.h"
#include "vk_graph_executor.h"

namespace handson::vk {

RaymarchPass::RaymarchPass(const Context& ctx) : ctx_(ctx), pipeline_(ctx, shaders::raymarch(), marchBindingsFor(false), 0) {}

void RaymarchPass::add(fg::FrameGraph& graph, const MarchInputs& in, fg::ResourceHandle output, const Sampler& sampler, const Sampler& nearest,
                       bool showOnly) {
  if (!in.strain.valid() || !in.labels.valid() || !in.overLimit.valid() || !in.jitter.valid() || !in.accum.valid())
    throw Error("raymarch: no strain, label, limit or accumulation image or jitter tile (bind a small one when there is none)");
  const fg::ImageDesc desc = graph.resource(output).image;
  const PassResources r = marchResources(in, sampler)
                              .sampled(gpu::kBindStrain, in.strain, nearest)
                              .sampled(gpu::kBindLabels, in.labels, nearest)
                              .sampled(gpu::kBindStrainLimit, in.overLimit, nearest)
                              .buffer(gpu::kBindJitter, in.jitter, fg::Access::StorageRead)
                              .storageImage(gpu::kBindAccum, in.accum, fg::Access::StorageReadWrite)
                              .storageImage(gpu::kBindOutput, output, fg::Access::StorageWrite);
  graph.addPass(
      showOnly ? PassId::StillFrame : PassId::Raymarch, [&](fg::PassBuilder& b) { r.declare(b); },
      [this, r, desc](fg::Executor& e) {
        GraphExecutor& x = vulkanExecutor(e);
        vkCmdBindPipeline(x.cmd(), VK_PIPELINE_BIND_POINT_COMPUTE, pipeline_.pipeline());
        r.push(ctx_, x, pipeline_);
        vkCmdDispatch(x.cmd(), (desc.width + gpu::kRaymarchGroupX - 1) / gpu::kRaymarchGroupX,
                      (desc.height + gpu::kRaymarchGroupY - 1) / gpu::kRaymarchGroupY, 1);
      });
}

}  // namespace handson::vk
