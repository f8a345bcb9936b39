#include "compute_passes.h"
#include "shaders/shared.h"
#include "shaders/spirv.h"
#include "vk_context.h"
#include "vk_graph_executor.h"

namespace handson::vk {

PickPass::PickPass(const Context& ctx) : ctx_(ctx), pipeline_(ctx, shaders::pick(), marchBindingsFor(true), 0) {}

void PickPass::add(fg::FrameGraph& graph, const MarchInputs& in, fg::ResourceHandle points, fg::ResourceHandle results,
                   std::uint32_t count, const Sampler& sampler) {
  const PassResources r = marchResources(in, sampler)
                              .buffer(gpu::kBindPickInput, points, fg::Access::StorageRead)
                              .buffer(gpu::kBindOutput, results, fg::Access::StorageWrite);
  graph.addPass(
      PassId::Pick, [&](fg::PassBuilder& b) { r.declare(b); },
      [this, r, count](fg::Executor& e) {
        GraphExecutor& x = vulkanExecutor(e);
        vkCmdBindPipeline(x.cmd(), VK_PIPELINE_BIND_POINT_COMPUTE, pipeline_.pipeline());
        r.push(ctx_, x, pipeline_);
        vkCmdDispatch(x.cmd(), (count + gpu::kPickGroupX - 1) / gpu::kPickGroupX, 1, 1);
      });
}

void addReadbackPass(fg::FrameGraph& graph, PassId id, fg::ResourceHandle src, fg::ResourceHandle hostBuffer) {
  const bool isImage = graph.resource(src).kind == fg::ResourceKind::Image;
  graph.addPass(
      id,
      [&](fg::PassBuilder& b) {
        b.read(src, fg::Access::TransferSrc);
        b.write(hostBuffer, fg::Access::TransferDst);
        b.sideEffect();
      },
      [src, hostBuffer, isImage](fg::Executor& e) {
        GraphExecutor& x = vulkanExecutor(e);
        if (isImage) {
          copyImageToBuffer(x.cmd(), x.image(src), x.buffer(hostBuffer).handle());
        } else {
          const VkBufferCopy c{0, 0, std::min(x.buffer(src).size(), x.buffer(hostBuffer).size())};
          vkCmdCopyBuffer(x.cmd(), x.buffer(src).handle(), x.buffer(hostBuffer).handle(), 1, &c);
        }
      });
  graph.exportResource(hostBuffer, fg::Access::HostRead);
}

}  // namespace handson::vk
