// Resampling: the box of voxels whose tissue moved (deform_bounds.comp, deform_args.comp), then the
// tetrahedral rasterization of the fine mesh into the deformed volume and mask over that box
// (deform_clear.comp, deform_claim.comp, deform_resolve.comp).
#include <climits>

#include "deform_descriptors.h"
#include "deform_pass.h"
#include "shaders/shared.h"
#include "sim/error.h"
#include "vk_context.h"

namespace handson::vk {

using deform::kParams;
using deform::kSampled;
using deform::kSsbo;
using deform::kStorageImage;

GpuDeformer::Outputs GpuDeformer::addResamplePasses(fg::FrameGraph& g, Redo redo) {
  using fg::Access;
  const Bound hb = h_;
  const gpu::DeformParams p = p_;
  const std::uint32_t tetGroups = std::uint32_t((tets_ + HANDSON_DEFORM_GROUP_X - 1) / HANDSON_DEFORM_GROUP_X);
  g.addPass(
      "deform-reset", [&](fg::PassBuilder& b) { b.write(hb.box, Access::TransferDst); },
      [hb, p, redo](fg::Executor& e) {
        GraphExecutor& x = vulkanExecutor(e);
        gpu::DeformBox init{};
        if (redo == Redo::Region) {
          init.lo = glm::ivec4(p.regionVoxLo.x, p.regionVoxLo.y, p.regionVoxLo.z, 0);
          init.hi = glm::ivec4(p.regionVoxHi.x, p.regionVoxHi.y, p.regionVoxHi.z, 0);
        } else if (redo == Redo::WholeVolume) {
          init.lo = glm::ivec4(0);
          init.hi = glm::ivec4(p.dims.x - 1, p.dims.y - 1, p.dims.z - 1, 0);
        } else {
          init.lo = glm::ivec4(INT_MAX);
          init.hi = glm::ivec4(INT_MIN);
        }
        vkCmdUpdateBuffer(x.cmd(), x.buffer(hb.box).handle(), 0, sizeof(init), &init);
      });
  if (redo == Redo::Moved)
    g.addPass(
        "deform-bounds",
        [&](fg::PassBuilder& b) {
          b.read(hb.params, Access::StorageRead);
          b.read(hb.tets, Access::StorageRead);
          b.read(hb.posNew, Access::StorageRead);
          b.read(hb.posOld, Access::StorageRead);
          b.write(hb.box, Access::StorageReadWrite);
        },
        [this, hb, tetGroups](fg::Executor& e) {
          GraphExecutor& x = vulkanExecutor(e);
          vkCmdBindPipeline(x.cmd(), VK_PIPELINE_BIND_POINT_COMPUTE, bounds_.pipeline());
          DescriptorWriter()
              .buffer(gpu::kBindDeformBoundsParams, kParams, x.buffer(hb.params).handle())
              .buffer(gpu::kBindDeformBoundsTets, kSsbo, x.buffer(hb.tets).handle())
              .buffer(gpu::kBindDeformBoundsPosNew, kSsbo, x.buffer(hb.posNew).handle())
              .buffer(gpu::kBindDeformBoundsPosOld, kSsbo, x.buffer(hb.posOld).handle())
              .buffer(gpu::kBindDeformBoundsBox, kSsbo, x.buffer(hb.box).handle())
              .push(ctx_, x.cmd(), bounds_);
          vkCmdDispatch(x.cmd(), tetGroups, 1, 1);
        });
  g.addPass(
      "deform-args",
      [&](fg::PassBuilder& b) {
        b.read(hb.params, Access::StorageRead);
        b.write(hb.box, Access::StorageReadWrite);
        b.write(hb.args, Access::StorageWrite);
      },
      [this, hb, whole = redo == Redo::WholeVolume ? 1u : 0u](fg::Executor& e) {
        GraphExecutor& x = vulkanExecutor(e);
        vkCmdBindPipeline(x.cmd(), VK_PIPELINE_BIND_POINT_COMPUTE, args_.pipeline());
        DescriptorWriter()
            .buffer(gpu::kBindDeformArgsParams, kParams, x.buffer(hb.params).handle())
            .buffer(gpu::kBindDeformArgsBox, kSsbo, x.buffer(hb.box).handle())
            .buffer(gpu::kBindDeformArgsArgs, kSsbo, x.buffer(hb.args).handle())
            .push(ctx_, x.cmd(), args_);
        vkCmdPushConstants(x.cmd(), args_.layout(), VK_SHADER_STAGE_COMPUTE_BIT, 0, 4, &whole);
        vkCmdDispatch(x.cmd(), 1, 1, 1);
      });
  g.addPass(
      "deform-clear",
      [&](fg::PassBuilder& b) {
        b.read(hb.params, Access::StorageRead);
        b.read(hb.args, Access::IndirectRead);
        b.read(hb.box, Access::StorageRead);
        b.read(hb.source, Access::Sampled);
        b.read(hb.sourceMask, Access::Sampled);
        b.write(hb.volume, Access::StorageReadWrite);
        b.write(hb.mask, Access::StorageReadWrite);
        b.write(hb.owner, Access::StorageReadWrite);
      },
      [this, hb](fg::Executor& e) {
        GraphExecutor& x = vulkanExecutor(e);
        vkCmdBindPipeline(x.cmd(), VK_PIPELINE_BIND_POINT_COMPUTE, clear_.pipeline());
        DescriptorWriter()
            .buffer(gpu::kBindDeformClearParams, kParams, x.buffer(hb.params).handle())
            .buffer(gpu::kBindDeformClearBox, kSsbo, x.buffer(hb.box).handle())
            .sampledImage(gpu::kBindDeformClearSource, x.image(hb.source).view(), nearest_.handle(),
                          VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL)
            .sampledImage(gpu::kBindDeformClearSourceMask, x.image(hb.sourceMask).view(), nearest_.handle(),
                          VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL)
            .storageImage(gpu::kBindDeformClearOut, x.image(hb.volume).view())
            .storageImage(gpu::kBindDeformClearOutMask, x.image(hb.mask).view())
            .buffer(gpu::kBindDeformClearOwner, kSsbo, x.buffer(hb.owner).handle())
            .push(ctx_, x.cmd(), clear_);
        vkCmdDispatchIndirect(x.cmd(), x.buffer(hb.args).handle(), 0);
      });
  g.addPass(
      "deform-claim",
      [&](fg::PassBuilder& b) {
        b.read(hb.params, Access::StorageRead);
        b.read(hb.tets, Access::StorageRead);
        b.read(hb.posNew, Access::StorageRead);
        b.read(hb.box, Access::StorageRead);
        b.read(hb.restIdx, Access::StorageRead);
        b.write(hb.owner, Access::StorageReadWrite);
        b.write(hb.affine, Access::StorageWrite);
      },
      [this, hb, tetGroups](fg::Executor& e) {
        GraphExecutor& x = vulkanExecutor(e);
        vkCmdBindPipeline(x.cmd(), VK_PIPELINE_BIND_POINT_COMPUTE, claim_.pipeline());
        DescriptorWriter()
            .buffer(gpu::kBindDeformClaimParams, kParams, x.buffer(hb.params).handle())
            .buffer(gpu::kBindDeformClaimTets, kSsbo, x.buffer(hb.tets).handle())
            .buffer(gpu::kBindDeformClaimPos, kSsbo, x.buffer(hb.posNew).handle())
            .buffer(gpu::kBindDeformClaimBox, kSsbo, x.buffer(hb.box).handle())
            .buffer(gpu::kBindDeformClaimOwner, kSsbo, x.buffer(hb.owner).handle())
            .buffer(gpu::kBindDeformClaimRestIdx, kSsbo, x.buffer(hb.restIdx).handle())
            .buffer(gpu::kBindDeformClaimAffine, kSsbo, x.buffer(hb.affine).handle())
            .push(ctx_, x.cmd(), claim_);
        vkCmdDispatch(x.cmd(), tetGroups, 1, 1);
      });
  g.addPass(
      "deform-resolve",
      [&](fg::PassBuilder& b) {
        b.read(hb.params, Access::StorageRead);
        b.read(hb.args, Access::IndirectRead);
        b.read(hb.affine, Access::StorageRead);
        b.read(hb.owner, Access::StorageRead);
        b.read(hb.source, Access::Sampled);
        b.read(hb.sourceMask, Access::Sampled);
        b.write(hb.box, Access::StorageReadWrite);
        b.write(hb.volume, Access::StorageReadWrite);
        b.write(hb.mask, Access::StorageReadWrite);
      },
      [this, hb](fg::Executor& e) {
        GraphExecutor& x = vulkanExecutor(e);
        vkCmdBindPipeline(x.cmd(), VK_PIPELINE_BIND_POINT_COMPUTE, resolve_.pipeline());
        DescriptorWriter()
            .buffer(gpu::kBindDeformResolveParams, kParams, x.buffer(hb.params).handle())
            .buffer(gpu::kBindDeformResolveAffine, kSsbo, x.buffer(hb.affine).handle())
            .buffer(gpu::kBindDeformResolveBox, kSsbo, x.buffer(hb.box).handle())
            .buffer(gpu::kBindDeformResolveOwner, kSsbo, x.buffer(hb.owner).handle())
            .sampledImage(gpu::kBindDeformResolveSource, x.image(hb.source).view(), nearest_.handle(),
                          VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL)
            .sampledImage(gpu::kBindDeformResolveSourceMask, x.image(hb.sourceMask).view(), nearest_.handle(),
                          VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL)
            .storageImage(gpu::kBindDeformResolveOut, x.image(hb.volume).view())
            .storageImage(gpu::kBindDeformResolveOutMask, x.image(hb.mask).view())
            .push(ctx_, x.cmd(), resolve_);
        vkCmdDispatchIndirect(x.cmd(), x.buffer(hb.args).handle(), 0);
      });
  g.exportResource(hb.volume, Access::Sampled);
  g.exportResource(hb.mask, Access::Sampled);
  return {hb.volume, hb.mask};
}

}  // namespace handson::vk
