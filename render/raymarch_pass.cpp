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
  graph.addPass(
      showOnly ? PassId::StillFrame : PassId::Raymarch,
      [&](fg::PassBuilder& b) {
        declareMarchInputs(b, in);
        b.read(in.strain, fg::Access::Sampled);
        b.read(in.labels, fg::Access::Sampled);
        b.read(in.overLimit, fg::Access::Sampled);
        b.read(in.jitter, fg::Access::StorageRead);
        b.write(in.accum, fg::Access::StorageReadWrite);
        b.write(output, fg::Access::StorageWrite);
      },
      [this, in, output, desc, &sampler, &nearest](fg::Executor& e) {
        GraphExecutor& x = vulkanExecutor(e);
        vkCmdBindPipeline(x.cmd(), VK_PIPELINE_BIND_POINT_COMPUTE, pipeline_.pipeline());
        marchDescriptors(x, in, sampler)
            .storageImage(gpu::kBindOutput, x.image(output).view())
            .sampledImage(gpu::kBindStrain, x.image(in.strain).view(), nearest.handle(), VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL)
            .sampledImage(gpu::kBindLabels, x.image(in.labels).view(), nearest.handle(), VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL)
            .sampledImage(gpu::kBindStrainLimit, x.image(in.overLimit).view(), nearest.handle(), VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL)
            .buffer(gpu::kBindJitter, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, x.buffer(in.jitter).handle())
            .storageImage(gpu::kBindAccum, x.image(in.accum).view())
            .push(ctx_, x.cmd(), pipeline_);
        vkCmdDispatch(x.cmd(), (desc.width + gpu::kRaymarchGroupX - 1) / gpu::kRaymarchGroupX,
                      (desc.height + gpu::kRaymarchGroupY - 1) / gpu::kRaymarchGroupY, 1);
      });
}

}  // namespace handson::vk
