// The deformation's strain passes (render/deform_strain_pass.h).
#include "deform_strain_pass.h"

#include <algorithm>
#include <vector>

#include "compute_passes.h"
#include "deform_descriptors.h"
#include "render/pass_id.h"
#include "shaders/shared.h"
#include "shaders/spirv.h"
#include "sim/base/error.h"
#include "vk_context.h"
#include "vk_graph_executor.h"

namespace handson::vk {

using deform::bindings;
using deform::kParams;
using deform::kSsbo;
using deform::kStorageImage;

namespace {
constexpr VkImageUsageFlags kVolumeUsage =
    VK_IMAGE_USAGE_STORAGE_BIT | VK_IMAGE_USAGE_SAMPLED_BIT | VK_IMAGE_USAGE_TRANSFER_SRC_BIT | VK_IMAGE_USAGE_TRANSFER_DST_BIT;

std::vector<float> downloaded(const Context& ctx, const Image& image) {
  const fg::ImageDesc d = image.desc();
  std::vector<float> out(std::size_t(d.width) * d.height * d.depth);
  downloadFromImage(ctx, image, out.data(), out.size() * sizeof(float));
  return out;
}
}  // namespace

DeformStrainPass::DeformStrainPass(const Context& ctx, std::size_t tets, const fg::ImageDesc& grid, const std::vector<float>* limits)
    : ctx_(ctx), tets_(tets), grid_(grid), hasLimits_(limits != nullptr) {
  strain_ = ComputePipeline(ctx, shaders::deformStrain(),
                            bindings({{gpu::kBindDeformStrainParams, kParams},
                                      {gpu::kBindDeformStrainTets, kSsbo},
                                      {gpu::kBindDeformStrainRest, kSsbo},
                                      {gpu::kBindDeformStrainPos, kSsbo},
                                      {gpu::kBindDeformStrainOut, kSsbo}}),
                            0);
  raster_ = ComputePipeline(ctx, shaders::deformStrainRaster(),
                            bindings({{gpu::kBindDeformStrainRasterParams, kParams},
                                      {gpu::kBindDeformStrainRasterBox, kSsbo},
                                      {gpu::kBindDeformStrainRasterOwner, kSsbo},
                                      {gpu::kBindDeformStrainRasterStrain, kSsbo},
                                      {gpu::kBindDeformStrainRasterOut, kStorageImage},
                                      {gpu::kBindDeformStrainRasterLimits, kSsbo},
                                      {gpu::kBindDeformStrainRasterLimitOut, kStorageImage},
                                      {gpu::kBindDeformStrainRasterBrickList, kSsbo}}),
                            0);
  const std::vector<float> none(1, 0.0f);
  const std::vector<float>& l = limits ? *limits : none;
  limits_ = Buffer(ctx, VkDeviceSize(std::max<std::size_t>(l.size(), 1) * sizeof(float)),
                   VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT | VK_BUFFER_USAGE_TRANSFER_SRC_BIT, Buffer::Memory::Device);
  if (!l.empty()) uploadToBuffer(ctx, limits_, l.data(), l.size() * sizeof(float));
}

void DeformStrainPass::allocate() {
  perTet_ = std::make_unique<Buffer>(ctx_, VkDeviceSize(tets_ * sizeof(float)), VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_SRC_BIT,
                                     Buffer::Memory::Device);
  const fg::ImageDesc d{grid_.width, grid_.height, grid_.depth, fg::Format::R32Sfloat};
  volume_ = Image(ctx_, d, kVolumeUsage, true);
  const std::vector<float> zeros(std::size_t(d.width) * d.height * d.depth, 0.0f);
  uploadToImage(ctx_, volume_, zeros.data(), zeros.size() * sizeof(float), VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL);
  // Strain over limit on the same grid; without limits one voxel the raster never writes.
  const fg::ImageDesc ld = hasLimits_ ? d : fg::ImageDesc{1, 1, 1, fg::Format::R32Sfloat};
  overLimit_ = Image(ctx_, ld, kVolumeUsage, true);
  uploadToImage(ctx_, overLimit_, zeros.data(), std::size_t(ld.width) * ld.height * ld.depth * sizeof(float), VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL);
}

DeformStrainPass::Outputs DeformStrainPass::add(fg::FrameGraph& g, const Inputs& in) {
  using fg::Access;
  if (!perTet_) allocate();
  h_.perTet = importBuffer(g, "fine-strain", *perTet_, Access::StorageWrite);
  h_.volume = importImage(g, "strain-volume", volume_, Access::Sampled);
  h_.limits = importBuffer(g, "strain-limits", limits_, Access::StorageRead);
  h_.overLimit = importImage(g, "strain-over-limit", overLimit_, Access::Sampled);
  const Handles h = h_;
  const std::uint32_t groups = std::uint32_t((tets_ + HANDSON_DEFORM_GROUP_X - 1) / HANDSON_DEFORM_GROUP_X);
  const PassResources perTet = PassResources()
                                   .buffer(gpu::kBindDeformStrainParams, in.params, Access::StorageRead)
                                   .buffer(gpu::kBindDeformStrainTets, in.tets, Access::StorageRead)
                                   .buffer(gpu::kBindDeformStrainRest, in.rest, Access::StorageRead)
                                   .buffer(gpu::kBindDeformStrainPos, in.positions, Access::StorageRead)
                                   .buffer(gpu::kBindDeformStrainOut, h.perTet, Access::StorageWrite);
  g.addPass(
      PassId::DeformStrain, [&](fg::PassBuilder& b) { perTet.declare(b); },
      [this, perTet, groups](fg::Executor& e) {
        GraphExecutor& x = vulkanExecutor(e);
        vkCmdBindPipeline(x.cmd(), VK_PIPELINE_BIND_POINT_COMPUTE, strain_.pipeline());
        perTet.push(ctx_, x, strain_);
        vkCmdDispatch(x.cmd(), groups, 1, 1);
      });
  // After the resolve pass (it writes the box's counters): the same box or bricks, the same owners.
  const PassResources raster = PassResources()
                                   .buffer(gpu::kBindDeformStrainRasterParams, in.params, Access::StorageRead)
                                   .use(in.args, Access::IndirectRead)
                                   .buffer(gpu::kBindDeformStrainRasterBox, in.box, Access::StorageRead)
                                   .buffer(gpu::kBindDeformStrainRasterOwner, in.owner, Access::StorageRead)
                                   .buffer(gpu::kBindDeformStrainRasterBrickList, in.brickList, Access::StorageRead)
                                   .buffer(gpu::kBindDeformStrainRasterStrain, h.perTet, Access::StorageRead)
                                   .buffer(gpu::kBindDeformStrainRasterLimits, h.limits, Access::StorageRead)
                                   .storageImage(gpu::kBindDeformStrainRasterOut, h.volume, Access::StorageWrite)
                                   .storageImage(gpu::kBindDeformStrainRasterLimitOut, h.overLimit, Access::StorageWrite);
  g.addPass(
      PassId::DeformStrainRaster, [&](fg::PassBuilder& b) { raster.declare(b); },
      [this, raster, args = in.args](fg::Executor& e) {
        GraphExecutor& x = vulkanExecutor(e);
        vkCmdBindPipeline(x.cmd(), VK_PIPELINE_BIND_POINT_COMPUTE, raster_.pipeline());
        raster.push(ctx_, x, raster_);
        vkCmdDispatchIndirect(x.cmd(), x.buffer(args).handle(), 0);
      });
  g.exportResource(h.volume, Access::Sampled);
  g.exportResource(h.overLimit, Access::Sampled);
  return {h.perTet, h.volume, hasLimits_ ? h.overLimit : fg::ResourceHandle{}};
}

DeformStrainPass::Outputs DeformStrainPass::importVolumes(fg::FrameGraph& g) {
  if (!perTet_) return {};
  h_.volume = importImage(g, "strain-volume", volume_, fg::Access::Sampled);
  if (!hasLimits_) return {{}, h_.volume, {}};
  h_.overLimit = importImage(g, "strain-over-limit", overLimit_, fg::Access::Sampled);
  return {{}, h_.volume, h_.overLimit};
}

std::vector<float> DeformStrainPass::readPerTet() const {
  if (!perTet_) throw Error("deformation: no strain computed yet");
  std::vector<float> out(tets_);
  downloadFromBuffer(ctx_, *perTet_, out.data(), out.size() * sizeof(float));
  return out;
}

std::vector<float> DeformStrainPass::readVolume() const {
  if (!perTet_) throw Error("deformation: no strain computed yet");
  return downloaded(ctx_, volume_);
}

std::vector<float> DeformStrainPass::readOverLimitVolume() const {
  if (!perTet_) throw Error("deformation: no strain computed yet");
  if (!hasLimits_) throw Error("deformation: no strain limits were given");
  return downloaded(ctx_, overLimit_);
}

}  // namespace handson::vk
