#pragma once
// GPU region growing over a box around the seed (shaders/region_grow.comp): keys per voxel of the
// box, lazily cached homogeneity, and GPU-built lists of active bricks consumed by indirect
// dispatch, so only the bricks on the moving front are worked on ("sparse"). "Dense" dispatches
// every brick of the box each round instead (the baseline). Each round is passes of the frame graph
// (which places the barriers), so a frame can carry a few rounds of a live selection. The CPU reference is
// interaction/region_grow.h; both give the same keys up to the bound, hence the same voxel set.
#include <Eigen/Core>

#include <array>
#include <cstdint>
#include <memory>
#include <vector>

#include "frame_graph.h"
#include "interaction/grow_setup.h"
#include "vk_graph_executor.h"
#include "vk_resources.h"

namespace handson::vk {

class Context;

class GpuRegionGrower {
 public:
  GpuRegionGrower(const Context& ctx, const Image& volume, const Sampler& sampler);

  /// Starts a selection: the box (volume voxels [boxMin, boxMin + boxDims)) must contain the seed.
  /// Allocates the box's buffers (no frame using the last ones may still be in flight); the next
  /// frame's first passes clear the keys and give the seed key 0 and its brick the active list.
  void begin(const GrowSetup& setup, const Eigen::Vector3i& boxMin, const Eigen::Vector3i& boxDims);
  /// Grows toward `bound` from the next round on (a bound larger than the last one grown to also
  /// wakes every brick holding reached voxels, once the active ones are done). Shrinking needs no
  /// GPU work (a threshold on keys).
  void setBound(std::uint32_t bound);

  /// The growth's buffers as imported into one frame graph.
  struct Bound {
    fg::ResourceHandle volume, keys, accept, flags, reached, lists[2], dense, activeHost;
  };
  /// Adds `rounds` rounds (relax over the active bricks, or every brick when `dense`; then the
  /// compaction of the next active list) to `g`, after the start's clears if begin() came since the
  /// last frame, and a readback of the active count. `volume`: the volume image if the frame already
  /// imports it (what it imports is bound there: vk::importBuffer). Call frameDone() once the frame has run and
  /// before the next addRounds: one frame of growth in flight at a time (the active count and the
  /// buffers' states are carried from one frame to the next).
  Bound addRounds(fg::FrameGraph& g, int rounds, bool dense, fg::ResourceHandle volume = {});
  /// After the frame's fence: keeps each buffer's last access for the next frame's barriers and
  /// reads the active count back (recordStates, then readActive).
  void frameDone(const fg::FrameGraph& g);
  /// Once the frame is recorded: each buffer's last access, for the next frame's barriers (frames
  /// run in order on one queue, so the next one may be recorded before this one has run).
  void recordStates(const fg::FrameGraph& g);
  /// After the frame's fence: the active count it left.
  void readActive();
  /// Bricks active for the next round, as of the last frame done.
  std::uint32_t activeBricks() const { return active_; }
  /// False once the keys up to the bound are final (no active brick, no resume pending).
  bool growing() const { return active_ != 0 || resumePending_; }

  /// Grows until no brick is active (the keys up to `bound` are final): frames of `roundsPerSubmit`
  /// rounds on an executor of its own, each waited for. Returns the rounds run.
  int growTo(std::uint32_t bound, bool dense = false, int roundsPerSubmit = 8);

  /// Keys of the box (x-fastest), kUnreached where not reached.
  std::vector<std::uint32_t> readKeys() const;
  const Eigen::Vector3i& boxMin() const { return boxMin_; }
  const Eigen::Vector3i& boxDims() const { return boxDims_; }

 private:
  enum BufferIndex { kKeys, kAccept, kFlags, kReached, kListA, kListB, kDense, kBufferCount };
  /// The imported buffers in BufferIndex order.
  static std::array<fg::ResourceHandle, kBufferCount> bufferHandles(const Bound& h) {
    return {h.keys, h.accept, h.flags, h.reached, h.lists[0], h.lists[1], h.dense};
  }
  void addStartPasses(fg::FrameGraph& g, const Bound& h);
  void addCompactPasses(fg::FrameGraph& g, fg::ResourceHandle flags, fg::ResourceHandle into, fg::ResourceHandle reached, bool fromReached);

  const Context& ctx_;
  const Image& volume_;
  const Sampler& sampler_;
  ComputePipeline relax_, compact_;  // relax_: built in begin() for the setup's criterion and keys (specialization constants)
  GrowCriterion relaxCriterion_ = GrowCriterion::Paper;
  bool relaxPathKeys_ = false;  // relax_ built with path keys (the second specialization constant)
  GrowSetup setup_{};
  Eigen::Vector3i boxMin_{0, 0, 0}, boxDims_{0, 0, 0}, bricks_{0, 0, 0};
  std::uint32_t brickCount_ = 0, bound_ = 0, seedIndex_ = 0, seedBrick_ = 0, active_ = 0;
  Buffer buffers_[kBufferCount];  // lists: kListA + current_ is the one the next round consumes
  Buffer activeHost_;
  fg::Access state_[kBufferCount] = {};
  int current_ = 0;
  bool startPending_ = false, resumePending_ = false, grown_ = false;  // grown_: rounds ran since begin()
  Bound handles_{};                                                                             // of the last addRounds
  std::unique_ptr<GraphExecutor> ownExecutor_;
};

}  // namespace handson::vk
