#include "compute_passes.h"
#include "shaders/shared.h"
#include "shaders/spirv.h"
#include "vk_context.h"
#include "vk_graph_executor.h"
#include "volume_texture.h"

namespace handson::vk {

namespace {
struct BrickPush {
  glm::ivec4 dims;
  glm::ivec4 brickDims;
};
static_assert(sizeof(BrickPush) == 32, "push constant layout of brick_minmax.comp");
}  // namespace

BrickPass::BrickPass(const Context& ctx)
    : ctx_(ctx),
      pipeline_(ctx, shaders::brickMinMax(),
                {{gpu::kBindBrickMinmaxVolume, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 1, VK_SHADER_STAGE_COMPUTE_BIT, nullptr},
                 {gpu::kBindBrickMinmaxOut, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 1, VK_SHADER_STAGE_COMPUTE_BIT, nullptr}},
                sizeof(BrickPush)) {}

void BrickPass::add(fg::FrameGraph& graph, fg::ResourceHandle volume, fg::ResourceHandle ranges, const Image& volumeImage,
                    const Sampler& sampler) {
  const fg::ImageDesc d = volumeImage.desc();
  int bx, by, bz;
  brickDims(Eigen::Vector3i(int(d.width), int(d.height), int(d.depth)), bx, by, bz);
  const BrickPush push{glm::ivec4(int(d.width), int(d.height), int(d.depth), 0), glm::ivec4(bx, by, bz, 0)};
  const std::uint32_t count = std::uint32_t(bx) * std::uint32_t(by) * std::uint32_t(bz);
  const PassResources r =
      PassResources().sampled(gpu::kBindBrickMinmaxVolume, volume, sampler).buffer(gpu::kBindBrickMinmaxOut, ranges, fg::Access::StorageWrite);
  graph.addPass(
      PassId::BrickMinmax, [&](fg::PassBuilder& b) { r.declare(b); },
      [this, r, push, count](fg::Executor& e) {
        GraphExecutor& x = vulkanExecutor(e);
        vkCmdBindPipeline(x.cmd(), VK_PIPELINE_BIND_POINT_COMPUTE, pipeline_.pipeline());
        r.push(ctx_, x, pipeline_);
        vkCmdPushConstants(x.cmd(), pipeline_.layout(), VK_SHADER_STAGE_COMPUTE_BIT, 0, sizeof(BrickPush), &push);
        vkCmdDispatch(x.cmd(), (count + gpu::kBrickGroupX - 1) / gpu::kBrickGroupX, 1, 1);
      });
}

}  // namespace handson::vk
