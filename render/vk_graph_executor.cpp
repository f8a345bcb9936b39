#include "vk_graph_executor.h"

#include <sstream>

#include "sim/base/error.h"
#include "vk_context.h"

namespace handson::vk {

namespace {

struct VkAccess {
  VkPipelineStageFlags2 stage;
  VkAccessFlags2 access;
};

VkAccess toVk(fg::Access a) {
  using fg::Access;
  switch (a) {
    case Access::None: return {VK_PIPELINE_STAGE_2_NONE, VK_ACCESS_2_NONE};
    case Access::Sampled: return {VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT, VK_ACCESS_2_SHADER_SAMPLED_READ_BIT};
    case Access::StorageRead: return {VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT, VK_ACCESS_2_SHADER_STORAGE_READ_BIT};
    case Access::StorageWrite: return {VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT, VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT};
    case Access::StorageReadWrite:
      return {VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT, VK_ACCESS_2_SHADER_STORAGE_READ_BIT | VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT};
    case Access::UniformRead: return {VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT, VK_ACCESS_2_UNIFORM_READ_BIT};
    // Every transfer command: copies, clears and the window's blits (a copy stage alone left the
    // blit to the swapchain unordered after the barrier: synchronization validation's
    // SYNC-HAZARD-READ-AFTER-WRITE, a torn picture on a GPU that overlaps them).
    case Access::TransferSrc: return {VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT, VK_ACCESS_2_TRANSFER_READ_BIT};
    case Access::TransferDst: return {VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT};
    case Access::HostRead: return {VK_PIPELINE_STAGE_2_HOST_BIT, VK_ACCESS_2_HOST_READ_BIT};
    case Access::HostWrite: return {VK_PIPELINE_STAGE_2_HOST_BIT, VK_ACCESS_2_HOST_WRITE_BIT};
    case Access::ColorAttachmentWrite:
      return {VK_PIPELINE_STAGE_2_COLOR_ATTACHMENT_OUTPUT_BIT, VK_ACCESS_2_COLOR_ATTACHMENT_READ_BIT | VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT};
    case Access::Present: return {VK_PIPELINE_STAGE_2_NONE, VK_ACCESS_2_NONE};
    case Access::IndirectRead: return {VK_PIPELINE_STAGE_2_DRAW_INDIRECT_BIT, VK_ACCESS_2_INDIRECT_COMMAND_READ_BIT};
  }
  return {VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT, VK_ACCESS_2_MEMORY_READ_BIT | VK_ACCESS_2_MEMORY_WRITE_BIT};
}

VkAccess toVkMask(fg::AccessMask m) {
  VkAccess out{VK_PIPELINE_STAGE_2_NONE, VK_ACCESS_2_NONE};
  for (unsigned i = 1; i < fg::kAccessCount; ++i)
    if (m & (1u << i)) {
      const VkAccess a = toVk(fg::Access(i));
      out.stage |= a.stage;
      out.access |= a.access;
    }
  return out;
}

VkImageLayout toVk(fg::Layout l) {
  switch (l) {
    case fg::Layout::Undefined: return VK_IMAGE_LAYOUT_UNDEFINED;
    case fg::Layout::General: return VK_IMAGE_LAYOUT_GENERAL;
    case fg::Layout::ShaderReadOnly: return VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL;
    case fg::Layout::TransferSrc: return VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL;
    case fg::Layout::TransferDst: return VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL;
    case fg::Layout::ColorAttachment: return VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL;
    case fg::Layout::PresentSrc: return VK_IMAGE_LAYOUT_PRESENT_SRC_KHR;
  }
  return VK_IMAGE_LAYOUT_GENERAL;
}

VkImageUsageFlags transientImageUsage() {
  return VK_IMAGE_USAGE_STORAGE_BIT | VK_IMAGE_USAGE_SAMPLED_BIT | VK_IMAGE_USAGE_TRANSFER_SRC_BIT | VK_IMAGE_USAGE_TRANSFER_DST_BIT;
}

std::string transientKey(const fg::ResourceInfo& info) {
  std::ostringstream k;
  k << info.name << '/' << info.image.width << 'x' << info.image.height << 'x' << info.image.depth << '/'
    << int(info.image.format) << '/' << info.buffer.size;
  return k.str();
}

}  // namespace

GraphExecutor::GraphExecutor(const Context& ctx, std::uint32_t framesInFlight, std::uint32_t maxPasses)
    : ctx_(ctx), maxPasses_(maxPasses) {
  if (framesInFlight == 0) framesInFlight = 1;
  VkCommandPoolCreateInfo pci{VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO};
  pci.flags = VK_COMMAND_POOL_CREATE_RESET_COMMAND_BUFFER_BIT;
  pci.queueFamilyIndex = ctx.queueFamily();
  check(vkCreateCommandPool(ctx.device(), &pci, nullptr, &pool_), "vkCreateCommandPool");
  slots_.resize(framesInFlight);
  try {
    for (auto& s : slots_) {
      VkCommandBufferAllocateInfo ai{VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO};
      ai.commandPool = pool_;
      ai.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
      ai.commandBufferCount = 1;
      check(vkAllocateCommandBuffers(ctx.device(), &ai, &s.cmd), "vkAllocateCommandBuffers");
      VkFenceCreateInfo fci{VK_STRUCTURE_TYPE_FENCE_CREATE_INFO};
      check(vkCreateFence(ctx.device(), &fci, nullptr, &s.fence), "vkCreateFence");
      if (ctx.timestampPeriodNs() > 0.0) {
        VkQueryPoolCreateInfo qci{VK_STRUCTURE_TYPE_QUERY_POOL_CREATE_INFO};
        qci.queryType = VK_QUERY_TYPE_TIMESTAMP;
        qci.queryCount = 2 * maxPasses_;
        check(vkCreateQueryPool(ctx.device(), &qci, nullptr, &s.queries), "vkCreateQueryPool");
      }
    }
  } catch (...) {
    release();
    throw;
  }
}

GraphExecutor::~GraphExecutor() { release(); }

void GraphExecutor::release() {
  VkDevice dev = ctx_.device();
  for (auto& s : slots_) {
    if (s.pending && s.fence) vkWaitForFences(dev, 1, &s.fence, VK_TRUE, UINT64_MAX);
    s.pending = false;
    if (s.fence) vkDestroyFence(dev, s.fence, nullptr);
    if (s.queries) vkDestroyQueryPool(dev, s.queries, nullptr);
    s.fence = VK_NULL_HANDLE;
    s.queries = VK_NULL_HANDLE;
    s.transientImages.clear();
    s.transientBuffers.clear();
  }
  if (pool_) vkDestroyCommandPool(dev, pool_, nullptr);
  pool_ = VK_NULL_HANDLE;
}

void GraphExecutor::collect(Slot& s) {
  if (!s.pending) return;
  check(vkWaitForFences(ctx_.device(), 1, &s.fence, VK_TRUE, UINT64_MAX), "vkWaitForFences");
  s.pending = false;
  s.timings.clear();
  completed_.clear();
  if (!s.queries || s.passes.empty()) return;
  std::vector<std::uint64_t> ticks(2 * s.passes.size());
  const VkResult r = vkGetQueryPoolResults(ctx_.device(), s.queries, 0, std::uint32_t(ticks.size()), ticks.size() * sizeof(std::uint64_t),
                                           ticks.data(), sizeof(std::uint64_t), VK_QUERY_RESULT_64_BIT | VK_QUERY_RESULT_WAIT_BIT);
  check(r, "vkGetQueryPoolResults");
  for (std::size_t i = 0; i < s.passes.size(); ++i)
    s.timings.push_back({s.passes[i].name, double(ticks[2 * i + 1] - ticks[2 * i]) * ctx_.timestampPeriodNs() * 1e-6, s.passes[i].id});
  completed_ = s.timings;
}

void GraphExecutor::beginFrame() {
  if (recording_) throw Error("GraphExecutor: beginFrame() while a frame is being recorded");
  current_ = (lastSubmitted_ == UINT32_MAX) ? 0 : (lastSubmitted_ + 1) % std::uint32_t(slots_.size());
  Slot& s = slots_[current_];
  collect(s);
  check(vkResetFences(ctx_.device(), 1, &s.fence), "vkResetFences");
  check(vkResetCommandBuffer(s.cmd, 0), "vkResetCommandBuffer");
  VkCommandBufferBeginInfo bi{VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO};
  bi.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT;
  check(vkBeginCommandBuffer(s.cmd, &bi), "vkBeginCommandBuffer");
  if (s.queries) vkCmdResetQueryPool(s.cmd, s.queries, 0, 2 * maxPasses_);
  s.passes.clear();
  images_.clear();
  rawImages_.clear();
  buffers_.clear();
  recording_ = true;
}

VkCommandBuffer GraphExecutor::cmd() const { return slots_[current_].cmd; }

void GraphExecutor::bindImage(fg::ResourceHandle h, const Image& image) { images_[h.id] = &image; }
void GraphExecutor::bindBuffer(fg::ResourceHandle h, const Buffer& buffer) { buffers_[h.id] = &buffer; }
void GraphExecutor::bindRawImage(fg::ResourceHandle h, VkImage image) { rawImages_[h.id] = image; }

const void* GraphExecutor::named(fg::ResourceHandle h, fg::ResourceKind kind) const {
  if (!graph_ || !h.valid()) return nullptr;
  const fg::ResourceInfo& info = graph_->resource(h);
  return info.imported && info.kind == kind ? info.external : nullptr;
}

const Image& GraphExecutor::image(fg::ResourceHandle h) const {
  auto it = images_.find(h.id);
  if (it != images_.end()) return *it->second;
  if (const void* p = named(h, fg::ResourceKind::Image)) return *static_cast<const Image*>(p);  // set only by vk::importImage
  throw Error("GraphExecutor: no image bound for a graph resource");
}

const Buffer& GraphExecutor::buffer(fg::ResourceHandle h) const {
  auto it = buffers_.find(h.id);
  if (it != buffers_.end()) return *it->second;
  if (const void* p = named(h, fg::ResourceKind::Buffer)) return *static_cast<const Buffer*>(p);  // set only by vk::importBuffer
  throw Error("GraphExecutor: no buffer bound for a graph resource");
}

fg::ResourceHandle importImage(fg::FrameGraph& graph, std::string name, const Image& image, fg::Access current) {
  return graph.importImage(std::move(name), image.desc(), current, &image);
}

fg::ResourceHandle importBuffer(fg::FrameGraph& graph, std::string name, const Buffer& buffer, fg::Access current) {
  return graph.importBuffer(std::move(name), {buffer.size()}, current, &buffer);
}

void GraphExecutor::realizeTransient(fg::ResourceHandle handle, const fg::ResourceInfo& info) {
  Slot& s = slots_[current_];
  const std::string key = transientKey(info);
  if (info.kind == fg::ResourceKind::Image) {
    auto& slot = s.transientImages[key];
    if (!slot) slot = std::make_unique<Image>(ctx_, info.image, transientImageUsage());
    images_[handle.id] = slot.get();
  } else {
    auto& slot = s.transientBuffers[key];
    if (!slot)
      slot = std::make_unique<Buffer>(ctx_, info.buffer.size,
                                      VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_SRC_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT,
                                      Buffer::Memory::Device);
    buffers_[handle.id] = slot.get();
  }
}

void GraphExecutor::beginPass(const fg::PassInfo& /*pass*/) {
  Slot& s = slots_[current_];
  if (s.queries && s.passes.size() < maxPasses_)
    vkCmdWriteTimestamp2(s.cmd, VK_PIPELINE_STAGE_2_TOP_OF_PIPE_BIT, s.queries, std::uint32_t(2 * s.passes.size()));
}

void GraphExecutor::endPass(const fg::PassInfo& pass) {
  Slot& s = slots_[current_];
  if (s.queries && s.passes.size() < maxPasses_) {
    vkCmdWriteTimestamp2(s.cmd, VK_PIPELINE_STAGE_2_BOTTOM_OF_PIPE_BIT, s.queries, std::uint32_t(2 * s.passes.size() + 1));
    s.passes.push_back(pass);
  }
}

void GraphExecutor::recordBarriers(const std::vector<fg::Barrier>& list) {
  if (!graph_) throw Error("GraphExecutor: setGraph() was not called");
  std::vector<VkImageMemoryBarrier2> ib;
  std::vector<VkBufferMemoryBarrier2> bb;
  for (const auto& b : list) {
    const fg::ResourceInfo& info = graph_->resource(b.resource);
    const VkAccess src = toVkMask(b.src);
    const VkAccess dst = toVkMask(b.dstAlso | fg::accessBit(b.dst));
    if (info.kind == fg::ResourceKind::Image) {
      VkImageMemoryBarrier2 m{VK_STRUCTURE_TYPE_IMAGE_MEMORY_BARRIER_2};
      m.srcStageMask = src.stage;
      m.srcAccessMask = src.access;
      m.dstStageMask = dst.stage;
      m.dstAccessMask = dst.access;
      m.oldLayout = toVk(b.oldLayout);
      m.newLayout = toVk(b.newLayout);
      m.srcQueueFamilyIndex = m.dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
      auto raw = rawImages_.find(b.resource.id);
      m.image = raw != rawImages_.end() ? raw->second : image(b.resource).handle();
      m.subresourceRange = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 1, 0, 1};
      ib.push_back(m);
    } else {
      VkBufferMemoryBarrier2 m{VK_STRUCTURE_TYPE_BUFFER_MEMORY_BARRIER_2};
      m.srcStageMask = src.stage;
      m.srcAccessMask = src.access;
      m.dstStageMask = dst.stage;
      m.dstAccessMask = dst.access;
      m.srcQueueFamilyIndex = m.dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
      m.buffer = buffer(b.resource).handle();
      m.size = VK_WHOLE_SIZE;
      bb.push_back(m);
    }
  }
  VkDependencyInfo dep{VK_STRUCTURE_TYPE_DEPENDENCY_INFO};
  dep.imageMemoryBarrierCount = std::uint32_t(ib.size());
  dep.pImageMemoryBarriers = ib.data();
  dep.bufferMemoryBarrierCount = std::uint32_t(bb.size());
  dep.pBufferMemoryBarriers = bb.data();
  vkCmdPipelineBarrier2(cmd(), &dep);
}

void GraphExecutor::barriers(const std::vector<fg::Barrier>& list) {
  if (!dropBarriers_) recordBarriers(list);
}
void GraphExecutor::finalBarriers(const std::vector<fg::Barrier>& list) {
  if (!dropBarriers_) recordBarriers(list);
}

void GraphExecutor::submit(VkSemaphore wait, VkPipelineStageFlags2 waitStage, VkSemaphore signal) {
  if (!recording_) throw Error("GraphExecutor: submit() without beginFrame()");
  Slot& s = slots_[current_];
  recording_ = false;
  check(vkEndCommandBuffer(s.cmd), "vkEndCommandBuffer");
  VkCommandBufferSubmitInfo cbi{VK_STRUCTURE_TYPE_COMMAND_BUFFER_SUBMIT_INFO};
  cbi.commandBuffer = s.cmd;
  VkSemaphoreSubmitInfo wi{VK_STRUCTURE_TYPE_SEMAPHORE_SUBMIT_INFO};
  wi.semaphore = wait;
  wi.stageMask = waitStage;
  VkSemaphoreSubmitInfo si{VK_STRUCTURE_TYPE_SEMAPHORE_SUBMIT_INFO};
  si.semaphore = signal;
  si.stageMask = VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT;
  VkSubmitInfo2 sub{VK_STRUCTURE_TYPE_SUBMIT_INFO_2};
  sub.commandBufferInfoCount = 1;
  sub.pCommandBufferInfos = &cbi;
  sub.waitSemaphoreInfoCount = wait ? 1 : 0;
  sub.pWaitSemaphoreInfos = &wi;
  sub.signalSemaphoreInfoCount = signal ? 1 : 0;
  sub.pSignalSemaphoreInfos = &si;
  check(ctx_.injectedFault(FaultSite::Submit) ? VK_ERROR_DEVICE_LOST : vkQueueSubmit2(ctx_.queue(), 1, &sub, s.fence),
        "vkQueueSubmit2");
  s.pending = true;
  lastSubmitted_ = current_;
}

void GraphExecutor::waitLastFrame() {
  if (lastSubmitted_ == UINT32_MAX) return;
  collect(slots_[lastSubmitted_]);
}

}  // namespace handson::vk

namespace handson::vk {
void GraphExecutor::waitSlot(std::uint32_t slot) { collect(slots_.at(slot)); }
}  // namespace handson::vk
