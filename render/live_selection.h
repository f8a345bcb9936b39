#pragma once
// A pinch's live selection grown on the GPU inside the renderer's frames (docs/region-growing.md,
// "Growth in the app"): each frame carries a few region-growing rounds (render/region_grow_pass.h)
// and live_mask.comp, which paints the selection into its box of the handle-id mask, so nothing
// crosses to the CPU while the fingers spread. The selected voxels are read back once, when the
// pinch ends. The seed statistics come from the CPU reference (interaction/region_grow.h, its
// setup), so the GPU selects exactly the reference's voxels.
#include <Eigen/Core>

#include <cstdint>
#include <optional>
#include <vector>

#include "frame_graph.h"
#include "region_grow_pass.h"
#include "vk_resources.h"

namespace handson::vk {

class Context;
class GraphExecutor;

/// CPU reference of live_mask.comp: the box's ids (x-fastest, one byte a voxel) from its keys, the
/// key bound and the ids the CPU painted there (base): the live id where key <= bound, else base.
std::vector<std::uint8_t> paintLiveBox(const std::vector<std::uint32_t>& keys, const std::vector<std::uint8_t>& base, std::uint32_t bound);

class LiveSelection {
 public:
  LiveSelection(const Context& ctx, const Image& volume, const Sampler& sampler);

  /// A new selection over the box (see GpuRegionGrower::begin: no frame using the last selection's
  /// buffers may still be in flight). `base`: the box's handle ids as the CPU paints them, boxDims.prod() bytes.
  /// `holdBound` > 0: the box replaces a selection already painted up to that bound (a larger box
  /// around the same seed); its frames grow without painting until the keys up to holdBound are
  /// final, so the mask keeps showing the old selection instead of less of it, then paint and grow on.
  void begin(const GrowSetup& setup, const Eigen::Vector3i& boxMin, const Eigen::Vector3i& boxDims, const std::vector<std::uint8_t>& base,
             std::uint32_t holdBound = 0);
  /// The fingers' extent as a key bound (growKeyBound): growing resumes; shrinking only repaints.
  void setBound(std::uint32_t bound);
  /// New base ids for the box (the handles changed under the pinch); no frame may be in flight.
  void setBase(const std::vector<std::uint8_t>& base);
  /// Region-growing rounds a frame carries while growing (default 8).
  void setRoundsPerFrame(int rounds) { rounds_ = rounds < 1 ? 1 : rounds; }

  /// The words a frame copies into the mask: the box's ids, rows of rowTexels bytes.
  struct Paint {
    fg::ResourceHandle ids;
    Eigen::Vector3i min, dims;
    std::uint32_t rowTexels = 0;
  };
  /// This frame's passes: rounds while growing, then the paint, if the box's ids may have changed
  /// since the last paint (nullopt and no passes otherwise). Before it, the frame that carried the
  /// last passes must be done (frameDone): the growth's state goes from one frame to the next.
  /// `volume`: the volume image as the frame imports it.
  std::optional<Paint> addPasses(fg::FrameGraph& g, fg::ResourceHandle volume);
  /// Once the frame with the passes is recorded, and after its fence.
  void submitted(const fg::FrameGraph& g);
  void frameDone();
  /// A frame carrying the passes was submitted and frameDone has not come yet.
  bool inFlight() const { return inFlight_; }
  /// Rounds still to run for the keys up to the bound to be final.
  bool growing() const { return holding_ || grower_.growing(); }
  /// Growing up to begin()'s holdBound, painting nothing yet.
  bool holding() const { return holding_; }

  /// Grows to the bound on submissions of its own (no frame may be in flight) and returns the
  /// selection's voxels: linear indices in a volume of `volumeDims`, ascending.
  std::vector<std::uint32_t> finish(const Eigen::Vector3i& volumeDims);

  const Eigen::Vector3i& boxMin() const { return grower_.boxMin(); }
  const Eigen::Vector3i& boxDims() const { return grower_.boxDims(); }
  std::uint32_t bound() const { return bound_; }

 private:
  const Context& ctx_;
  GpuRegionGrower grower_;
  ComputePipeline paint_;
  Buffer base_, ids_;  // the box's words: the CPU's ids, and the painted ones
  fg::Access idsState_ = fg::Access::None, baseState_ = fg::Access::None;
  fg::ResourceHandle baseHandle_, idsHandle_;
  std::uint32_t bound_ = 0, rowWords_ = 0, words_ = 0, hold_ = 0;
  int rounds_ = 8;
  bool repaint_ = false, inFlight_ = false, holding_ = false, painting_ = false;  // painting_: the frame in flight paints
};

}  // namespace handson::vk
