#include "region_grow_pass.h"

#include <algorithm>
#include <cstring>

#include "compute_passes.h"
#include "shaders/shared.h"
#include "shaders/spirv.h"
#include "sim/base/error.h"
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

constexpr const char* kBufferNames[] = {"grow-keys",     "grow-accept",   "grow-brick-flags", "grow-brick-reached",
                                        "grow-active-a", "grow-active-b", "grow-dense-list"};

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
  {
    const int B = HANDSON_GROW_BRICK;
    const Eigen::Vector3i b = (boxDims.array() + (B - 1)) / B;
    if (std::uint64_t(b.x()) * b.y() * b.z() > ctx_.properties().limits.maxComputeWorkGroupCount[0])
      throw Error("region growing: the box has more bricks than this device can dispatch at once");
  }
  const bool pathKeys = setup.criterion != GrowCriterion::Paper && setup.bound == GrowBound::Path;
  if (!relax_.pipeline() || relaxCriterion_ != setup.criterion || relaxPathKeys_ != pathKeys) {
    static_assert(int(GrowCriterion::Paper) == 0 && int(GrowCriterion::Smoothed) == 1 && int(GrowCriterion::Core) == 2, "region_grow.comp's codes");
    relax_ =
        ComputePipeline(ctx_, shaders::regionGrow(),
                        {{gpu::kBindRegionGrowVolume, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 1, VK_SHADER_STAGE_COMPUTE_BIT, nullptr},
                         storage(gpu::kBindRegionGrowKeys),
                         storage(gpu::kBindRegionGrowAccept),
                         storage(gpu::kBindRegionGrowList),
                         storage(gpu::kBindRegionGrowFlags),
                         storage(gpu::kBindRegionGrowReached)},
                        sizeof(gpu::GrowPush), {std::uint32_t(setup.criterion), pathKeys ? 1u : 0u});
    relaxCriterion_ = setup.criterion;
    relaxPathKeys_ = pathKeys;
  }
  setup_ = setup;
  boxMin_ = boxMin;
  boxDims_ = boxDims;
  const int B = HANDSON_GROW_BRICK;
  bricks_ = (boxDims.array() + (B - 1)) / B;
  brickCount_ = std::uint32_t(bricks_.x() * bricks_.y() * bricks_.z());
  const VkBufferUsageFlags usage = VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT | VK_BUFFER_USAGE_TRANSFER_SRC_BIT;
  const VkDeviceSize listBytes = (gpu::kGrowListHeader + brickCount_) * 4;
  buffers_[kKeys] = Buffer(ctx_, voxels * 4, usage, Buffer::Memory::Device);
  buffers_[kAccept] = Buffer(ctx_, voxels * 4, usage, Buffer::Memory::Device);
  buffers_[kFlags] = Buffer(ctx_, brickCount_ * 4, usage, Buffer::Memory::Device);
  buffers_[kReached] = Buffer(ctx_, brickCount_ * 4, usage, Buffer::Memory::Device);
  for (int l : {kListA, kListB, kDense})
    buffers_[l] = Buffer(ctx_, listBytes, usage | VK_BUFFER_USAGE_INDIRECT_BUFFER_BIT, Buffer::Memory::Device);
  std::vector<std::uint32_t> dense(gpu::kGrowListHeader + brickCount_);
  dense[0] = brickCount_;
  dense[1] = dense[2] = 1;
  for (std::uint32_t i = 0; i < brickCount_; ++i) dense[gpu::kGrowListHeader + i] = i;
  uploadToBuffer(ctx_, buffers_[kDense], dense.data(), listBytes);  // a fixed list, like a mesh upload
  for (auto& a : state_) a = fg::Access::None;                      // fresh buffers
  state_[kDense] = fg::Access::TransferDst;
  if (!activeHost_.handle()) activeHost_ = Buffer(ctx_, 16, VK_BUFFER_USAGE_TRANSFER_DST_BIT, Buffer::Memory::HostVisible);
  const Eigen::Vector3i s = setup.seed - boxMin;
  seedIndex_ = std::uint32_t(s.x() + boxDims.x() * (s.y() + boxDims.y() * s.z()));
  const Eigen::Vector3i sb = s / B;
  seedBrick_ = std::uint32_t(sb.x() + bricks_.x() * (sb.y() + bricks_.y() * sb.z()));
  current_ = 0;
  bound_ = 0;
  active_ = 1;
  startPending_ = true;
  resumePending_ = grown_ = false;
}

void GpuRegionGrower::setBound(std::uint32_t bound) {
  if (brickCount_ == 0) throw Error("region growing: begin() first");
  // The extent grew: the active bricks go on under the new bound, and once none is left every
  // brick with reached voxels takes part again (bricks whose front had stopped at the old bound
  // are in no list). Not at once: a brick flagged by a neighbour but not yet run holds no reached
  // voxel, and relisting from the reached bricks would drop it.
  if (bound > bound_ && grown_) resumePending_ = true;
  bound_ = std::max(bound_, bound);
}

void GpuRegionGrower::addStartPasses(fg::FrameGraph& g, const Bound& h) {
  using fg::Access;
  g.addPass(
      PassId::GrowClear,
      [&](fg::PassBuilder& b) {
        for (auto r : {h.keys, h.accept, h.flags, h.reached, h.lists[1 - current_]}) b.write(r, Access::TransferDst);
        b.sideEffect();
      },
      [h, next = h.lists[1 - current_]](fg::Executor& e) {
        GraphExecutor& x = vulkanExecutor(e);
        vkCmdFillBuffer(x.cmd(), x.buffer(h.keys).handle(), 0, VK_WHOLE_SIZE, gpu::kGrowUnreached);
        for (auto r : {h.accept, h.flags, h.reached, next}) vkCmdFillBuffer(x.cmd(), x.buffer(r).handle(), 0, VK_WHOLE_SIZE, 0);
      });
  g.addPass(
      PassId::GrowSeed,
      [&](fg::PassBuilder& b) {
        for (auto r : {h.keys, h.lists[0], h.lists[1]}) b.write(r, Access::TransferDst);
        b.sideEffect();
      },
      [h, cur = h.lists[current_], next = h.lists[1 - current_], seedIndex = seedIndex_, seedBrick = seedBrick_](fg::Executor& e) {
        GraphExecutor& x = vulkanExecutor(e);
        const std::uint32_t zero = 0, header[4] = {1, 1, 1, 0}, emptyHeader[3] = {0, 1, 1};
        vkCmdUpdateBuffer(x.cmd(), x.buffer(h.keys).handle(), VkDeviceSize(seedIndex) * 4, 4, &zero);
        vkCmdUpdateBuffer(x.cmd(), x.buffer(cur).handle(), 0, sizeof(header), header);
        vkCmdUpdateBuffer(x.cmd(), x.buffer(cur).handle(), gpu::kGrowListHeader * 4, 4, &seedBrick);
        vkCmdUpdateBuffer(x.cmd(), x.buffer(next).handle(), 0, sizeof(emptyHeader), emptyHeader);
      });
}

void GpuRegionGrower::addCompactPasses(fg::FrameGraph& g, fg::ResourceHandle flags, fg::ResourceHandle into, fg::ResourceHandle reached,
                                       bool fromReached) {
  using fg::Access;
  g.addPass(
      PassId::GrowListReset,
      [&](fg::PassBuilder& b) {
        b.write(into, Access::TransferDst);
        b.sideEffect();
      },
      [into](fg::Executor& e) {
        GraphExecutor& x = vulkanExecutor(e);
        vkCmdFillBuffer(x.cmd(), x.buffer(into).handle(), 0, 4, 0);
      });
  const PassResources r = PassResources()
                              .buffer(gpu::kBindRegionCompactFlags, flags, Access::StorageReadWrite)
                              .buffer(gpu::kBindRegionCompactList, into, Access::StorageReadWrite)
                              .buffer(gpu::kBindRegionCompactReached, reached, Access::StorageRead);
  g.addPass(
      fromReached ? PassId::GrowResume : PassId::GrowCompact,
      [&](fg::PassBuilder& b) {
        r.declare(b);
        b.sideEffect();
      },
      [this, r, fromReached](fg::Executor& e) {
        GraphExecutor& x = vulkanExecutor(e);
        vkCmdBindPipeline(x.cmd(), VK_PIPELINE_BIND_POINT_COMPUTE, compact_.pipeline());
        r.push(ctx_, x, compact_);
        const CompactPush cp{brickCount_, fromReached ? 1u : 0u};
        vkCmdPushConstants(x.cmd(), compact_.layout(), VK_SHADER_STAGE_COMPUTE_BIT, 0, sizeof(cp), &cp);
        vkCmdDispatch(x.cmd(), (brickCount_ + HANDSON_COMPACT_GROUP_X - 1) / HANDSON_COMPACT_GROUP_X, 1, 1);
      });
}

GpuRegionGrower::Bound GpuRegionGrower::addRounds(fg::FrameGraph& g, int rounds, bool dense, fg::ResourceHandle volume) {
  using fg::Access;
  if (brickCount_ == 0) throw Error("region growing: begin() first");
  Bound h;
  fg::ResourceHandle* slot[kBufferCount] = {&h.keys, &h.accept, &h.flags, &h.reached, &h.lists[0], &h.lists[1], &h.dense};
  for (int i = 0; i < kBufferCount; ++i) *slot[i] = importBuffer(g, kBufferNames[i], buffers_[i], state_[i]);
  h.volume = volume.valid() ? volume : importImage(g, "grow-volume", volume_, Access::Sampled);
  if (startPending_) addStartPasses(g, h);
  startPending_ = false;
  if (resumePending_ && active_ == 0) {  // active_: the list the next round consumes, as of the last frame done
    addCompactPasses(g, h.flags, h.lists[current_], h.reached, true);
    resumePending_ = false;
  }

  gpu::GrowPush push{};
  push.boxMin = glm::ivec4(boxMin_.x(), boxMin_.y(), boxMin_.z(), 0);
  push.boxDims = glm::ivec4(boxDims_.x(), boxDims_.y(), boxDims_.z(), int(setup_.criterion));
  push.brickDims = glm::ivec4(bricks_.x(), bricks_.y(), bricks_.z(), 0);
  push.seed = glm::ivec4(setup_.seed.x(), setup_.seed.y(), setup_.seed.z(), int(bound_));
  push.spacing = glm::vec4(setup_.spacing.x(), setup_.spacing.y(), setup_.spacing.z(), setup_.seedValue);
  push.tolerance = glm::vec4(setup_.tolerance, setup_.coreTolerance, 0, 0);
  const auto steps = growStepCosts(setup_.spacing);
  push.steps[0] = glm::uvec4(0, steps[1], steps[2], steps[3]);
  push.steps[1] = glm::uvec4(steps[4], steps[5], steps[6], steps[7]);
  if (rounds > 0) grown_ = true;
  for (int r = 0; r < rounds; ++r) {
    const fg::ResourceHandle list = dense ? h.dense : h.lists[current_];
    const PassResources res = PassResources()
                                  .sampled(gpu::kBindRegionGrowVolume, h.volume, sampler_)
                                  .use(list, Access::IndirectRead)
                                  .buffer(gpu::kBindRegionGrowList, list, Access::StorageRead)
                                  .buffer(gpu::kBindRegionGrowKeys, h.keys, Access::StorageReadWrite)
                                  .buffer(gpu::kBindRegionGrowAccept, h.accept, Access::StorageReadWrite)
                                  .buffer(gpu::kBindRegionGrowFlags, h.flags, Access::StorageReadWrite)
                                  .buffer(gpu::kBindRegionGrowReached, h.reached, Access::StorageReadWrite);
    g.addPass(
        PassId::GrowRelax,
        [&](fg::PassBuilder& b) {
          res.declare(b);
          b.sideEffect();
        },
        [this, res, list, push](fg::Executor& e) {
          GraphExecutor& x = vulkanExecutor(e);
          vkCmdBindPipeline(x.cmd(), VK_PIPELINE_BIND_POINT_COMPUTE, relax_.pipeline());
          res.push(ctx_, x, relax_);
          vkCmdPushConstants(x.cmd(), relax_.layout(), VK_SHADER_STAGE_COMPUTE_BIT, 0, sizeof(push), &push);
          vkCmdDispatchIndirect(x.cmd(), x.buffer(list).handle(), 0);
        });
    current_ = 1 - current_;  // dense: the compacted list only tells when to stop
    addCompactPasses(g, h.flags, h.lists[current_], h.reached, false);
  }
  // Active count for the host: the header of the list the next round would use.
  h.activeHost = importBuffer(g, "grow-active-host", activeHost_, Access::None);
  addReadbackPass(g, PassId::GrowActiveReadback, h.lists[current_], h.activeHost);
  handles_ = h;
  return h;
}

void GpuRegionGrower::frameDone(const fg::FrameGraph& g) {
  recordStates(g);
  readActive();
}

void GpuRegionGrower::recordStates(const fg::FrameGraph& g) {
  const auto imported = bufferHandles(handles_);
  for (int i = 0; i < kBufferCount; ++i) state_[i] = g.stateAfterFrame(imported[std::size_t(i)]);
}

void GpuRegionGrower::readActive() {
  activeHost_.invalidate();
  std::memcpy(&active_, activeHost_.mapped(), 4);
}

int GpuRegionGrower::growTo(std::uint32_t bound, bool dense, int roundsPerSubmit) {
  setBound(bound);
  if (!ownExecutor_) ownExecutor_ = std::make_unique<GraphExecutor>(ctx_, 1, 4 * std::uint32_t(roundsPerSubmit) + 8);
  GraphExecutor& x = *ownExecutor_;
  int rounds = 0;
  for (int guard = 0; guard < 100000 && growing(); ++guard) {
    x.beginFrame();
    fg::FrameGraph g;
    addRounds(g, roundsPerSubmit, dense);
    g.compile();
    x.setGraph(&g);
    g.execute(x);
    x.setGraph(nullptr);
    x.submit();
    x.waitLastFrame();
    frameDone(g);
    rounds += roundsPerSubmit;
  }
  return rounds;
}

std::vector<std::uint32_t> GpuRegionGrower::readKeys() const {
  std::vector<std::uint32_t> out(buffers_[kKeys].size() / 4);
  downloadFromBuffer(ctx_, buffers_[kKeys], out.data(), buffers_[kKeys].size());
  return out;
}

}  // namespace handson::vk
