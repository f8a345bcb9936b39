#pragma once
// The frame graph's Vulkan backend: turns the graph's barriers into vkCmdPipelineBarrier2 calls,
// allocates transient resources (one set per frame in flight), binds imported ones, and times each
// pass with timestamp queries. Frames are double-buffered: beginFrame() waits only for the frame
// that used the same slot two submissions ago, so the CPU never waits for the frame it just sent.
#include <vulkan/vulkan.h>

#include <map>
#include <memory>
#include <string>
#include <vector>

#include "frame_graph.h"
#include "vk_resources.h"

namespace handson::vk {

class Context;

struct PassTiming {
  std::string name;
  double gpuMs = 0.0;
  PassId id = PassId::Unnamed;
};

class GraphExecutor final : public fg::Executor {
 public:
  explicit GraphExecutor(const Context& ctx, std::uint32_t framesInFlight = 2, std::uint32_t maxPasses = 32);
  ~GraphExecutor() override;
  GraphExecutor(const GraphExecutor&) = delete;
  GraphExecutor& operator=(const GraphExecutor&) = delete;

  /// Starts recording the next frame slot. Waits for that slot's previous submission (if any),
  /// and collects its pass timings into completedTimings(). Clears bindings.
  void beginFrame();
  VkCommandBuffer cmd() const;
  /// Index of the current slot (0 .. framesInFlight-1), for per-slot resources kept by passes.
  std::uint32_t slot() const { return current_; }
  std::uint32_t framesInFlight() const { return std::uint32_t(slots_.size()); }

  /// Binds an import declared without what it names (FrameGraph::importImage / importBuffer with a
  /// description only); imports made by vk::importImage / vk::importBuffer need none.
  void bindImage(fg::ResourceHandle h, const Image& image);
  void bindBuffer(fg::ResourceHandle h, const Buffer& buffer);
  /// An image not owned by a vk::Image (a swapchain image): known to the executor for barriers only.
  void bindRawImage(fg::ResourceHandle h, VkImage image);
  /// What a resource is this frame: bound, realized (transient) or named by its import.
  const Image& image(fg::ResourceHandle h) const;
  const Buffer& buffer(fg::ResourceHandle h) const;

  /// Ends and submits the frame. Optional semaphores for the window path.
  void submit(VkSemaphore wait = VK_NULL_HANDLE, VkPipelineStageFlags2 waitStage = 0, VkSemaphore signal = VK_NULL_HANDLE);
  /// Blocks until the last submitted frame has finished and collects its timings.
  void waitLastFrame();
  /// Blocks until a slot's last submission has finished and collects its timings.
  void waitSlot(std::uint32_t slot);
  /// Per-pass GPU times of the most recently completed frame (empty without timestamp support).
  const std::vector<PassTiming>& completedTimings() const { return completed_; }
  /// Per-pass GPU times of the last completed frame of a slot.
  const std::vector<PassTiming>& slotTimings(std::uint32_t slot) const { return slots_.at(slot).timings; }

  // fg::Executor
  void realizeTransient(fg::ResourceHandle handle, const fg::ResourceInfo& info) override;
  void beginPass(const fg::PassInfo& pass) override;
  void barriers(const std::vector<fg::Barrier>& list) override;
  void endPass(const fg::PassInfo& pass) override;
  void finalBarriers(const std::vector<fg::Barrier>& list) override;

  /// The graph this frame executes (needed to map handles to descriptions in barriers).
  void setGraph(const fg::FrameGraph* graph) { graph_ = graph; }

  /// Test only: records no barriers (the graph's still computed), so the tests' positive control
  /// can show that synchronization validation reports a missing one. Never set by the app.
  void dropBarriersForTest(bool drop) { dropBarriers_ = drop; }

 private:
  /// What an import made by vk::importImage / importBuffer names (null: none, or not this kind).
  const void* named(fg::ResourceHandle h, fg::ResourceKind kind) const;
  struct Slot {
    VkCommandBuffer cmd = VK_NULL_HANDLE;
    VkFence fence = VK_NULL_HANDLE;
    VkQueryPool queries = VK_NULL_HANDLE;
    bool pending = false;
    std::vector<fg::PassInfo> passes;  ///< timed this frame, in order
    std::vector<PassTiming> timings;
    std::map<std::string, std::unique_ptr<Image>> transientImages;
    std::map<std::string, std::unique_ptr<Buffer>> transientBuffers;
  };
  void collect(Slot& s);
  void release();
  void recordBarriers(const std::vector<fg::Barrier>& list);

  const Context& ctx_;
  VkCommandPool pool_ = VK_NULL_HANDLE;
  std::vector<Slot> slots_;
  std::uint32_t current_ = 0;
  std::uint32_t lastSubmitted_ = UINT32_MAX;
  std::uint32_t maxPasses_;
  bool recording_ = false;
  bool dropBarriers_ = false;
  const fg::FrameGraph* graph_ = nullptr;
  std::map<std::uint32_t, const Image*> images_;
  std::map<std::uint32_t, VkImage> rawImages_;
  std::map<std::uint32_t, const Buffer*> buffers_;
  std::vector<PassTiming> completed_;
};

/// Imports `image` into `graph` (its description, in the access it is in when the frame starts)
/// and binds it there: a resource owned outside the graph is declared and bound in one place, and
/// the executor finds it from the graph. `image` must outlive the frame's execution.
fg::ResourceHandle importImage(fg::FrameGraph& graph, std::string name, const Image& image, fg::Access current);
/// The same for a buffer.
fg::ResourceHandle importBuffer(fg::FrameGraph& graph, std::string name, const Buffer& buffer, fg::Access current);

}  // namespace handson::vk
