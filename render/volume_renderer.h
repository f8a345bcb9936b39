#pragma once
// Wires the passes into one frame graph per frame: raymarch (-> optional image readback) and
// picking (-> pick readback). Uploads the volume once (R16_UNORM 3D image), computes the brick
// ranges on the GPU, and keeps per-frame-in-flight uniform and readback buffers so that the CPU
// never waits for the frame it just submitted: results arrive when their slot comes round again
// (poll) or on an explicit wait.
#include <glm/glm.hpp>

#include <cstdint>
#include <memory>
#include <optional>
#include <vector>

#include "compute_passes.h"
#include "deform_pass.h"
#include "frame_renderer.h"
#include "live_selection.h"
#include "shaders/shared.h"
#include "tf_table.h"
#include "sim/base/progress.h"
#include "vk_graph_executor.h"
#include "vk_resources.h"
#include "volume_texture.h"

namespace handson {

/// Passes a caller adds after the raymarch (presenting to a window, drawing the UI), and the
/// semaphores the frame's submission waits on and signals.
class FrameExtension {
 public:
  virtual ~FrameExtension() = default;
  /// Declares the extra passes; `color` is the raymarched image (RGBA8).
  virtual void addPasses(fg::FrameGraph& graph, fg::ResourceHandle color) = 0;
  /// Binds what the extra passes imported without naming it (a swapchain image: bindRawImage);
  /// an import made with vk::importImage / importBuffer is bound already.
  virtual void bind(vk::GraphExecutor& executor) = 0;
  VkSemaphore waitSemaphore = VK_NULL_HANDLE;
  VkPipelineStageFlags2 waitStage = VK_PIPELINE_STAGE_2_TRANSFER_BIT;
  VkSemaphore signalSemaphore = VK_NULL_HANDLE;
};

/// A box of the handle-id mask to overwrite this frame (uploaded inside the frame graph).
struct MaskUpload {
  Eigen::Vector3i min{0, 0, 0}, dims{0, 0, 0};
  std::vector<std::uint8_t> ids;  ///< dims.prod() bytes, x-fastest
};
/// The box [min, min + dims) of a mask on a volume of `volumeDims` (x-fastest), as an upload.
MaskUpload maskBox(const std::vector<std::uint8_t>& mask, const Eigen::Vector3i& volumeDims, const Eigen::Vector3i& min, const Eigen::Vector3i& dims);

struct FrameRequest {
  gpu::RenderParams params{};
  const MaskUpload* maskUpload = nullptr;
  std::vector<glm::vec2> pickPoints;  ///< NDC (x right, y down)
  bool readbackImage = true;
  FrameExtension* extension = nullptr;
  /// While deforming: a new coarse state to show (nullptr: the deformed volume as it is).
  const CoarseFrameState* deform = nullptr;
  /// While deforming: refined fine node positions (voxel index space) to show instead; uploaded.
  const std::vector<Eigen::Vector4f>* deformFine = nullptr;
  /// While deforming: draw `deform` at its exact state, not lagging by up to
  /// DeformSetup::motionLagVoxels as frames during motion may (a replay's frames, an export).
  /// Without a new state, a frame after lagging ones always settles the deformation so.
  bool deformExact = false;
  /// > 0, with the ray jitter on (kFlagJitter): a still picture sums up to this many jitter
  /// phases, one a frame, and shows their running mean (render_params.h, setStillPhase). Any change
  /// of the picture starts a new sum: other parameters, size, transfer function, tints, labels,
  /// mask, volume, deformation. 0: no sum (one jitter phase, or none).
  int stillPhases = 0;
};

struct FrameResult {
  std::uint64_t frame = 0;  ///< sequence number returned by submit()
  int width = 0, height = 0;
  std::vector<std::uint8_t> rgba;  ///< empty unless the frame asked for it
  std::vector<gpu::PickResult> picks;
  std::vector<vk::PassTiming> timings;
};

class VolumeRenderer final : public FrameRenderer {
 public:
  explicit VolumeRenderer(const vk::Context& ctx, std::uint32_t framesInFlight = 2);
  ~VolumeRenderer();

  /// Uploads the volume and computes its brick grid on the GPU (read back for occupancy updates).
  void setVolume(const QuantizedVolume& volume, const ProgressFn& progress = {});
  /// Uploads a lookup table and the brick occupancy it implies. Throws handson::Error on a table
  /// whose shape is not one the passes read (TfTable::valid).
  void setTransferFunction(const TfTable& lut) override;
  /// Tint per handle id (gpu::kMaxHandleIds entries: rgb, weight; id 0 unused).
  void setHandleTints(const std::vector<glm::vec4>& tints);
  /// Organ labels on the volume's grid for the label tint (gpu::kFlagLabelTint; uploaded now,
  /// synchronously); empty: none (the tint is then off). The tint shows the rest anatomy, so it is
  /// off while the deformed volume is shown. Throws handson::Error on a size that is not the volume's.
  void setLabels(const std::vector<std::uint16_t>& labels);
  bool hasLabels() const { return hasLabels_; }
  /// Clears the handle-id mask (synchronously; for a new volume or a reset).
  void clearMask();
  const vk::Image& volumeImage() const { return volume_; }

  /// Shows the volume deformed by the simulation from now on: frames carrying a coarse state
  /// (FrameRequest::deform) run the deformation passes before the raymarch, and the raymarch and
  /// picking read the deformed volume and handle mask. Bricks overlapping the region count as
  /// occupied (tissue may move into them). The deformer copies what it needs from the setup.
  void beginDeformation(const vk::DeformSetup& setup);
  /// Back to the undeformed volume.
  void endDeformation();
  bool deforming() const { return bool(deformer_); }
  /// Whether the deformed images lag the last coarse state (frames during motion redo only the
  /// bricks whose tissue moved more than DeformSetup::motionLagVoxels); the next frame without a
  /// new state settles them.
  bool deformationLagging() const { return deformLagging_; }
  /// Brings the deformed images (and the strain volumes, when shown) to the last coarse state's
  /// exact answer now, waiting for frames in flight: before they are read back (an export).
  void settleDeformation();
  const vk::GpuDeformer* deformer() const { return deformer_.get(); }
  const vk::Sampler& sampler() const { return linear_; }

  /// A pinch's live selection grown on the GPU (render/live_selection.h): from the next frame on,
  /// frames carry its region-growing rounds and paint it into the handle-id mask (and, while
  /// deforming, into the deformed mask as a mask upload does) until the keys up to the bound are
  /// final; a frame with rounds waits for the last one that had some (the growth's state goes from
  /// frame to frame). `base`: the box's handle ids as the caller paints them (boxDims.prod() bytes).
  /// Waits for the frames in flight; replaces a live selection already running. `holdBound` > 0:
  /// the mask shows a selection up to that bound around the same seed, which the new box keeps
  /// showing until it has grown that far (LiveSelection::begin).
  void beginLiveSelection(const GrowSetup& setup, const Eigen::Vector3i& boxMin, const Eigen::Vector3i& boxDims,
                          const std::vector<std::uint8_t>& base, std::uint32_t holdBound = 0);
  /// The fingers' extent as a key bound (growKeyBound).
  void setLiveSelectionBound(std::uint32_t bound);
  /// New base ids for the box (the handles changed during the pinch); waits for the frames in flight.
  void setLiveSelectionBase(const std::vector<std::uint8_t>& base);
  /// Ends the live selection: grows to its bound (waiting for the GPU) and returns its voxels,
  /// ascending linear indices. The box keeps the last paint until the caller uploads its own ids.
  std::vector<std::uint32_t> finishLiveSelection();
  /// Ends it without a result (the box keeps the last paint, as above).
  void endLiveSelection();
  const vk::LiveSelection* liveSelection() const { return live_.get(); }
  /// Region-growing rounds a frame carries while a live selection grows (default 8; from the next begin).
  void setLiveRoundsPerFrame(int rounds) { liveRounds_ = rounds; }
  /// The handle-id mask (undeformed) as the frames left it, x-fastest; waits for the frames in flight.
  std::vector<std::uint8_t> readMask();

  /// Records and submits one frame; blocks only if the slot it reuses is still in flight.
  std::uint64_t submit(const FrameRequest& request) override;
  /// The jitter phases in the still frame's sum the last submitted frame shows (0: not a sum).
  int stillPhasesShown() const override { return stillShown_; }
  /// Results that completed since the last call (non-blocking; from slots that came round again).
  std::vector<FrameResult> takeCompleted();
  /// Waits for the last submitted frame and returns its results.
  FrameResult waitLast();

  const BrickGrid& bricks() const { return bricks_; }
  /// Brick occupancy as uploaded (while deforming, the region's bricks count as occupied).
  const std::vector<std::uint32_t>& occupancy() const { return uploadedOccupancy_; }
  /// The lookup table last set (empty before setTransferFunction).
  const TfTable& transferFunction() const { return lut_; }
  const vk::Context& context() const { return ctx_; }

 private:
  struct Slot {
    std::unique_ptr<vk::Buffer> params;
    std::unique_ptr<vk::Buffer> pickPoints, pickReadback, imageReadback, maskStaging;
    std::optional<std::uint64_t> frame;
    int width = 0, height = 0;
    std::size_t pickCount = 0;
    bool wantImage = false;
  };
  void harvest(std::uint32_t slot, std::vector<FrameResult>& out);
  void ensureBuffer(std::unique_ptr<vk::Buffer>& b, VkDeviceSize size, VkBufferUsageFlags usage);

  void uploadOccupancy();
  /// FrameRequest::stillPhases: the next phase of the still frame's sum, or a new sum (params).
  void sumStillFrame(const FrameRequest& req, gpu::RenderParams& params);
  /// A box of the handle-id mask written this frame: first voxel, last voxel (inclusive).
  using MaskBox = std::optional<std::pair<Eigen::Vector3i, Eigen::Vector3i>>;
  struct FrameBuild;  // one frame's graph and what submit() binds to it (volume_renderer.cpp)
  /// The raymarch's and picking's imported inputs, and the deformed images while deforming.
  void importInputs(FrameBuild& f, const Slot& s);
  /// The frame's writes into the handle-id mask (and the deformed one): the request's upload, then
  /// the live selection's paint. Returns the box they cover (nullopt: none).
  MaskBox addMaskWrites(FrameBuild& f, const FrameRequest& req, Slot& s);
  /// The deformation's passes; the raymarch and picking then read the deformed images (and strain).
  void addDeformation(FrameBuild& f, const FrameRequest& req, const MaskBox& maskWritten, bool wantStrain);
  /// The overlays' inputs (labels, strain, strain over its limit): stand-ins, their flags cleared,
  /// where the frame has none.
  void addOverlayInputs(FrameBuild& f, gpu::RenderParams& params);
  /// The still frame's running sum (kFlagAccumulate) at the frame's size (params: its phase).
  void addAccumulation(FrameBuild& f, const FrameRequest& req, gpu::RenderParams& params);
  /// The image's read-back (or the extension's passes on it) and the picks.
  void addReadbacks(FrameBuild& f, const FrameRequest& req, Slot& s, fg::ResourceHandle color);
  /// What is left to bind once the frame is compiled: the caller's extension's imports (every
  /// other import was bound where it was declared); the still sum's image marked as written.
  void bindFrame(FrameBuild& f, const FrameRequest& req);
  /// Waits for every frame in flight (and takes the live selection's growth state from them).
  void waitFramesInFlight();

  const vk::Context& ctx_;
  vk::GraphExecutor executor_;
  vk::RaymarchPass raymarch_;
  TfTable lut_;
  vk::PickPass pick_;
  vk::BrickPass brick_;
  vk::Sampler linear_, nearest_;
  vk::Image noStrain_;        ///< the raymarch's strain image without a strain overlay (one zero voxel)
  vk::Buffer jitter_;         ///< the raymarch's blue-noise tile (render/blue_noise.h)
  vk::Image accum_, noAccum_;  ///< a still frame's running sum (kFlagAccumulate), and the 1x1 stand-in
  fg::Access accumAccess_ = fg::Access::None, noAccumAccess_ = fg::Access::None;  ///< how each was last used
  std::uint64_t contentVersion_ = 0;  ///< bumped by every setter that changes the picture outside the request
  struct StillSum {
    gpu::RenderParams key{};     ///< the summed picture's parameters (picks and the sum's own fields cleared)
    std::uint64_t version = 0;   ///< contentVersion_ when it started
    int phases = 0;              ///< the phases it sums to (FrameRequest::stillPhases)
    int count = 0;               ///< phases in it (0: none)
  } still_;
  int stillShown_ = 0;
  vk::Image noOverLimit_;     ///< its strain-over-limit image without the limit highlight (one zero voxel)
  bool strainShown_ = false;  ///< the deformer's strain volume is current over the whole region
  vk::Image volume_, mask_;
  vk::Image labels_;          ///< organ labels (R16 unorm), or one zero voxel when there are none
  bool hasLabels_ = false;
  vk::Buffer tf_, occupancyBuffer_, handleTints_;
  BrickGrid bricks_;
  std::vector<std::uint32_t> occupancy_, uploadedOccupancy_;
  std::vector<Slot> slots_;
  std::vector<FrameResult> completed_;
  std::uint64_t nextFrame_ = 1;
  bool hasVolume_ = false, hasTf_ = false;
  std::unique_ptr<vk::GpuDeformer> deformer_;
  bool deformFirst_ = false;                 ///< the next deform frame redoes the whole region
  bool deformLagging_ = false;               ///< the deformed images lag lastDeform_ (see deformationLagging)
  std::optional<CoarseFrameState> lastDeform_;  ///< for a redo when the mask changes while deforming
  std::unique_ptr<vk::LiveSelection> live_;  ///< a pinch's selection growing on the GPU, or none
  std::uint32_t liveSlot_ = 0;               ///< the slot of the frame carrying its last passes
  int liveRounds_ = 8;                       ///< its rounds a frame
};

}  // namespace handson
