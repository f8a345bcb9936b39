#include "compute_passes.h"
#include "shaders/shared.h"
#include "shaders/spirv.h"
#include "vk_context.h"
#include "vk_graph_executor.h"

namespace handson::vk {

PickPass::PickPass(const Context& ctx) : ctx_(ctx), pipeline_(ctx, shaders::pick(), marchBindingsFor(true), 0) {}

void PickPass::add(fg::FrameGraph& graph, const MarchInputs& in, fg::ResourceHandle points, fg::ResourceHandle results,
                   std::uint32_t count, const Sampler& sampler) {
  graph.addPass(
      PassId::Pick,
      [&](fg::PassBuilder& b) {
        declareMarchInputs(b, in);
        b.read(points, fg::Access::StorageRead);
        b.write(results, fg::Access::StorageWrite);
      },
      [this, in, points, results, count, &sampler](fg::Executor& e) {
        GraphExecutor& x = vulkanExecutor(e);
        vkCmdBindPipeline(x.cmd(), VK_PIPELINE_BIND_POINT_COMPUTE, pipeline_.pipeline());
        marchDescriptors(x, in, sampler)
            .buffer(gpu::kBindOutput, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, x.buffer(results).handle())
            .buffer(gpu::kBindPickInput, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, x.buffer(points).handle())
            .push(ctx_, x.cmd(), pipeline_);
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
