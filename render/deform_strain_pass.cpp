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
  constexpr VkDescriptorType ssbo = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
  if (!perTet_) allocate();
  h_.perTet = importBuffer(g, "fine-strain", *perTet_, Access::StorageWrite);
  h_.volume = importImage(g, "strain-volume", volume_, Access::Sampled);
  h_.limits = importBuffer(g, "strain-limits", limits_, Access::StorageRead);
  h_.overLimit = importImage(g, "strain-over-limit", overLimit_, Access::Sampled);
  const Handles h = h_;
  const std::uint32_t groups = std::uint32_t((tets_ + HANDSON_DEFORM_GROUP_X - 1) / HANDSON_DEFORM_GROUP_X);
  g.addPass(
      PassId::DeformStrain,
      [&](fg::PassBuilder& b) {
        b.read(in.params, Access::StorageRead);
        b.read(in.tets, Access::StorageRead);
        b.read(in.rest, Access::StorageRead);
        b.read(in.positions, Access::StorageRead);
        b.write(h.perTet, Access::StorageWrite);
      },
      [this, in, h, groups](fg::Executor& e) {
        GraphExecutor& x = vulkanExecutor(e);
        vkCmdBindPipeline(x.cmd(), VK_PIPELINE_BIND_POINT_COMPUTE, strain_.pipeline());
        DescriptorWriter()
            .buffer(gpu::kBindDeformStrainParams, ssbo, x.buffer(in.params).handle())
            .buffer(gpu::kBindDeformStrainTets, ssbo, x.buffer(in.tets).handle())
            .buffer(gpu::kBindDeformStrainRest, ssbo, x.buffer(in.rest).handle())
            .buffer(gpu::kBindDeformStrainPos, ssbo, x.buffer(in.positions).handle())
            .buffer(gpu::kBindDeformStrainOut, ssbo, x.buffer(h.perTet).handle())
            .push(ctx_, x.cmd(), strain_);
        vkCmdDispatch(x.cmd(), groups, 1, 1);
      });
  // After the resolve pass (it writes the box's counters): the same box or bricks, the same owners.
  g.addPass(
      PassId::DeformStrainRaster,
      [&](fg::PassBuilder& b) {
        b.read(in.params, Access::StorageRead);
        b.read(in.args, Access::IndirectRead);
        b.read(in.box, Access::StorageRead);
        b.read(in.owner, Access::StorageRead);
        b.read(in.brickList, Access::StorageRead);
        b.read(h.perTet, Access::StorageRead);
        b.read(h.limits, Access::StorageRead);
        b.write(h.volume, Access::StorageWrite);
        b.write(h.overLimit, Access::StorageWrite);
      },
      [this, in, h](fg::Executor& e) {
        GraphExecutor& x = vulkanExecutor(e);
        vkCmdBindPipeline(x.cmd(), VK_PIPELINE_BIND_POINT_COMPUTE, raster_.pipeline());
        DescriptorWriter()
            .buffer(gpu::kBindDeformStrainRasterParams, ssbo, x.buffer(in.params).handle())
            .buffer(gpu::kBindDeformStrainRasterBox, ssbo, x.buffer(in.box).handle())
            .buffer(gpu::kBindDeformStrainRasterOwner, ssbo, x.buffer(in.owner).handle())
            .buffer(gpu::kBindDeformStrainRasterStrain, ssbo, x.buffer(h.perTet).handle())
            .storageImage(gpu::kBindDeformStrainRasterOut, x.image(h.volume).view())
            .buffer(gpu::kBindDeformStrainRasterLimits, ssbo, x.buffer(h.limits).handle())
            .storageImage(gpu::kBindDeformStrainRasterLimitOut, x.image(h.overLimit).view())
            .buffer(gpu::kBindDeformStrainRasterBrickList, ssbo, x.buffer(in.brickList).handle())
            .push(ctx_, x.cmd(), raster_);
        vkCmdDispatchIndirect(x.cmd(), x.buffer(in.args).handle(), 0);
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
