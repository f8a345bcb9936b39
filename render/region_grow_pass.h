#pragma once
// GPU region growing over a box around the seed (shaders/region_grow.comp): keys per voxel of the
// box, lazily cached homogeneity, and GPU-built lists of active bricks consumed by indirect
// dispatch, so only the bricks on the moving front are worked on ("sparse"). "Dense" dispatches
// every brick of the box each round instead (the baseline). The CPU reference is
// interaction/region_grow.h; both give the same keys up to the bound, hence the same voxel set.
#include <Eigen/Core>

#include <cstdint>
#include <vector>

#include "sim/grow_setup.h"
#include "vk_resources.h"

namespace handson::vk {

class Context;

class GpuRegionGrower {
 public:
  GpuRegionGrower(const Context& ctx, const Image& volume, const Sampler& sampler);

  /// Starts a selection: the box (volume voxels [boxMin, boxMin + boxDims)) must contain the seed;
  /// keys are cleared, the seed gets key 0 and its brick is active.
  void begin(const GrowSetup& setup, const Eigen::Vector3i& boxMin, const Eigen::Vector3i& boxDims);
  /// Grows until no brick is active (the keys up to `bound` are final). Records rounds of
  /// `roundsPerSubmit` relax + compact steps per submission and checks the active count between
  /// submissions. Returns the rounds run. Shrinking needs no GPU work (a threshold on keys).
  int growTo(std::uint32_t bound, bool dense = false, int roundsPerSubmit = 8);

  /// Keys of the box (x-fastest), kUnreached where not reached.
  std::vector<std::uint32_t> readKeys() const;
  const Eigen::Vector3i& boxMin() const { return boxMin_; }
  const Eigen::Vector3i& boxDims() const { return boxDims_; }
  /// Bricks dispatched in the last growTo (sum over rounds).
  std::uint64_t bricksDispatched() const { return bricksDispatched_; }

 private:
  void record(VkCommandBuffer cmd, int rounds, bool dense, bool resume);

  const Context& ctx_;
  const Image& volume_;
  const Sampler& sampler_;
  ComputePipeline relax_, compact_;  // relax_: built in begin() for the setup's criterion (a specialization constant)
  GrowCriterion relaxCriterion_ = GrowCriterion::Paper;
  GrowSetup setup_{};
  Eigen::Vector3i boxMin_{0, 0, 0}, boxDims_{0, 0, 0}, bricks_{0, 0, 0};
  std::uint32_t brickCount_ = 0, bound_ = 0;
  Buffer keys_, accept_, flags_, reached_, listA_, listB_, denseList_, readback_;
  bool resumeNeeded_ = false;
  std::uint64_t bricksDispatched_ = 0;
};

}  // namespace handson::vk
