#include "region_grow_pass.h"

#include <algorithm>
#include <cstring>

#include "shaders/shared.h"
#include "shaders/spirv.h"
#include "sim/error.h"
#include "vk_context.h"

namespace handson::vk {

namespace {

struct CompactPush {
  std::uint32_t count;
  std::uint32_t fromReached;
};

VkDescriptorSetLayoutBinding storage(std::uint32_t b) {
  return {b, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 1, VK_SHADER_STAGE_COMPUTE_BIT, nullptr};
}

// A full compute -> compute/indirect/transfer dependency (the loop's steps depend on each other).
void fullBarrier(VkCommandBuffer cmd) {
  memoryBarrier(cmd, VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT | VK_PIPELINE_STAGE_2_TRANSFER_BIT,
                VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT | VK_ACCESS_2_TRANSFER_WRITE_BIT,
                VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT | VK_PIPELINE_STAGE_2_DRAW_INDIRECT_BIT | VK_PIPELINE_STAGE_2_TRANSFER_BIT,
                VK_ACCESS_2_SHADER_STORAGE_READ_BIT | VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT | VK_ACCESS_2_INDIRECT_COMMAND_READ_BIT |
                    VK_ACCESS_2_TRANSFER_WRITE_BIT | VK_ACCESS_2_TRANSFER_READ_BIT);
}

// Copies made visible to the host.
void hostReadBarrier(VkCommandBuffer cmd) {
  memoryBarrier(cmd, VK_PIPELINE_STAGE_2_TRANSFER_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT, VK_PIPELINE_STAGE_2_HOST_BIT, VK_ACCESS_2_HOST_READ_BIT);
}

}  // namespace

GpuRegionGrower::GpuRegionGrower(const Context& ctx, const Image& volume, const Sampler& sampler)
    : ctx_(ctx),
      volume_(volume),
      sampler_(sampler),
      compact_(ctx, shaders::regionCompact(),
               {storage(gpu::kBindRegionCompactFlags), storage(gpu::kBindRegionCompactList), storage(gpu::kBindRegionCompactReached)},
               sizeof(CompactPush)) {}

void GpuRegionGrower::begin(const GrowSetup& setup, const Eigen::Vector3i& boxMin, const Eigen::Vector3i& boxDims) {
  const fg::ImageDesc vd = volume_.desc();
  const Eigen::Vector3i vol(int(vd.width), int(vd.height), int(vd.depth));
  if ((boxMin.array() < 0).any() || (boxDims.array() <= 0).any() || ((boxMin + boxDims).array() > vol.array()).any())
    throw Error("region growing: the box does not fit in the volume");
  if (((setup.seed - boxMin).array() < 0).any() || ((setup.seed - boxMin).array() >= boxDims.array()).any())
    throw Error("region growing: the seed lies outside the box");
  const std::uint64_t voxels = std::uint64_t(boxDims.x()) * boxDims.y() * boxDims.z();
  if (voxels * 4 > ctx_.properties().limits.maxStorageBufferRange)
    throw Error("region growing: the box is larger than this device's storage buffers allow");
  if (!relax_.pipeline() || relaxCriterion_ != setup.criterion) {
    static_assert(int(GrowCriterion::Paper) == 0 && int(GrowCriterion::Smoothed) == 1 && int(GrowCriterion::Core) == 2, "region_grow.comp's codes");
    relax_ =
        ComputePipeline(ctx_, shaders::regionGrow(),
                        {{gpu::kBindRegionGrowVolume, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 1, VK_SHADER_STAGE_COMPUTE_BIT, nullptr},
                         storage(gpu::kBindRegionGrowKeys),
                         storage(gpu::kBindRegionGrowAccept),
                         storage(gpu::kBindRegionGrowList),
                         storage(gpu::kBindRegionGrowFlags),
                         storage(gpu::kBindRegionGrowReached)},
                        sizeof(gpu::GrowPush), {std::uint32_t(setup.criterion)});
    relaxCriterion_ = setup.criterion;
  }
  setup_ = setup;
  boxMin_ = boxMin;
  boxDims_ = boxDims;
  const int B = HANDSON_GROW_BRICK;
  bricks_ = (boxDims.array() + (B - 1)) / B;
  brickCount_ = std::uint32_t(bricks_.x() * bricks_.y() * bricks_.z());
  const VkBufferUsageFlags usage = VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT | VK_BUFFER_USAGE_TRANSFER_SRC_BIT;
  keys_ = Buffer(ctx_, voxels * 4, usage, Buffer::Memory::Device);
  accept_ = Buffer(ctx_, voxels * 4, usage, Buffer::Memory::Device);
  flags_ = Buffer(ctx_, brickCount_ * 4, usage, Buffer::Memory::Device);
  reached_ = Buffer(ctx_, brickCount_ * 4, usage, Buffer::Memory::Device);
  const VkDeviceSize listBytes = (gpu::kGrowListHeader + brickCount_) * 4;
  listA_ = Buffer(ctx_, listBytes, usage | VK_BUFFER_USAGE_INDIRECT_BUFFER_BIT, Buffer::Memory::Device);
  listB_ = Buffer(ctx_, listBytes, usage | VK_BUFFER_USAGE_INDIRECT_BUFFER_BIT, Buffer::Memory::Device);
  std::vector<std::uint32_t> dense(gpu::kGrowListHeader + brickCount_);
  dense[0] = brickCount_;
  dense[1] = dense[2] = 1;
  for (std::uint32_t i = 0; i < brickCount_; ++i) dense[gpu::kGrowListHeader + i] = i;
  denseList_ = Buffer(ctx_, listBytes, usage | VK_BUFFER_USAGE_INDIRECT_BUFFER_BIT, Buffer::Memory::Device);
  uploadToBuffer(ctx_, denseList_, dense.data(), listBytes);
  readback_ = Buffer(ctx_, 16, VK_BUFFER_USAGE_TRANSFER_DST_BIT, Buffer::Memory::HostVisible);
  const Eigen::Vector3i s = setup.seed - boxMin;
  const std::uint32_t seedIndex = std::uint32_t(s.x() + boxDims.x() * (s.y() + boxDims.y() * s.z()));
  const Eigen::Vector3i sb = s / B;
  const std::uint32_t seedBrick = std::uint32_t(sb.x() + bricks_.x() * (sb.y() + bricks_.y() * sb.z()));
  const std::uint32_t header[4] = {1, 1, 1, 0};
  ctx_.submitAndWait([&](VkCommandBuffer cmd) {
    vkCmdFillBuffer(cmd, keys_.handle(), 0, VK_WHOLE_SIZE, gpu::kGrowUnreached);
    vkCmdFillBuffer(cmd, accept_.handle(), 0, VK_WHOLE_SIZE, 0);
    vkCmdFillBuffer(cmd, flags_.handle(), 0, VK_WHOLE_SIZE, 0);
    vkCmdFillBuffer(cmd, reached_.handle(), 0, VK_WHOLE_SIZE, 0);
    vkCmdFillBuffer(cmd, listB_.handle(), 0, VK_WHOLE_SIZE, 0);
    fullBarrier(cmd);
    const std::uint32_t zero = 0;
    vkCmdUpdateBuffer(cmd, keys_.handle(), VkDeviceSize(seedIndex) * 4, 4, &zero);
    vkCmdUpdateBuffer(cmd, listA_.handle(), 0, sizeof(header), header);
    vkCmdUpdateBuffer(cmd, listA_.handle(), gpu::kGrowListHeader * 4, 4, &seedBrick);
    const std::uint32_t one[3] = {0, 1, 1};
    vkCmdUpdateBuffer(cmd, listB_.handle(), 0, 12, one);
  });
  bound_ = 0;
  resumeNeeded_ = false;
}

void GpuRegionGrower::record(VkCommandBuffer cmd, int rounds, bool dense, bool resume) {
  gpu::GrowPush push{};
  push.boxMin = glm::ivec4(boxMin_.x(), boxMin_.y(), boxMin_.z(), 0);
  push.boxDims = glm::ivec4(boxDims_.x(), boxDims_.y(), boxDims_.z(), int(setup_.criterion));
  push.brickDims = glm::ivec4(bricks_.x(), bricks_.y(), bricks_.z(), 0);
  push.seed = glm::ivec4(setup_.seed.x(), setup_.seed.y(), setup_.seed.z(), int(bound_));
  push.spacing = glm::vec4(setup_.spacing.x(), setup_.spacing.y(), setup_.spacing.z(), setup_.seedValue);
  push.tolerance = glm::vec4(setup_.tolerance, setup_.coreTolerance, 0, 0);
  auto compact = [&](const Buffer& into, bool fromReached) {
    vkCmdFillBuffer(cmd, into.handle(), 0, 4, 0);
    fullBarrier(cmd);
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, compact_.pipeline());
    DescriptorWriter()
        .buffer(gpu::kBindRegionCompactFlags, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, flags_.handle())
        .buffer(gpu::kBindRegionCompactList, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, into.handle())
        .buffer(gpu::kBindRegionCompactReached, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, reached_.handle())
        .push(ctx_, cmd, compact_);
    const CompactPush cp{brickCount_, fromReached ? 1u : 0u};
    vkCmdPushConstants(cmd, compact_.layout(), VK_SHADER_STAGE_COMPUTE_BIT, 0, sizeof(cp), &cp);
    vkCmdDispatch(cmd, (brickCount_ + HANDSON_COMPACT_GROUP_X - 1) / HANDSON_COMPACT_GROUP_X, 1, 1);
    fullBarrier(cmd);
  };
  if (resume) compact(listA_, true);  // the extent grew: every brick with reached voxels takes part again
  for (int r = 0; r < rounds; ++r) {
    const Buffer& list = dense ? denseList_ : listA_;
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, relax_.pipeline());
    DescriptorWriter()
        .sampledImage(gpu::kBindRegionGrowVolume, volume_.view(), sampler_.handle(), VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL)
        .buffer(gpu::kBindRegionGrowKeys, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, keys_.handle())
        .buffer(gpu::kBindRegionGrowAccept, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, accept_.handle())
        .buffer(gpu::kBindRegionGrowList, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, list.handle())
        .buffer(gpu::kBindRegionGrowFlags, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, flags_.handle())
        .buffer(gpu::kBindRegionGrowReached, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, reached_.handle())
        .push(ctx_, cmd, relax_);
    vkCmdPushConstants(cmd, relax_.layout(), VK_SHADER_STAGE_COMPUTE_BIT, 0, sizeof(push), &push);
    vkCmdDispatchIndirect(cmd, list.handle(), 0);
    fullBarrier(cmd);
    compact(listB_, false);
    std::swap(listA_, listB_);  // dense: the compacted list only tells when to stop
  }
  // Active count for the host: the header of the list the next round would use.
  VkBufferCopy c{0, 0, 4};
  vkCmdCopyBuffer(cmd, listA_.handle(), readback_.handle(), 1, &c);
  hostReadBarrier(cmd);
}

int GpuRegionGrower::growTo(std::uint32_t bound, bool dense, int roundsPerSubmit) {
  if (brickCount_ == 0) throw Error("region growing: begin() first");
  bool resume = bound > bound_ && resumeNeeded_;
  bound_ = std::max(bound_, bound);
  int rounds = 0;
  bricksDispatched_ = 0;
  for (int guard = 0; guard < 100000; ++guard) {
    ctx_.submitAndWait([&](VkCommandBuffer cmd) { record(cmd, roundsPerSubmit, dense, resume); });
    resume = false;
    rounds += roundsPerSubmit;
    readback_.invalidate();
    std::uint32_t active = 0;
    std::memcpy(&active, readback_.mapped(), 4);
    if (active == 0) break;
  }
  resumeNeeded_ = true;
  return rounds;
}

std::vector<std::uint32_t> GpuRegionGrower::readKeys() const {
  std::vector<std::uint32_t> out(keys_.size() / 4);
  downloadFromBuffer(ctx_, keys_, out.data(), keys_.size());
  return out;
}

}  // namespace handson::vk
