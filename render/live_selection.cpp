#include "live_selection.h"

#include <algorithm>

#include "compute_passes.h"
#include "shaders/shared.h"
#include "shaders/spirv.h"
#include "sim/base/error.h"
#include "vk_context.h"
#include "vk_graph_executor.h"

namespace handson::vk {

static_assert(gpu::kLiveMaskId == 255u, "the live selection's id (interaction/handles.h: HandleSet::kLiveSelectionId)");

std::vector<std::uint8_t> paintLiveBox(const std::vector<std::uint32_t>& keys, const std::vector<std::uint8_t>& base, std::uint32_t bound) {
  if (keys.size() != base.size()) throw Error("live selection: keys and base ids differ in size");
  std::vector<std::uint8_t> out(base);
  for (std::size_t v = 0; v < keys.size(); ++v)
    if (keys[v] <= bound) out[v] = std::uint8_t(gpu::kLiveMaskId);
  return out;
}

namespace {

VkDescriptorSetLayoutBinding storage(std::uint32_t b) {
  return {b, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 1, VK_SHADER_STAGE_COMPUTE_BIT, nullptr};
}

}  // namespace

LiveSelection::LiveSelection(const Context& ctx, const Image& volume, const Sampler& sampler)
    : ctx_(ctx),
      grower_(ctx, volume, sampler),
      paint_(ctx, shaders::liveMask(), {storage(gpu::kBindLiveMaskKeys), storage(gpu::kBindLiveMaskBase), storage(gpu::kBindLiveMaskOut)},
             sizeof(gpu::LiveMaskPush)) {}

void LiveSelection::begin(const GrowSetup& setup, const Eigen::Vector3i& boxMin, const Eigen::Vector3i& boxDims,
                          const std::vector<std::uint8_t>& base, std::uint32_t holdBound) {
  grower_.begin(setup, boxMin, boxDims);  // checks the box
  rowWords_ = std::uint32_t(boxDims.x() + 3) / 4;
  words_ = rowWords_ * std::uint32_t(boxDims.y()) * std::uint32_t(boxDims.z());
  const VkBufferUsageFlags usage = VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT | VK_BUFFER_USAGE_TRANSFER_SRC_BIT;
  base_ = Buffer(ctx_, VkDeviceSize(words_) * 4, usage, Buffer::Memory::Device);
  ids_ = Buffer(ctx_, VkDeviceSize(words_) * 4, usage, Buffer::Memory::Device);
  idsState_ = fg::Access::None;
  bound_ = 0;
  inFlight_ = painting_ = false;
  hold_ = holdBound;
  holding_ = holdBound > 0;
  setBase(base);
}

void LiveSelection::setBase(const std::vector<std::uint8_t>& base) {
  const Eigen::Vector3i& d = grower_.boxDims();
  if (base.size() != std::size_t(d.prod())) throw Error("live selection: the base ids do not fit the box");
  // Rows padded to whole words (the shader's layout and the copy's row length).
  std::vector<std::uint8_t> padded(std::size_t(words_) * 4, 0);
  for (std::size_t row = 0; row < std::size_t(d.y()) * std::size_t(d.z()); ++row)
    std::copy_n(base.begin() + std::ptrdiff_t(row * std::size_t(d.x())), d.x(), padded.begin() + std::ptrdiff_t(row * rowWords_ * 4));
  uploadToBuffer(ctx_, base_, padded.data(), padded.size());
  baseState_ = fg::Access::TransferDst;
  repaint_ = true;
}

void LiveSelection::setBound(std::uint32_t bound) {
  if (bound == bound_) return;
  // Growth resumes for a larger bound; a smaller one only thresholds. Holding, the growth goes no
  // further than the held bound until it is reached.
  grower_.setBound(holding_ ? std::min(bound, hold_) : bound);
  bound_ = bound;
  repaint_ = true;
}

std::optional<LiveSelection::Paint> LiveSelection::addPasses(fg::FrameGraph& g, fg::ResourceHandle volume) {
  if (inFlight_) throw Error("live selection: the last frame's growth is not done yet");
  if (holding_ && !grower_.growing()) {
    // The keys up to the held bound are final: the box shows at least the old selection from now
    // on, and grows on toward the fingers' bound.
    holding_ = false;
    grower_.setBound(bound_);
    repaint_ = true;
  }
  const bool grow = grower_.growing();
  if (holding_) {
    grower_.addRounds(g, rounds_, false, volume);  // rounds only: the mask keeps the old selection
    inFlight_ = true;
    painting_ = false;
    return std::nullopt;
  }
  if (!repaint_ && !grow) return std::nullopt;
  const GpuRegionGrower::Bound h = grower_.addRounds(g, grow ? rounds_ : 0, false, volume);
  baseHandle_ = importBuffer(g, "live-base-ids", base_, baseState_);
  idsHandle_ = importBuffer(g, "live-ids", ids_, idsState_);
  const Eigen::Vector3i& d = grower_.boxDims();
  gpu::LiveMaskPush push{};
  push.boxDims = glm::ivec4(d.x(), d.y(), d.z(), int(rowWords_));
  push.bound = glm::uvec4(bound_, words_, 0, 0);
  const PassResources r = PassResources()
                              .buffer(gpu::kBindLiveMaskKeys, h.keys, fg::Access::StorageRead)
                              .buffer(gpu::kBindLiveMaskBase, baseHandle_, fg::Access::StorageRead)
                              .buffer(gpu::kBindLiveMaskOut, idsHandle_, fg::Access::StorageWrite);
  g.addPass(
      PassId::LiveMask, [&](fg::PassBuilder& b) { r.declare(b); },
      [this, r, push, maxGroups = std::min<std::uint32_t>(ctx_.properties().limits.maxComputeWorkGroupCount[0], 65535u)](fg::Executor& e) {
        GraphExecutor& x = vulkanExecutor(e);
        vkCmdBindPipeline(x.cmd(), VK_PIPELINE_BIND_POINT_COMPUTE, paint_.pipeline());
        r.push(ctx_, x, paint_);
        vkCmdPushConstants(x.cmd(), paint_.layout(), VK_SHADER_STAGE_COMPUTE_BIT, 0, sizeof(push), &push);
        const std::uint32_t groups = (push.bound.y + HANDSON_LIVE_MASK_GROUP_X - 1) / HANDSON_LIVE_MASK_GROUP_X;
        vkCmdDispatch(x.cmd(), std::min(groups, maxGroups), 1, 1);  // the shader strides over the rest
      });
  repaint_ = false;  // the rounds above are painted in this frame; more rounds paint again
  inFlight_ = painting_ = true;
  return Paint{idsHandle_, grower_.boxMin(), d, rowWords_ * 4};
}

void LiveSelection::submitted(const fg::FrameGraph& g) {
  grower_.recordStates(g);
  if (!painting_) return;
  idsState_ = g.stateAfterFrame(idsHandle_);
  baseState_ = g.stateAfterFrame(baseHandle_);
}

void LiveSelection::frameDone() {
  if (!inFlight_) return;
  grower_.readActive();
  inFlight_ = false;
}

std::vector<std::uint32_t> LiveSelection::finish(const Eigen::Vector3i& volumeDims) {
  if (inFlight_) throw Error("live selection: finish() with a frame in flight");
  holding_ = false;
  grower_.growTo(bound_);
  const std::vector<std::uint32_t> keys = grower_.readKeys();
  const Eigen::Vector3i& lo = grower_.boxMin();
  const Eigen::Vector3i& d = grower_.boxDims();
  std::vector<std::uint32_t> out;
  std::size_t b = 0;
  for (int k = 0; k < d.z(); ++k)
    for (int j = 0; j < d.y(); ++j)
      for (int i = 0; i < d.x(); ++i, ++b)
        if (keys[b] <= bound_)
          out.push_back(std::uint32_t(std::size_t(lo.x() + i) +
                                      std::size_t(volumeDims.x()) * (std::size_t(lo.y() + j) + std::size_t(volumeDims.y()) * std::size_t(lo.z() + k))));
  return out;  // ascending: x fastest, then y, then z, as linear indices are
}

}  // namespace handson::vk
