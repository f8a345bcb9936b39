#include "volume_renderer.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <iomanip>
#include <sstream>

#include "blue_noise.h"
#include "render_params.h"
#include "sim/base/error.h"
#include "vk_context.h"

namespace handson {

using vk::Buffer;

MaskUpload maskBox(const std::vector<std::uint8_t>& mask, const Eigen::Vector3i& volumeDims, const Eigen::Vector3i& min, const Eigen::Vector3i& dims) {
  MaskUpload out{min, dims, std::vector<std::uint8_t>(std::size_t(dims.prod()))};
  const Eigen::Vector3i& d = volumeDims;
  std::size_t o = 0;
  for (int k = min.z(); k < min.z() + dims.z(); ++k)
    for (int j = min.y(); j < min.y() + dims.y(); ++j) {
      const std::size_t row = std::size_t(min.x()) + std::size_t(d.x()) * (std::size_t(j) + std::size_t(d.y()) * std::size_t(k));
      std::copy_n(mask.begin() + std::ptrdiff_t(row), dims.x(), out.ids.begin() + std::ptrdiff_t(o));
      o += std::size_t(dims.x());
    }
  return out;
}

VolumeRenderer::VolumeRenderer(const vk::Context& ctx, std::uint32_t framesInFlight)
    : ctx_(ctx),
      executor_(ctx, framesInFlight, 128),  // a frame can carry a live selection's rounds and the deformation before the raymarch
      raymarch_(ctx),
      pick_(ctx),
      brick_(ctx),
      linear_(ctx, true),
      nearest_(ctx, false),
      slots_(framesInFlight == 0 ? 1 : framesInFlight) {
  // The raymarch's strain image when there is no strain to show: one zero voxel.
  noStrain_ = vk::Image(ctx, {1, 1, 1, fg::Format::R32Sfloat}, VK_IMAGE_USAGE_SAMPLED_BIT | VK_IMAGE_USAGE_TRANSFER_DST_BIT, true);
  const float zero = 0.0f;
  vk::uploadToImage(ctx, noStrain_, &zero, sizeof zero, VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL);
  noOverLimit_ = vk::Image(ctx, {1, 1, 1, fg::Format::R32Sfloat}, VK_IMAGE_USAGE_SAMPLED_BIT | VK_IMAGE_USAGE_TRANSFER_DST_BIT, true);
  vk::uploadToImage(ctx, noOverLimit_, &zero, sizeof zero, VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL);
  // The raymarch's ray-start jitter tile (render/blue_noise.h), read whether or not jitter is on.
  const std::vector<std::uint32_t>& ranks = blueNoiseRanks();
  jitter_ = vk::Buffer(ctx, ranks.size() * sizeof(std::uint32_t), VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT,
                       vk::Buffer::Memory::Device);
  vk::uploadToBuffer(ctx, jitter_, ranks.data(), ranks.size() * sizeof(std::uint32_t));
  // The raymarch's accumulation image when a frame does not accumulate (never read then).
  noAccum_ = vk::Image(ctx, {1, 1, 1, fg::Format::Rgba32Sfloat}, VK_IMAGE_USAGE_STORAGE_BIT);
  setLabels({});
}

void VolumeRenderer::setLabels(const std::vector<std::uint16_t>& labels) {
  ++contentVersion_;  // a still frame's sum starts anew
  if (labels.empty()) {
    labels_ = vk::Image(ctx_, {1, 1, 1, fg::Format::R16Unorm}, VK_IMAGE_USAGE_SAMPLED_BIT | VK_IMAGE_USAGE_TRANSFER_DST_BIT, true);
    const std::uint16_t zero = 0;
    vk::uploadToImage(ctx_, labels_, &zero, sizeof zero, VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL);
    hasLabels_ = false;
    return;
  }
  if (!hasVolume_) throw Error("renderer: labels before a volume");
  const fg::ImageDesc d = volume_.desc();
  if (labels.size() != std::size_t(d.width) * d.height * d.depth) throw Error("renderer: the labels are not on the volume's grid");
  labels_ = vk::Image(ctx_, {d.width, d.height, d.depth, fg::Format::R16Unorm}, VK_IMAGE_USAGE_SAMPLED_BIT | VK_IMAGE_USAGE_TRANSFER_DST_BIT, true);
  vk::uploadToImage(ctx_, labels_, labels.data(), labels.size() * sizeof(std::uint16_t), VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL);
  hasLabels_ = true;
}

VolumeRenderer::~VolumeRenderer() {
  try {
    executor_.waitLastFrame();
  } catch (...) {
    // Device lost while shutting down: nothing more to wait for.
  }
}

void VolumeRenderer::ensureBuffer(std::unique_ptr<Buffer>& b, VkDeviceSize size, VkBufferUsageFlags usage) {
  if (b && b->size() >= size) return;
  b = std::make_unique<Buffer>(ctx_, size, usage, Buffer::Memory::HostVisible);
}

void VolumeRenderer::setVolume(const QuantizedVolume& volume, const ProgressFn& progress) {
  ++contentVersion_;  // a still frame's sum starts anew
  const auto& d = volume.geometry.dims;
  if (volume.data.size() != volume.geometry.voxelCount() || volume.data.empty())
    throw Error("renderer: volume data does not match its dimensions");
  endLiveSelection();  // its box and keys were on the old volume
  // The textures (16-bit values, 8-bit handle mask), the upload's staging copy, and the
  // deformation's copies of both: refused up front when the device cannot hold them.
  const double voxels = double(volume.data.size());
  const double needed = voxels * (2.0 + 1.0 + 2.0 + 2.0 + 1.0);
  if (const double heap = double(ctx_.deviceLocalHeapBytes()); heap > 0 && needed > heap) {
    std::ostringstream msg;
    msg << std::fixed << std::setprecision(0) << "the volume (" << d.x() << "x" << d.y() << "x" << d.z() << " voxels) needs about "
        << needed / double(1u << 20) << " MiB of GPU memory to render and deform, more than the " << heap / double(1u << 20)
        << " MiB of '" << ctx_.summary().name << "': resample it to fewer voxels (handson resample --voxels N)";
    throw Error(msg.str());
  }
  executor_.waitLastFrame();
  reportProgress(progress, 0.0, "uploading volume");
  const fg::ImageDesc desc{std::uint32_t(d.x()), std::uint32_t(d.y()), std::uint32_t(d.z()), fg::Format::R16Unorm};
  deformer_.reset();
  lastDeform_.reset();
  // Transfer source: the deformation starts from copies of the volume and the mask.
  volume_ = vk::Image(ctx_, desc, VK_IMAGE_USAGE_SAMPLED_BIT | VK_IMAGE_USAGE_TRANSFER_DST_BIT | VK_IMAGE_USAGE_TRANSFER_SRC_BIT, true);
  vk::uploadToImage(ctx_, volume_, volume.data.data(), volume.data.size() * sizeof(std::uint16_t),
                    VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL);
  reportProgress(progress, 0.6, "computing empty-space bricks");

  // Brick ranges on the GPU, through the graph, read back once.
  bricks_ = BrickGrid{};
  brickDims(d, bricks_.bx, bricks_.by, bricks_.bz);
  const VkDeviceSize rangeBytes = bricks_.count() * 2 * sizeof(std::uint32_t);
  Buffer ranges(ctx_, rangeBytes, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_SRC_BIT, Buffer::Memory::Device);
  Buffer readback(ctx_, rangeBytes, VK_BUFFER_USAGE_TRANSFER_DST_BIT, Buffer::Memory::HostVisible);
  fg::FrameGraph g;
  auto hVol = vk::importImage(g, "volume", volume_, fg::Access::Sampled);
  auto hRanges = vk::importBuffer(g, "brick-ranges", ranges, fg::Access::None);
  auto hRead = vk::importBuffer(g, "brick-ranges-host", readback, fg::Access::None);
  brick_.add(g, hVol, hRanges, volume_, linear_);
  vk::addReadbackPass(g, PassId::BrickReadback, hRanges, hRead);
  g.compile();
  executor_.beginFrame();
  executor_.setGraph(&g);
  g.execute(executor_);
  executor_.submit();
  executor_.waitLastFrame();
  readback.invalidate();
  bricks_.ranges.resize(bricks_.count() * 2);
  std::memcpy(bricks_.ranges.data(), readback.mapped(), rangeBytes);
  if (hasLabels_) setLabels({});  // they were on the old volume's grid
  mask_ = vk::Image(ctx_, {desc.width, desc.height, desc.depth, fg::Format::R8Unorm},
                    VK_IMAGE_USAGE_SAMPLED_BIT | VK_IMAGE_USAGE_TRANSFER_DST_BIT | VK_IMAGE_USAGE_TRANSFER_SRC_BIT, true);
  hasVolume_ = true;
  clearMask();
  setHandleTints(std::vector<glm::vec4>(gpu::kMaxHandleIds, glm::vec4(0.0f)));
  occupancy_.clear();
  uploadedOccupancy_.clear();
  hasTf_ = false;
  reportProgress(progress, 1.0, "volume ready");
}

void VolumeRenderer::setTransferFunction(const TfTable& lut) {
  ++contentVersion_;  // a still frame's sum starts anew
  if (!hasVolume_) throw Error("renderer: setVolume() must come before setTransferFunction()");
  if (!lut.valid()) throw Error("renderer: transfer function table has the wrong shape");
  executor_.waitLastFrame();
  occupancy_ = brickOccupancy(bricks_, lut.maxAlpha());
  lut_ = lut;
  const VkBufferUsageFlags usage = VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT;
  const std::size_t bytes = lut.entries.size() * sizeof(glm::vec4);
  tf_ = Buffer(ctx_, bytes, usage, Buffer::Memory::Device);
  vk::uploadToBuffer(ctx_, tf_, lut.entries.data(), bytes);
  hasTf_ = true;
  uploadOccupancy();
}

void VolumeRenderer::uploadOccupancy() {
  std::vector<std::uint32_t> occ = occupancy_;
  if (deformer_) {
    const int b = int(gpu::kBrickSize);
    const Eigen::Vector3i lo = deformer_->regionVoxelLo() / b, hi = deformer_->regionVoxelHi() / b;
    for (int z = std::max(0, lo.z() - 1); z <= std::min(bricks_.bz - 1, hi.z() + 1); ++z)
      for (int y = std::max(0, lo.y() - 1); y <= std::min(bricks_.by - 1, hi.y() + 1); ++y)
        for (int x = std::max(0, lo.x() - 1); x <= std::min(bricks_.bx - 1, hi.x() + 1); ++x) occ[(std::size_t(z) * bricks_.by + y) * bricks_.bx + x] = 1;
  }
  uploadedOccupancy_ = occ;
  if (occ.empty()) return;
  if (occupancyBuffer_.size() < occ.size() * sizeof(std::uint32_t))
    occupancyBuffer_ = Buffer(ctx_, occ.size() * sizeof(std::uint32_t), VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT,
                              Buffer::Memory::Device);
  vk::uploadToBuffer(ctx_, occupancyBuffer_, occ.data(), occ.size() * sizeof(std::uint32_t));
}

void VolumeRenderer::beginDeformation(const vk::DeformSetup& setup) {
  ++contentVersion_;  // a still frame's sum starts anew
  if (!hasVolume_) throw Error("renderer: no volume to deform");
  executor_.waitLastFrame();
  for (std::uint32_t i = 0; i < slots_.size(); ++i) executor_.waitSlot(i);
  deformer_ = std::make_unique<vk::GpuDeformer>(ctx_, volume_, mask_, setup, std::uint32_t(slots_.size()));
  deformFirst_ = true;
  lastDeform_.reset();
  if (hasTf_) uploadOccupancy();
}

void VolumeRenderer::endDeformation() {
  ++contentVersion_;  // a still frame's sum starts anew
  if (!deformer_) return;
  executor_.waitLastFrame();
  for (std::uint32_t i = 0; i < slots_.size(); ++i) executor_.waitSlot(i);
  deformer_.reset();
  lastDeform_.reset();
  if (hasTf_) uploadOccupancy();
}

void VolumeRenderer::setHandleTints(const std::vector<glm::vec4>& tints) {
  ++contentVersion_;  // a still frame's sum starts anew
  if (tints.size() != gpu::kMaxHandleIds) throw Error("renderer: the handle tint table has the wrong size");
  executor_.waitLastFrame();
  for (std::uint32_t i = 0; i < slots_.size(); ++i) executor_.waitSlot(i);
  if (!handleTints_.handle())
    handleTints_ = Buffer(ctx_, tints.size() * sizeof(glm::vec4), VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT,
                          Buffer::Memory::Device);
  vk::uploadToBuffer(ctx_, handleTints_, tints.data(), tints.size() * sizeof(glm::vec4));
}

void VolumeRenderer::clearMask() {
  ++contentVersion_;  // a still frame's sum starts anew
  if (!hasVolume_) throw Error("renderer: no volume");
  waitFramesInFlight();
  ctx_.submitAndWait([&](VkCommandBuffer cmd) {
    vk::transitionImage(cmd, mask_.handle(), VK_IMAGE_LAYOUT_UNDEFINED, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL);
    const VkClearColorValue zero{};
    const VkImageSubresourceRange range{VK_IMAGE_ASPECT_COLOR_BIT, 0, 1, 0, 1};
    vkCmdClearColorImage(cmd, mask_.handle(), VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, &zero, 1, &range);
    vk::transitionImage(cmd, mask_.handle(), VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL);
  });
}

void VolumeRenderer::waitFramesInFlight() {
  for (std::uint32_t i = 0; i < slots_.size(); ++i) executor_.waitSlot(i);
  if (live_) live_->frameDone();
}

void VolumeRenderer::beginLiveSelection(const GrowSetup& setup, const Eigen::Vector3i& boxMin, const Eigen::Vector3i& boxDims,
                                        const std::vector<std::uint8_t>& base, std::uint32_t holdBound) {
  if (!hasVolume_) throw Error("renderer: no volume");
  waitFramesInFlight();  // the last selection's buffers may still be read
  if (!live_) live_ = std::make_unique<vk::LiveSelection>(ctx_, volume_, linear_);
  try {
    live_->setRoundsPerFrame(liveRounds_);
    live_->begin(setup, boxMin, boxDims, base, holdBound);
  } catch (...) {
    live_.reset();  // never a half-begun selection in the next frames
    throw;
  }
}

void VolumeRenderer::setLiveSelectionBound(std::uint32_t bound) {
  if (!live_) throw Error("renderer: no live selection");
  live_->setBound(bound);
}

void VolumeRenderer::setLiveSelectionBase(const std::vector<std::uint8_t>& base) {
  if (!live_) throw Error("renderer: no live selection");
  waitFramesInFlight();
  live_->setBase(base);
}

std::vector<std::uint32_t> VolumeRenderer::finishLiveSelection() {
  if (!live_) throw Error("renderer: no live selection");
  waitFramesInFlight();
  const fg::ImageDesc d = volume_.desc();
  std::vector<std::uint32_t> voxels = live_->finish(Eigen::Vector3i(int(d.width), int(d.height), int(d.depth)));
  live_.reset();
  return voxels;
}

void VolumeRenderer::endLiveSelection() {
  if (!live_) return;
  waitFramesInFlight();
  live_.reset();
}

std::vector<std::uint8_t> VolumeRenderer::readMask() {
  if (!hasVolume_) throw Error("renderer: no volume");
  waitFramesInFlight();
  const fg::ImageDesc d = mask_.desc();
  std::vector<std::uint8_t> out(std::size_t(d.width) * d.height * d.depth);
  vk::downloadFromImage(ctx_, mask_, out.data(), out.size());
  return out;
}

void VolumeRenderer::harvest(std::uint32_t slot, std::vector<FrameResult>& out) {
  Slot& s = slots_[slot];
  if (!s.frame) return;
  FrameResult r;
  r.frame = *s.frame;
  r.width = s.width;
  r.height = s.height;
  if (s.wantImage) {
    s.imageReadback->invalidate();
    r.rgba.resize(std::size_t(s.width) * s.height * 4);
    std::memcpy(r.rgba.data(), s.imageReadback->mapped(), r.rgba.size());
  }
  if (s.pickCount) {
    s.pickReadback->invalidate();
    r.picks.resize(s.pickCount);
    std::memcpy(r.picks.data(), s.pickReadback->mapped(), s.pickCount * sizeof(gpu::PickResult));
  }
  r.timings = executor_.slotTimings(slot);
  s.frame.reset();
  out.push_back(std::move(r));
}

namespace {

/// A box of ids to copy into the handle-id mask: rows of rowTexels texels (0: the box's width) in `src`.
struct MaskCopy {
  PassId id;
  fg::ResourceHandle src;
  Eigen::Vector3i min, dims;
  std::uint32_t rowTexels = 0;
};

/// Copies a box of ids into the handle-id mask and, while deforming, into the deformed mask:
/// outside the simulated region the ids hold at once; inside it the region's redo carries them
/// through the deformation.
void addMaskCopy(fg::FrameGraph& g, const MaskCopy& c, fg::ResourceHandle mask, fg::ResourceHandle deformedMask) {
  g.addPass(
      c.id,
      [&](fg::PassBuilder& b) {
        b.read(c.src, fg::Access::TransferSrc);
        b.write(mask, fg::Access::TransferDst);
        if (deformedMask.valid()) b.write(deformedMask, fg::Access::TransferDst);
      },
      [c, mask, deformedMask](fg::Executor& e) {
        auto& x = vk::vulkanExecutor(e);
        VkBufferImageCopy r{};
        r.bufferRowLength = c.rowTexels;
        r.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
        r.imageOffset = {c.min.x(), c.min.y(), c.min.z()};
        r.imageExtent = {std::uint32_t(c.dims.x()), std::uint32_t(c.dims.y()), std::uint32_t(c.dims.z())};
        vkCmdCopyBufferToImage(x.cmd(), x.buffer(c.src).handle(), x.image(mask).handle(), VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, 1, &r);
        if (deformedMask.valid())
          vkCmdCopyBufferToImage(x.cmd(), x.buffer(c.src).handle(), x.image(deformedMask).handle(), VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, 1, &r);
      });
}

}  // namespace

// One frame's graph and what submit() binds to it.
struct VolumeRenderer::FrameBuild {
  fg::FrameGraph g;
  vk::MarchInputs in;                 ///< what the raymarch and picking read (the deformed images while deforming)
  vk::GpuDeformer::Outputs deformed;  ///< the deformed images, while deforming
  fg::ResourceHandle sourceVolume, sourceMask;  ///< the source images, bound to the renderer's own
  fg::ResourceHandle maskStaging, imageHost, pickIn, pickHost;  ///< per-slot buffers, where used
  bool ownStrain = false, ownOverLimit = false;  ///< the overlays' stand-ins are bound
  vk::Image* accum = nullptr;         ///< the still frame's sum, or its 1x1 stand-in
  fg::Access* accumAccess = nullptr;  ///< how it was last used
};

VolumeRenderer::MaskBox VolumeRenderer::addMaskWrites(FrameBuild& f, const FrameRequest& req, Slot& s) {
  fg::FrameGraph& g = f.g;
  const fg::ResourceHandle mask = f.in.mask, deformedMask = f.deformed.mask;
  MaskBox box;
  auto cover = [&box](const Eigen::Vector3i& mn, const Eigen::Vector3i& dm) {
    const Eigen::Vector3i hi = mn + dm - Eigen::Vector3i::Ones();
    box = box ? std::make_pair(box->first.cwiseMin(mn), box->second.cwiseMax(hi)) : std::make_pair(mn, hi);
  };
  if (req.maskUpload) {
    const MaskUpload& up = *req.maskUpload;
    const fg::ImageDesc md = mask_.desc();
    const Eigen::Vector3i mdims(int(md.width), int(md.height), int(md.depth));
    if ((up.min.array() < 0).any() || (up.dims.array() <= 0).any() || ((up.min + up.dims).array() > mdims.array()).any() ||
        up.ids.size() != std::size_t(up.dims.prod()))
      throw Error("renderer: the mask upload does not fit the volume");
    ensureBuffer(s.maskStaging, up.ids.size(), VK_BUFFER_USAGE_TRANSFER_SRC_BIT);
    std::memcpy(s.maskStaging->mapped(), up.ids.data(), up.ids.size());
    s.maskStaging->flush();
    f.maskStaging = vk::importBuffer(g, "mask-staging", *s.maskStaging, fg::Access::HostWrite);
    addMaskCopy(g, {PassId::MaskUpload, f.maskStaging, up.min, up.dims}, mask, deformedMask);
    cover(up.min, up.dims);
  }
  // The live selection's rounds and paint (after the upload: its base holds the uploaded ids).
  if (live_)
    if (const auto paint = live_->addPasses(g, f.in.volume)) {
      addMaskCopy(g, {PassId::LiveMaskCopy, paint->ids, paint->min, paint->dims, paint->rowTexels}, mask, deformedMask);
      cover(paint->min, paint->dims);
    }
  return box;
}

// The deformation: new coarse state (or a mask change to carry over) -> its passes, whose outputs
// the raymarch and picking read (`in`); otherwise the deformed images as they are. With the strain
// overlay or the limit highlight, the strain passes after them (or the strain volumes as they are).
void VolumeRenderer::addDeformation(FrameBuild& f, const FrameRequest& req, const MaskBox& maskWritten, bool wantStrain) {
  fg::FrameGraph& g = f.g;
  vk::MarchInputs& in = f.in;
  const vk::GpuDeformer::Outputs& deformed = f.deformed;
  const vk::GpuDeformer::FrameImports at{executor_.slot(), in.volume, in.mask, deformed};
  if (req.deform) lastDeform_ = *req.deform;
  bool uploadInRegion = false;
  if (maskWritten) {
    const auto& [lo, hi] = *maskWritten;
    uploadInRegion = (lo.array() <= deformer_->regionVoxelHi().array()).all() && (hi.array() >= deformer_->regionVoxelLo().array()).all();
    g.exportResource(deformed.mask, fg::Access::Sampled);
  }
  // The strain overlay, when first shown, needs the whole region's strain: a region redo.
  const bool whole = deformFirst_ || uploadInRegion || (wantStrain && !strainShown_);  // redo the deformed images over the region
  bool passes = false;
  if (req.deformFine) {
    if (lastDeform_) deformer_->setHandlePoses(lastDeform_->handles);  // the refined state's poses
    deformer_->addPassesFromPositions(g, *req.deformFine, whole ? vk::Redo::Region : vk::Redo::Bricks, at);
    deformFirst_ = false;
    deformLagging_ = false;  // refined positions are drawn as they are
    passes = true;
  } else if (lastDeform_ && (req.deform || whole || deformLagging_)) {
    // During motion only the bricks whose tissue moved more than the allowed lag are redone; the
    // first frame without a new state (or one asked to be exact) brings every brick to the exact state.
    const bool moving = req.deform && !req.deformExact;
    const vk::Redo redo = whole ? vk::Redo::Region : moving ? vk::Redo::BricksDuringMotion : vk::Redo::Bricks;
    deformer_->addPasses(g, *lastDeform_, redo, at);
    if (!req.deform) ++contentVersion_;  // the settled picture differs: a still frame's sum starts anew
    deformFirst_ = false;
    deformLagging_ = redo != vk::Redo::Bricks;  // a region redo takes nodes at commitVoxels: settled next
    passes = true;
  }
  in.volume = deformed.volume;
  in.mask = deformed.mask;
  if (wantStrain && passes) {
    const auto st = deformer_->addStrainPass(g);
    in.strain = st.volume;
    in.overLimit = st.overLimit;
    strainShown_ = true;
  } else if (wantStrain && strainShown_) {
    const auto st = deformer_->importStrainVolume(g);
    in.strain = st.volume;
    in.overLimit = st.overLimit;
  }
  if (!wantStrain) strainShown_ = false;  // shown again later: redone over the region then
}

void VolumeRenderer::settleDeformation() {
  if (!deformer_ || !lastDeform_ || !deformLagging_) return;
  executor_.waitLastFrame();
  for (std::uint32_t i = 0; i < slots_.size(); ++i) executor_.waitSlot(i);
  deformer_->settle(*lastDeform_, strainShown_);
  deformLagging_ = false;
  ++contentVersion_;
}

void VolumeRenderer::sumStillFrame(const FrameRequest& req, gpu::RenderParams& params) {
  stillShown_ = 0;
  if (req.stillPhases <= 0 || !(params.flags & gpu::kFlagJitter)) {
    still_.count = 0;
    return;
  }
  gpu::RenderParams key = params;
  key.pickCount = 0;
  key.flags &= ~(gpu::kFlagAccumulate | gpu::kFlagShowSum);
  key.jitterPhase = key.summedFrames = 0;
  const bool same = still_.count > 0 && still_.version == contentVersion_ && still_.phases == req.stillPhases && !req.maskUpload &&
                    !req.deform && !req.deformFine && std::memcmp(&key, &still_.key, sizeof key) == 0;
  const int before = same ? still_.count : 0;
  setStillPhase(params, before, req.stillPhases);
  still_ = {key, contentVersion_, req.stillPhases, std::min(before + 1, req.stillPhases)};
  stillShown_ = still_.count;
}


void VolumeRenderer::importInputs(FrameBuild& f, const Slot& s) {
  fg::FrameGraph& g = f.g;
  vk::MarchInputs& in = f.in;
  in.params = vk::importBuffer(g, "params", *s.params, fg::Access::HostWrite);
  in.volume = vk::importImage(g, "volume", volume_, fg::Access::Sampled);
  in.tf = vk::importBuffer(g, "transfer-function", tf_, fg::Access::StorageRead);
  in.occupancy = vk::importBuffer(g, "occupancy", occupancyBuffer_, fg::Access::StorageRead);
  in.mask = vk::importImage(g, "handle-mask", mask_, fg::Access::Sampled);
  in.handles = vk::importBuffer(g, "handle-tints", handleTints_, fg::Access::StorageRead);
  in.jitter = vk::importBuffer(g, "jitter-tile", jitter_, fg::Access::StorageRead);
  // While deforming, the deformed images are what the raymarch and picking read.
  if (deformer_) f.deformed = deformer_->importOutputs(g);
}

void VolumeRenderer::addOverlayInputs(FrameBuild& f, gpu::RenderParams& params) {
  vk::MarchInputs& in = f.in;
  in.labels = vk::importImage(f.g, "labels", labels_, fg::Access::Sampled);
  if (!hasLabels_ || !(in.volume == f.sourceVolume)) params.flags &= ~gpu::kFlagLabelTint;  // none, or deformed anatomy shown
  f.ownStrain = !in.strain.valid();
  if (f.ownStrain) {
    in.strain = vk::importImage(f.g, "no-strain", noStrain_, fg::Access::Sampled);
    params.flags &= ~gpu::kFlagStrainOverlay;  // nothing to show (not deforming): no overlay
  }
  f.ownOverLimit = !in.overLimit.valid();
  if (f.ownOverLimit) {
    in.overLimit = vk::importImage(f.g, "no-strain-over-limit", noOverLimit_, fg::Access::Sampled);
    params.flags &= ~gpu::kFlagLimitHighlight;  // not deforming, or no limits: nothing to highlight
  }
}

void VolumeRenderer::addAccumulation(FrameBuild& f, const FrameRequest& req, gpu::RenderParams& params) {
  const std::uint32_t w = std::uint32_t(params.outputWidth), h = std::uint32_t(params.outputHeight);
  sumStillFrame(req, params);
  const bool accumulate = (params.flags & gpu::kFlagAccumulate) != 0;
  if (accumulate && (!accum_.handle() || accum_.desc().width != w || accum_.desc().height != h)) {
    if (accum_.handle()) vkDeviceWaitIdle(ctx_.device());  // frames in flight may still use the old one (a resize: rare)
    accum_ = vk::Image(ctx_, {w, h, 1, fg::Format::Rgba32Sfloat}, VK_IMAGE_USAGE_STORAGE_BIT);
    accumAccess_ = fg::Access::None;
    params.summedFrames = 0;  // nothing summed in it yet: this phase starts the sum
    params.flags &= ~gpu::kFlagShowSum;
  }
  f.accum = accumulate ? &accum_ : &noAccum_;
  f.accumAccess = accumulate ? &accumAccess_ : &noAccumAccess_;
  f.in.accum = vk::importImage(f.g, accumulate ? "accumulation" : "no-accumulation", *f.accum, *f.accumAccess);
}

void VolumeRenderer::addReadbacks(FrameBuild& f, const FrameRequest& req, Slot& s, fg::ResourceHandle color) {
  fg::FrameGraph& g = f.g;
  s.width = req.params.outputWidth;
  s.height = req.params.outputHeight;
  s.wantImage = req.readbackImage;
  if (req.readbackImage) {
    ensureBuffer(s.imageReadback, VkDeviceSize(s.width) * VkDeviceSize(s.height) * 4, VK_BUFFER_USAGE_TRANSFER_DST_BIT);
    f.imageHost = vk::importBuffer(g, "image-readback", *s.imageReadback, fg::Access::None);
    vk::addReadbackPass(g, PassId::ImageReadback, color, f.imageHost);
  } else if (!req.extension) {
    g.exportResource(color, fg::Access::TransferSrc);
  }
  if (req.extension) req.extension->addPasses(g, color);
  s.pickCount = req.pickPoints.size();
  if (req.pickPoints.empty()) return;
  const std::uint32_t n = std::uint32_t(req.pickPoints.size());
  ensureBuffer(s.pickPoints, n * sizeof(glm::vec4), VK_BUFFER_USAGE_STORAGE_BUFFER_BIT);
  ensureBuffer(s.pickReadback, n * sizeof(gpu::PickResult), VK_BUFFER_USAGE_TRANSFER_DST_BIT);
  auto* pts = static_cast<glm::vec4*>(s.pickPoints->mapped());
  for (std::uint32_t i = 0; i < n; ++i) pts[i] = glm::vec4(req.pickPoints[i], 0.0f, 0.0f);
  s.pickPoints->flush();
  f.pickIn = vk::importBuffer(g, "pick-points", *s.pickPoints, fg::Access::HostWrite);
  const fg::ResourceHandle pickOut = g.createBuffer("pick-results", {n * sizeof(gpu::PickResult)});
  f.pickHost = vk::importBuffer(g, "pick-readback", *s.pickReadback, fg::Access::None);
  pick_.add(g, f.in, f.pickIn, pickOut, n, linear_);
  vk::addReadbackPass(g, PassId::PickReadback, pickOut, f.pickHost);
}

void VolumeRenderer::bindFrame(FrameBuild& f, const FrameRequest& req) {
  // Every import of the renderer and its passes was bound where it was declared (vk::importImage,
  // vk::importBuffer); what the caller's extension imported it binds itself.
  *f.accumAccess = fg::Access::StorageReadWrite;
  if (req.extension) req.extension->bind(executor_);
}

std::uint64_t VolumeRenderer::submit(const FrameRequest& req) {
  if (!hasVolume_ || !hasTf_) throw Error("renderer: no volume or transfer function");
  const int w = req.params.outputWidth, h = req.params.outputHeight;
  if (w <= 0 || h <= 0) throw Error("renderer: invalid output size");

  executor_.beginFrame();  // waits only for the frame that last used this slot
  harvest(executor_.slot(), completed_);
  Slot& s = slots_[executor_.slot()];
  ensureBuffer(s.params, sizeof(gpu::RenderParams), VK_BUFFER_USAGE_STORAGE_BUFFER_BIT);  // not uniform: see deform_descriptors.h
  gpu::RenderParams params = req.params;
  params.pickCount = std::uint32_t(req.pickPoints.size());  // written below, once the overlay is known

  FrameBuild f;
  importInputs(f, s);
  // A frame carrying the live selection's growth waits for the last one that did.
  if (live_ && live_->inFlight()) {
    executor_.waitSlot(liveSlot_);
    live_->frameDone();
  }
  const MaskBox maskWritten = addMaskWrites(f, req, s);
  f.sourceVolume = f.in.volume;
  f.sourceMask = f.in.mask;
  if (maskWritten) f.g.exportResource(f.sourceMask, fg::Access::Sampled);  // whoever reads it, it ends the frame sampled
  if (maskWritten) ++contentVersion_;                                     // a still frame's sum starts anew
  // The deformed images (and strain) the raymarch and picking read, while deforming.
  if (deformer_) addDeformation(f, req, maskWritten, (params.flags & (gpu::kFlagStrainOverlay | gpu::kFlagLimitHighlight)) != 0);
  addOverlayInputs(f, params);
  params.tfRowGradient = lut_.gradientTop;  // the table's, whatever the request said
  addAccumulation(f, req, params);  // a still frame's running sum, at the frame's size; a new one starts a new sum
  std::memcpy(s.params->mapped(), &params, sizeof(params));
  s.params->flush();
  const fg::ResourceHandle color = f.g.createImage("color", {std::uint32_t(w), std::uint32_t(h), 1, fg::Format::Rgba8Unorm});
  raymarch_.add(f.g, f.in, color, linear_, nearest_, (params.flags & gpu::kFlagAccumulate) != 0 && (params.flags & gpu::kFlagShowSum) != 0);
  addReadbacks(f, req, s, color);

  f.g.compile();
  executor_.setGraph(&f.g);
  const bool liveRan = live_ && live_->inFlight();  // its passes are in this frame
  bindFrame(f, req);
  f.g.execute(executor_);
  executor_.setGraph(nullptr);
  if (req.extension) executor_.submit(req.extension->waitSemaphore, req.extension->waitStage, req.extension->signalSemaphore);
  else executor_.submit();
  if (liveRan) {
    live_->submitted(f.g);
    liveSlot_ = executor_.slot();
  }
  s.frame = nextFrame_++;
  return *s.frame;
}

std::vector<FrameResult> VolumeRenderer::takeCompleted() { return std::exchange(completed_, {}); }

FrameResult VolumeRenderer::waitLast() {
  executor_.waitLastFrame();
  std::vector<FrameResult> out;
  // Every slot has finished once the last one has (one queue); collect each slot's fence.
  for (std::uint32_t i = 0; i < slots_.size(); ++i) {
    executor_.waitSlot(i);
    harvest(i, out);
  }
  if (live_) live_->frameDone();
  if (out.empty()) throw Error("renderer: no frame was submitted");
  std::sort(out.begin(), out.end(), [](const FrameResult& a, const FrameResult& b) { return a.frame < b.frame; });
  FrameResult last = std::move(out.back());
  out.pop_back();
  for (auto& r : out) completed_.push_back(std::move(r));
  return last;
}

}  // namespace handson
