// The fine node positions of a frame: interpolated from the coarse state on the GPU
// (deform_interpolate.comp), or uploaded from refined positions the CPU computed.
#include <algorithm>
#include <cstring>
#include <memory>

#include "deform_descriptors.h"
#include "deform_pass.h"
#include "shaders/shared.h"
#include "sim/base/error.h"
#include "vk_context.h"

namespace handson::vk {

float GpuDeformer::commitFor(Redo redo) const {
  // The bricks' lag is kept per brick (deform_bricks.comp): every node takes its exact position.
  if (redo == Redo::BricksDuringMotion || redo == Redo::Bricks) return 0.0f;
  return commit_;
}


GpuDeformer::Outputs GpuDeformer::addPasses(fg::FrameGraph& g, const CoarseFrameState& state, Redo redo, const FrameImports& at) {
  const std::uint32_t slot = at.slot;
  if (slot >= slots_.size()) throw Error("deformation: frame slot out of range");
  if (state.positions.size() != coarseNodes_ || state.rotations.size() != coarseElements_ || state.handles.size() != handles_)
    throw Error("deformation: the coarse state does not match the mesh");
  Slot& s = slots_[slot];
  auto hostBuffer = [&](std::unique_ptr<Buffer>& b, const void* data, std::size_t bytes) {
    const VkDeviceSize size = std::max<VkDeviceSize>(bytes, 64);
    if (!b || b->size() < size) b = std::make_unique<Buffer>(ctx_, size, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, Buffer::Memory::HostVisible);
    if (bytes) std::memcpy(b->mapped(), data, bytes);
    b->flush();
  };
  static_assert(sizeof(Eigen::Vector4f) == 16 && sizeof(Eigen::Matrix4f) == 64, "packed state layout");
  hostBuffer(s.positions, state.positions.data(), state.positions.size() * 16);
  hostBuffer(s.rotations, state.rotations.data(), state.rotations.size() * 16);
  hostBuffer(s.handles, state.handles.data(), state.handles.size() * 64);
  if (!rigidIds_.empty()) poses_ = state.handles;  // the rigid handles drawn at the state's poses

  importResources(g, true, at);
  using fg::Access;
  const Bound hb = h_;
  const std::uint32_t nodeGroups = std::uint32_t((nodes_ + HANDSON_DEFORM_GROUP_X - 1) / HANDSON_DEFORM_GROUP_X);

  const PassResources r = PassResources()
                              .buffer(gpu::kBindDeformInterpolateParams, hb.params, Access::StorageRead)
                              .buffer(gpu::kBindDeformInterpolateNodes, hb.nodeInfo, Access::StorageRead)
                              .buffer(gpu::kBindDeformInterpolateRest, hb.rest, Access::StorageRead)
                              .buffer(gpu::kBindDeformInterpolateBlocks, hb.blocks, Access::StorageRead)
                              .buffer(gpu::kBindDeformInterpolateElements, hb.elementCorners, Access::StorageRead)
                              .buffer(gpu::kBindDeformInterpolateCoarseRest, hb.coarseRest, Access::StorageRead)
                              .buffer(gpu::kBindDeformInterpolateCoarsePos, hb.positions, Access::StorageRead)
                              .buffer(gpu::kBindDeformInterpolateRotations, hb.rotations, Access::StorageRead)
                              .buffer(gpu::kBindDeformInterpolateHandles, hb.handles, Access::StorageRead)
                              .buffer(gpu::kBindDeformInterpolateOut, hb.posNew, Access::StorageReadWrite)
                              .buffer(gpu::kBindDeformInterpolatePrev, hb.posOld, Access::StorageWrite);
  g.addPass(
      PassId::DeformInterpolate, [&](fg::PassBuilder& b) { r.declare(b); },
      [this, r, nodeGroups, commit = commitFor(redo)](fg::Executor& e) {
        GraphExecutor& x = vulkanExecutor(e);
        vkCmdBindPipeline(x.cmd(), VK_PIPELINE_BIND_POINT_COMPUTE, interpolate_.pipeline());
        r.push(ctx_, x, interpolate_);
        vkCmdPushConstants(x.cmd(), interpolate_.layout(), VK_SHADER_STAGE_COMPUTE_BIT, 0, 4, &commit);
        vkCmdDispatch(x.cmd(), nodeGroups, 1, 1);
      });
  return addResamplePasses(g, redo);
}

GpuDeformer::Outputs GpuDeformer::addPassesFromPositions(fg::FrameGraph& g, const std::vector<Eigen::Vector4f>& positions, Redo redo, const FrameImports& at) {
  const std::uint32_t slot = at.slot;
  if (slot >= slots_.size()) throw Error("deformation: frame slot out of range");
  if (positions.size() != nodes_) throw Error("deformation: one position per fine node expected");
  for (const auto& p : positions)
    if (!p.allFinite()) throw Error("deformation: a fine node position is not finite");
  Slot& s = slots_[slot];
  const VkDeviceSize bytes = nodes_ * 16;
  if (!s.fine || s.fine->size() < bytes) s.fine = std::make_unique<Buffer>(ctx_, bytes, VK_BUFFER_USAGE_TRANSFER_SRC_BIT, Buffer::Memory::HostVisible);
  std::memcpy(s.fine->mapped(), positions.data(), bytes);
  s.fine->flush();
  importResources(g, false, at);
  using fg::Access;
  h_.fineUpload = importBuffer(g, "fine-positions-upload", *s.fine, Access::HostWrite);
  const Bound hb = h_;
  // The positions last taken become the previous ones (for the moved box), then the upload.
  auto copyPass = [&](const char* name, fg::ResourceHandle from, fg::ResourceHandle to) {
    g.addPass(
        name,
        [&](fg::PassBuilder& b) {
          b.read(from, Access::TransferSrc);
          b.write(to, Access::TransferDst);
        },
        [from, to, bytes](fg::Executor& e) {
          GraphExecutor& x = vulkanExecutor(e);
          const VkBufferCopy c{0, 0, bytes};
          vkCmdCopyBuffer(x.cmd(), x.buffer(from).handle(), x.buffer(to).handle(), 1, &c);
        });
  };
  copyPass("deform-keep-previous", hb.posNew, hb.posOld);
  copyPass("deform-upload-positions", hb.fineUpload, hb.posNew);
  return addResamplePasses(g, redo);
}

}  // namespace handson::vk
