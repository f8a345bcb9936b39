// Resampling: the box or the bricks of voxels whose tissue moved (deform_bounds.comp,
// deform_bricks.comp, deform_args.comp), then the tetrahedral rasterization of the fine mesh into
// the deformed volume and mask over them (deform_clear.comp, deform_claim.comp, deform_resolve.comp).
#include <climits>

#include "deform_descriptors.h"
#include "deform_pass.h"
#include "shaders/shared.h"
#include "sim/base/error.h"
#include "vk_context.h"

namespace handson::vk {

namespace {
struct BricksPush {  // deform_bricks.comp's push constants
  float lag;
  std::uint32_t settle;
};
}  // namespace

using deform::kParams;
using deform::kSampled;
using deform::kSsbo;
using deform::kStorageImage;

// What to redo: the moved tets' box (deform_bounds.comp), and in brick mode each brick's lag and the
// list of bricks past it (deform_bricks.comp).
void GpuDeformer::addRedoSelection(fg::FrameGraph& g, Redo redo) {
  using fg::Access;
  const Bound hb = h_;
  const std::uint32_t tetGroups = std::uint32_t((tets_ + HANDSON_DEFORM_GROUP_X - 1) / HANDSON_DEFORM_GROUP_X);
  const std::uint32_t brickGroups = std::uint32_t((p_.brickCount + HANDSON_DEFORM_GROUP_X - 1) / HANDSON_DEFORM_GROUP_X);
  const bool bricks = redo == Redo::Bricks || redo == Redo::BricksDuringMotion;
  if (redo == Redo::Moved || bricks)
    g.addPass(
        PassId::DeformBounds,
        [&](fg::PassBuilder& b) {
          b.read(hb.params, Access::StorageRead);
          b.read(hb.tets, Access::StorageRead);
          b.read(hb.posNew, Access::StorageRead);
          b.read(hb.posOld, Access::StorageRead);
          b.write(hb.box, Access::StorageReadWrite);
          b.write(hb.brickFlags, Access::StorageReadWrite);
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
              .buffer(gpu::kBindDeformBoundsBrickMotion, kSsbo, x.buffer(hb.brickFlags).handle())
              .push(ctx_, x.cmd(), bounds_);
          vkCmdDispatch(x.cmd(), tetGroups, 1, 1);
        });
  if (bricks)
    g.addPass(
        PassId::DeformBricks,
        [&](fg::PassBuilder& b) {
          b.read(hb.params, Access::StorageRead);
          b.read(hb.rigid, Access::StorageRead);
          b.write(hb.brickFlags, Access::StorageReadWrite);
          b.write(hb.brickLag, Access::StorageReadWrite);
          b.write(hb.box, Access::StorageReadWrite);
          b.write(hb.brickList, Access::StorageWrite);
        },
        [this, hb, brickGroups, push = BricksPush{redo == Redo::Bricks ? 0.0f : motionLag_, redo == Redo::Bricks ? 1u : 0u}](fg::Executor& e) {
          GraphExecutor& x = vulkanExecutor(e);
          vkCmdBindPipeline(x.cmd(), VK_PIPELINE_BIND_POINT_COMPUTE, bricks_.pipeline());
          DescriptorWriter()
              .buffer(gpu::kBindDeformBricksParams, kParams, x.buffer(hb.params).handle())
              .buffer(gpu::kBindDeformBricksBox, kSsbo, x.buffer(hb.box).handle())
              .buffer(gpu::kBindDeformBricksFlags, kSsbo, x.buffer(hb.brickFlags).handle())
              .buffer(gpu::kBindDeformBricksList, kSsbo, x.buffer(hb.brickList).handle())
              .buffer(gpu::kBindDeformBricksLag, kSsbo, x.buffer(hb.brickLag).handle())
              .buffer(gpu::kBindDeformBricksRigid, kSsbo, x.buffer(hb.rigid).handle())
              .push(ctx_, x.cmd(), bricks_);
          vkCmdPushConstants(x.cmd(), bricks_.layout(), VK_SHADER_STAGE_COMPUTE_BIT, 0, sizeof push, &push);
          vkCmdDispatch(x.cmd(), brickGroups, 1, 1);
        });
}

GpuDeformer::Outputs GpuDeformer::addResamplePasses(fg::FrameGraph& g, Redo redo) {
  addResetPass(g, redo);
  addRedoSelection(g, redo);
  addArgsPass(g, redo);
  addClearPass(g);
  addClaimPass(g);
  addResolvePass(g);
  g.exportResource(h_.volume, fg::Access::Sampled);
  g.exportResource(h_.mask, fg::Access::Sampled);
  return {h_.volume, h_.mask};
}

// The frame's box (or brick mode) and counters reset; brick flags cleared; a region redo's lag zeroed.
void GpuDeformer::addResetPass(fg::FrameGraph& g, Redo redo) {
  using fg::Access;
  const Bound hb = h_;
  const gpu::DeformParams p = p_;
  const bool bricks = redo == Redo::Bricks || redo == Redo::BricksDuringMotion;
  g.addPass(
      PassId::DeformReset,
      [&](fg::PassBuilder& b) {
        b.write(hb.box, Access::TransferDst);
        if (bricks) b.write(hb.brickFlags, Access::TransferDst);
        if (redo == Redo::Region || redo == Redo::WholeVolume) b.write(hb.brickLag, Access::TransferDst);
      },
      [hb, p, redo, bricks](fg::Executor& e) {
        GraphExecutor& x = vulkanExecutor(e);
        gpu::DeformBox init{};
        if (redo == Redo::Region || bricks) {  // brick mode: the box only bounds the skipped-tet count
          init.lo = p.regionVoxLo;
          init.hi = p.regionVoxHi;
        } else if (redo == Redo::WholeVolume) {
          init.lo = glm::ivec3(0);
          init.hi = p.volumeDims - 1;
        } else {
          init.lo = glm::ivec3(INT_MAX);
          init.hi = glm::ivec3(INT_MIN);
        }
        init.brickMode = bricks ? 1u : 0u;
        vkCmdUpdateBuffer(x.cmd(), x.buffer(hb.box).handle(), 0, sizeof(init), &init);
        if (bricks) vkCmdFillBuffer(x.cmd(), x.buffer(hb.brickFlags).handle(), 0, VK_WHOLE_SIZE, 0u);
        // A redo of the region leaves no brick lagging (the box of a moved-box frame is exact too,
        // at its own commit threshold, and adds no lag).
        if (redo == Redo::Region || redo == Redo::WholeVolume) vkCmdFillBuffer(x.cmd(), x.buffer(hb.brickLag).handle(), 0, VK_WHOLE_SIZE, 0u);
      });
}

// The indirect dispatch of the per-voxel passes over the box or the listed bricks.
void GpuDeformer::addArgsPass(fg::FrameGraph& g, Redo redo) {
  using fg::Access;
  const Bound hb = h_;
  g.addPass(
      PassId::DeformArgs,
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
}

// The redone voxels reset (deform_clear.comp).
void GpuDeformer::addClearPass(fg::FrameGraph& g) {
  using fg::Access;
  const Bound hb = h_;
  g.addPass(
      PassId::DeformClear,
      [&](fg::PassBuilder& b) {
        b.read(hb.params, Access::StorageRead);
        b.read(hb.args, Access::IndirectRead);
        b.read(hb.box, Access::StorageRead);
        b.read(hb.brickList, Access::StorageRead);
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
            .buffer(gpu::kBindDeformClearBrickList, kSsbo, x.buffer(hb.brickList).handle())
            .push(ctx_, x.cmd(), clear_);
        vkCmdDispatchIndirect(x.cmd(), x.buffer(hb.args).handle(), 0);
      });
}

// Each deformed tet claims the voxel centres it covers (deform_claim.comp).
void GpuDeformer::addClaimPass(fg::FrameGraph& g) {
  using fg::Access;
  const Bound hb = h_;
  const std::uint32_t tetGroups = std::uint32_t((tets_ + HANDSON_DEFORM_GROUP_X - 1) / HANDSON_DEFORM_GROUP_X);
  g.addPass(
      PassId::DeformClaim,
      [&](fg::PassBuilder& b) {
        b.read(hb.params, Access::StorageRead);
        b.read(hb.tets, Access::StorageRead);
        b.read(hb.posNew, Access::StorageRead);
        b.read(hb.box, Access::StorageRead);
        b.read(hb.restIdx, Access::StorageRead);
        b.read(hb.brickFlags, Access::StorageRead);
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
            .buffer(gpu::kBindDeformClaimBrickFlags, kSsbo, x.buffer(hb.brickFlags).handle())
            .push(ctx_, x.cmd(), claim_);
        vkCmdDispatch(x.cmd(), tetGroups, 1, 1);
      });
}

// Each claimed voxel sampled at its rest position, rigid handles first (deform_resolve.comp).
void GpuDeformer::addResolvePass(fg::FrameGraph& g) {
  using fg::Access;
  const Bound hb = h_;
  g.addPass(
      PassId::DeformResolve,
      [&](fg::PassBuilder& b) {
        b.read(hb.params, Access::StorageRead);
        b.read(hb.args, Access::IndirectRead);
        b.read(hb.affine, Access::StorageRead);
        b.read(hb.brickList, Access::StorageRead);
        b.read(hb.rigid, Access::StorageRead);
        b.read(hb.source, Access::Sampled);
        b.read(hb.sourceMask, Access::Sampled);
        b.write(hb.owner, Access::StorageReadWrite);  // the voxels a rigid handle took
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
            .buffer(gpu::kBindDeformResolveBrickList, kSsbo, x.buffer(hb.brickList).handle())
            .buffer(gpu::kBindDeformResolveRigid, kSsbo, x.buffer(hb.rigid).handle())
            .push(ctx_, x.cmd(), resolve_);
        vkCmdDispatchIndirect(x.cmd(), x.buffer(hb.args).handle(), 0);
      });
}

}  // namespace handson::vk
