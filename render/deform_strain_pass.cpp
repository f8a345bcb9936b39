// GpuDeformer's strain pass (deform_strain.comp): per fine tet, the largest principal stretch - 1
// at the fine positions of the frame (render/deform_pass.h). CPU reference: tetStrain
// (sim/strain.h).
#include <cstring>

#include "deform_pass.h"
#include "shaders/shared.h"
#include "sim/error.h"
#include "vk_context.h"

namespace handson::vk {

GpuDeformer::StrainOutputs GpuDeformer::addStrainPass(fg::FrameGraph& g) {
  using fg::Access;
  if (h_.onlyOutputs || !h_.posNew.valid() || !h_.args.valid())
    throw Error("deformation: the strain passes need this frame's fine positions and resampling (addPasses first)");
  constexpr VkDescriptorType ssbo = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
  if (!strainBuffer_) {
    strainBuffer_ = std::make_unique<Buffer>(ctx_, VkDeviceSize(tets_ * sizeof(float)),
                                             VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_SRC_BIT, Buffer::Memory::Device);
    const fg::ImageDesc d{volume_.desc().width, volume_.desc().height, volume_.desc().depth, fg::Format::R32Sfloat};
    strainVolume_ = Image(ctx_, d, VK_IMAGE_USAGE_STORAGE_BIT | VK_IMAGE_USAGE_SAMPLED_BIT | VK_IMAGE_USAGE_TRANSFER_SRC_BIT | VK_IMAGE_USAGE_TRANSFER_DST_BIT,
                          true);
    const std::vector<float> zeros(std::size_t(d.width) * d.height * d.depth, 0.0f);
    uploadToImage(ctx_, strainVolume_, zeros.data(), zeros.size() * sizeof(float), VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL);
    // Strain over limit on the same grid; without limits one voxel the raster never writes.
    const fg::ImageDesc ld = hasStrainLimits() ? d : fg::ImageDesc{1, 1, 1, fg::Format::R32Sfloat};
    overLimitVolume_ = Image(ctx_, ld, VK_IMAGE_USAGE_STORAGE_BIT | VK_IMAGE_USAGE_SAMPLED_BIT | VK_IMAGE_USAGE_TRANSFER_SRC_BIT | VK_IMAGE_USAGE_TRANSFER_DST_BIT,
                             true);
    uploadToImage(ctx_, overLimitVolume_, zeros.data(), std::size_t(ld.width) * ld.height * ld.depth * sizeof(float), VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL);
  }
  h_.strain = g.importBuffer("fine-strain", {strainBuffer_->size()}, Access::StorageWrite);
  h_.strainVolume = g.importImage("strain-volume", strainVolume_.desc(), Access::Sampled);
  h_.strainLimits = g.importBuffer("strain-limits", {strainLimits_.size()}, Access::StorageRead);
  h_.overLimitVolume = g.importImage("strain-over-limit", overLimitVolume_.desc(), Access::Sampled);
  const Bound hb = h_;
  const std::uint32_t groups = std::uint32_t((tets_ + HANDSON_DEFORM_GROUP_X - 1) / HANDSON_DEFORM_GROUP_X);
  g.addPass(
      "deform-strain",
      [&](fg::PassBuilder& b) {
        b.read(hb.params, Access::StorageRead);
        b.read(hb.tets, Access::StorageRead);
        b.read(hb.rest, Access::StorageRead);
        b.read(hb.posNew, Access::StorageRead);
        b.write(hb.strain, Access::StorageWrite);
      },
      [this, hb, groups](fg::Executor& e) {
        GraphExecutor& x = vulkanExecutor(e);
        vkCmdBindPipeline(x.cmd(), VK_PIPELINE_BIND_POINT_COMPUTE, strain_.pipeline());
        DescriptorWriter()
            .buffer(gpu::kBindDeformStrainParams, ssbo, x.buffer(hb.params).handle())
            .buffer(gpu::kBindDeformStrainTets, ssbo, x.buffer(hb.tets).handle())
            .buffer(gpu::kBindDeformStrainRest, ssbo, x.buffer(hb.rest).handle())
            .buffer(gpu::kBindDeformStrainPos, ssbo, x.buffer(hb.posNew).handle())
            .buffer(gpu::kBindDeformStrainOut, ssbo, x.buffer(hb.strain).handle())
            .push(ctx_, x.cmd(), strain_);
        vkCmdDispatch(x.cmd(), groups, 1, 1);
      });
  // After the resolve pass (it writes the box's counters): the same box or bricks, the same owners.
  g.addPass(
      "deform-strain-raster",
      [&](fg::PassBuilder& b) {
        b.read(hb.params, Access::StorageRead);
        b.read(hb.args, Access::IndirectRead);
        b.read(hb.box, Access::StorageRead);
        b.read(hb.owner, Access::StorageRead);
        b.read(hb.brickList, Access::StorageRead);
        b.read(hb.strain, Access::StorageRead);
        b.read(hb.strainLimits, Access::StorageRead);
        b.write(hb.strainVolume, Access::StorageWrite);
        b.write(hb.overLimitVolume, Access::StorageWrite);
      },
      [this, hb](fg::Executor& e) {
        GraphExecutor& x = vulkanExecutor(e);
        vkCmdBindPipeline(x.cmd(), VK_PIPELINE_BIND_POINT_COMPUTE, strainRaster_.pipeline());
        DescriptorWriter()
            .buffer(gpu::kBindDeformStrainRasterParams, ssbo, x.buffer(hb.params).handle())
            .buffer(gpu::kBindDeformStrainRasterBox, ssbo, x.buffer(hb.box).handle())
            .buffer(gpu::kBindDeformStrainRasterOwner, ssbo, x.buffer(hb.owner).handle())
            .buffer(gpu::kBindDeformStrainRasterStrain, ssbo, x.buffer(hb.strain).handle())
            .storageImage(gpu::kBindDeformStrainRasterOut, x.image(hb.strainVolume).view())
            .buffer(gpu::kBindDeformStrainRasterLimits, ssbo, x.buffer(hb.strainLimits).handle())
            .storageImage(gpu::kBindDeformStrainRasterLimitOut, x.image(hb.overLimitVolume).view())
            .buffer(gpu::kBindDeformStrainRasterBrickList, ssbo, x.buffer(hb.brickList).handle())
            .push(ctx_, x.cmd(), strainRaster_);
        vkCmdDispatchIndirect(x.cmd(), x.buffer(hb.args).handle(), 0);
      });
  g.exportResource(hb.strainVolume, Access::Sampled);
  g.exportResource(hb.overLimitVolume, Access::Sampled);
  return {hb.strain, hb.strainVolume, hasStrainLimits() ? hb.overLimitVolume : fg::ResourceHandle{}};
}

GpuDeformer::StrainOutputs GpuDeformer::importStrainVolume(fg::FrameGraph& g) {
  if (!strainBuffer_) return {};
  h_.strainVolume = g.importImage("strain-volume", strainVolume_.desc(), fg::Access::Sampled);
  if (!hasStrainLimits()) return {{}, h_.strainVolume, {}};
  h_.overLimitVolume = g.importImage("strain-over-limit", overLimitVolume_.desc(), fg::Access::Sampled);
  return {{}, h_.strainVolume, h_.overLimitVolume};
}

std::vector<float> GpuDeformer::readStrain() const {
  if (!strainBuffer_) throw Error("deformation: no strain computed yet");
  std::vector<float> out(tets_);
  downloadFromBuffer(ctx_, *strainBuffer_, out.data(), out.size() * sizeof(float));
  return out;
}

std::vector<float> GpuDeformer::runStrain(const std::vector<Eigen::Vector4f>& indexPositions) {
  runOwn([&](fg::FrameGraph& g) {
    addPassesFromPositions(g, indexPositions, Redo::Region);
    addStrainPass(g);
  });
  return readStrain();
}

}  // namespace handson::vk
