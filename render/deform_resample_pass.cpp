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


// What to redo: the moved tets' box (deform_bounds.comp), and in brick mode each brick's lag and the
// list of bricks past it (deform_bricks.comp).
void GpuDeformer::addRedoSelection(fg::FrameGraph& g, Redo redo) {
  using fg::Access;
  const Bound hb = h_;
  const std::uint32_t tetGroups = std::uint32_t((tets_ + HANDSON_DEFORM_GROUP_X - 1) / HANDSON_DEFORM_GROUP_X);
  const std::uint32_t brickGroups = std::uint32_t((p_.brickCount + HANDSON_DEFORM_GROUP_X - 1) / HANDSON_DEFORM_GROUP_X);
  const bool bricks = redo == Redo::Bricks || redo == Redo::BricksDuringMotion;
  if (redo == Redo::Moved || bricks) {
    const PassResources r = PassResources()
                                .buffer(gpu::kBindDeformBoundsParams, hb.params, Access::StorageRead)
                                .buffer(gpu::kBindDeformBoundsTets, hb.tets, Access::StorageRead)
                                .buffer(gpu::kBindDeformBoundsPosNew, hb.posNew, Access::StorageRead)
                                .buffer(gpu::kBindDeformBoundsPosOld, hb.posOld, Access::StorageRead)
                                .buffer(gpu::kBindDeformBoundsBox, hb.box, Access::StorageReadWrite)
                                .buffer(gpu::kBindDeformBoundsBrickMotion, hb.brickFlags, Access::StorageReadWrite);
    g.addPass(
        PassId::DeformBounds, [&](fg::PassBuilder& b) { r.declare(b); },
        [this, r, tetGroups](fg::Executor& e) {
          GraphExecutor& x = vulkanExecutor(e);
          vkCmdBindPipeline(x.cmd(), VK_PIPELINE_BIND_POINT_COMPUTE, bounds_.pipeline());
          r.push(ctx_, x, bounds_);
          vkCmdDispatch(x.cmd(), tetGroups, 1, 1);
        });
  }
  if (bricks) {
    const PassResources r = PassResources()
                                .buffer(gpu::kBindDeformBricksParams, hb.params, Access::StorageRead)
                                .buffer(gpu::kBindDeformBricksRigid, hb.rigid, Access::StorageRead)
                                .buffer(gpu::kBindDeformBricksFlags, hb.brickFlags, Access::StorageReadWrite)
                                .buffer(gpu::kBindDeformBricksLag, hb.brickLag, Access::StorageReadWrite)
                                .buffer(gpu::kBindDeformBricksBox, hb.box, Access::StorageReadWrite)
                                .buffer(gpu::kBindDeformBricksList, hb.brickList, Access::StorageWrite);
    g.addPass(
        PassId::DeformBricks, [&](fg::PassBuilder& b) { r.declare(b); },
        [this, r, brickGroups, push = BricksPush{redo == Redo::Bricks ? 0.0f : motionLag_, redo == Redo::Bricks ? 1u : 0u}](fg::Executor& e) {
          GraphExecutor& x = vulkanExecutor(e);
          vkCmdBindPipeline(x.cmd(), VK_PIPELINE_BIND_POINT_COMPUTE, bricks_.pipeline());
          r.push(ctx_, x, bricks_);
          vkCmdPushConstants(x.cmd(), bricks_.layout(), VK_SHADER_STAGE_COMPUTE_BIT, 0, sizeof push, &push);
          vkCmdDispatch(x.cmd(), brickGroups, 1, 1);
        });
  }
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
  const PassResources r = PassResources()
                              .buffer(gpu::kBindDeformArgsParams, hb.params, Access::StorageRead)
                              .buffer(gpu::kBindDeformArgsBox, hb.box, Access::StorageReadWrite)
                              .buffer(gpu::kBindDeformArgsArgs, hb.args, Access::StorageWrite);
  g.addPass(
      PassId::DeformArgs, [&](fg::PassBuilder& b) { r.declare(b); },
      [this, r, whole = redo == Redo::WholeVolume ? 1u : 0u](fg::Executor& e) {
        GraphExecutor& x = vulkanExecutor(e);
        vkCmdBindPipeline(x.cmd(), VK_PIPELINE_BIND_POINT_COMPUTE, args_.pipeline());
        r.push(ctx_, x, args_);
        vkCmdPushConstants(x.cmd(), args_.layout(), VK_SHADER_STAGE_COMPUTE_BIT, 0, 4, &whole);
        vkCmdDispatch(x.cmd(), 1, 1, 1);
      });
}

// The redone voxels reset (deform_clear.comp).
void GpuDeformer::addClearPass(fg::FrameGraph& g) {
  using fg::Access;
  const Bound hb = h_;
  const PassResources r = PassResources()
                              .buffer(gpu::kBindDeformClearParams, hb.params, Access::StorageRead)
                              .use(hb.args, Access::IndirectRead)
                              .buffer(gpu::kBindDeformClearBox, hb.box, Access::StorageRead)
                              .buffer(gpu::kBindDeformClearBrickList, hb.brickList, Access::StorageRead)
                              .sampled(gpu::kBindDeformClearSource, hb.source, nearest_)
                              .sampled(gpu::kBindDeformClearSourceMask, hb.sourceMask, nearest_)
                              .storageImage(gpu::kBindDeformClearOut, hb.volume, Access::StorageReadWrite)
                              .storageImage(gpu::kBindDeformClearOutMask, hb.mask, Access::StorageReadWrite)
                              .buffer(gpu::kBindDeformClearOwner, hb.owner, Access::StorageReadWrite);
  g.addPass(
      PassId::DeformClear, [&](fg::PassBuilder& b) { r.declare(b); },
      [this, r, args = hb.args](fg::Executor& e) {
        GraphExecutor& x = vulkanExecutor(e);
        vkCmdBindPipeline(x.cmd(), VK_PIPELINE_BIND_POINT_COMPUTE, clear_.pipeline());
        r.push(ctx_, x, clear_);
        vkCmdDispatchIndirect(x.cmd(), x.buffer(args).handle(), 0);
      });
}

// Each deformed tet claims the voxel centres it covers (deform_claim.comp).
void GpuDeformer::addClaimPass(fg::FrameGraph& g) {
  using fg::Access;
  const Bound hb = h_;
  const std::uint32_t tetGroups = std::uint32_t((tets_ + HANDSON_DEFORM_GROUP_X - 1) / HANDSON_DEFORM_GROUP_X);
  const PassResources r = PassResources()
                              .buffer(gpu::kBindDeformClaimParams, hb.params, Access::StorageRead)
                              .buffer(gpu::kBindDeformClaimTets, hb.tets, Access::StorageRead)
                              .buffer(gpu::kBindDeformClaimPos, hb.posNew, Access::StorageRead)
                              .buffer(gpu::kBindDeformClaimBox, hb.box, Access::StorageRead)
                              .buffer(gpu::kBindDeformClaimRestIdx, hb.restIdx, Access::StorageRead)
                              .buffer(gpu::kBindDeformClaimBrickFlags, hb.brickFlags, Access::StorageRead)
                              .buffer(gpu::kBindDeformClaimOwner, hb.owner, Access::StorageReadWrite)
                              .buffer(gpu::kBindDeformClaimAffine, hb.affine, Access::StorageWrite);
  g.addPass(
      PassId::DeformClaim, [&](fg::PassBuilder& b) { r.declare(b); },
      [this, r, tetGroups](fg::Executor& e) {
        GraphExecutor& x = vulkanExecutor(e);
        vkCmdBindPipeline(x.cmd(), VK_PIPELINE_BIND_POINT_COMPUTE, claim_.pipeline());
        r.push(ctx_, x, claim_);
        vkCmdDispatch(x.cmd(), tetGroups, 1, 1);
      });
}

// Each claimed voxel sampled at its rest position, rigid handles first (deform_resolve.comp).
void GpuDeformer::addResolvePass(fg::FrameGraph& g) {
  using fg::Access;
  const Bound hb = h_;
  const PassResources r = PassResources()
                              .buffer(gpu::kBindDeformResolveParams, hb.params, Access::StorageRead)
                              .use(hb.args, Access::IndirectRead)
                              .buffer(gpu::kBindDeformResolveAffine, hb.affine, Access::StorageRead)
                              .buffer(gpu::kBindDeformResolveBrickList, hb.brickList, Access::StorageRead)
                              .buffer(gpu::kBindDeformResolveRigid, hb.rigid, Access::StorageRead)
                              .sampled(gpu::kBindDeformResolveSource, hb.source, nearest_)
                              .sampled(gpu::kBindDeformResolveSourceMask, hb.sourceMask, nearest_)
                              .buffer(gpu::kBindDeformResolveOwner, hb.owner, Access::StorageReadWrite)  // the voxels a rigid handle took
                              .buffer(gpu::kBindDeformResolveBox, hb.box, Access::StorageReadWrite)
                              .storageImage(gpu::kBindDeformResolveOut, hb.volume, Access::StorageReadWrite)
                              .storageImage(gpu::kBindDeformResolveOutMask, hb.mask, Access::StorageReadWrite);
  g.addPass(
      PassId::DeformResolve, [&](fg::PassBuilder& b) { r.declare(b); },
      [this, r, args = hb.args](fg::Executor& e) {
        GraphExecutor& x = vulkanExecutor(e);
        vkCmdBindPipeline(x.cmd(), VK_PIPELINE_BIND_POINT_COMPUTE, resolve_.pipeline());
        r.push(ctx_, x, resolve_);
        vkCmdDispatchIndirect(x.cmd(), x.buffer(args).handle(), 0);
      });
}

}  // namespace handson::vk
