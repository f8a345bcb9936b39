// GpuDeformer: its construction (checks in deform_setup.cpp), resources and frames; its passes are
// in deform_interpolate_pass.cpp and deform_resample_pass.cpp, the strain passes a class of their
// own (deform_strain_pass.h).
#include "deform_pass.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <cstring>

#include "deform_descriptors.h"
#include "deform_setup.h"
#include "render/render_params.h"
#include "shaders/spirv.h"
#include "sim/tet_raster.h"
#include "sim/base/error.h"
#include "vk_context.h"

namespace handson::vk {

using deform::bindings;
using deform::kParams;
using deform::kSampled;
using deform::kSsbo;
using deform::kStorageImage;

namespace {

constexpr VkBufferUsageFlags kStorageUsage = VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT | VK_BUFFER_USAGE_TRANSFER_SRC_BIT;

template <class T> Buffer uploaded(const Context& ctx, const std::vector<T>& data, std::size_t minCount = 1) {
  const VkDeviceSize bytes = std::max(data.size(), minCount) * sizeof(T);
  Buffer b(ctx, bytes, kStorageUsage, Buffer::Memory::Device);
  if (!data.empty()) uploadToBuffer(ctx, b, data.data(), data.size() * sizeof(T));
  return b;
}

}  // namespace

std::uint64_t DeformFrameStats::redoneVoxels() const {
  if (bricks) return std::uint64_t(dirtyBricks) * HANDSON_DEFORM_BRICK * HANDSON_DEFORM_BRICK * HANDSON_DEFORM_BRICK;
  return boxVoxels();
}

std::uint64_t DeformFrameStats::boxVoxels() const {
  if ((boxLo.array() > boxHi.array()).any()) return 0;
  const Eigen::Vector3i d = boxHi - boxLo + Eigen::Vector3i::Ones();
  return std::uint64_t(d.x()) * std::uint64_t(d.y()) * std::uint64_t(d.z());
}

GpuDeformer::GpuDeformer(const Context& ctx, const Image& source, const Image& sourceMask, const DeformSetup& setup, std::uint32_t framesInFlight)
    : ctx_(ctx), source_(source), sourceMask_(sourceMask), nearest_(ctx, false), slots_(std::max<std::uint32_t>(1, framesInFlight)) {
  const ValidatedDeformSetup valid = validateDeformSetup(ctx, source.desc(), sourceMask.desc(), setup);
  const FineInterpolationData& d = *setup.interpolation;
  nodes_ = d.node.size();
  tets_ = setup.fineTets->size();
  coarseNodes_ = d.coarseRest.size();
  coarseElements_ = d.elementCount();
  handles_ = d.handleCount;
  p_ = valid.params;

  createPipelines();
  strain_ = std::make_unique<DeformStrainPass>(ctx, tets_, source.desc(), setup.strainLimits);
  uploadStaticData(setup, valid);
}

// The passes' pipelines and their bindings.
void GpuDeformer::createPipelines() {
  const Context& ctx = ctx_;
  interpolate_ = ComputePipeline(ctx, shaders::deformInterpolate(),
                                 bindings({{gpu::kBindDeformInterpolateParams, kParams},
                                           {gpu::kBindDeformInterpolateNodes, kSsbo},
                                           {gpu::kBindDeformInterpolateRest, kSsbo},
                                           {gpu::kBindDeformInterpolateBlocks, kSsbo},
                                           {gpu::kBindDeformInterpolateElements, kSsbo},
                                           {gpu::kBindDeformInterpolateCoarseRest, kSsbo},
                                           {gpu::kBindDeformInterpolateCoarsePos, kSsbo},
                                           {gpu::kBindDeformInterpolateRotations, kSsbo},
                                           {gpu::kBindDeformInterpolateHandles, kSsbo},
                                           {gpu::kBindDeformInterpolateOut, kSsbo},
                                           {gpu::kBindDeformInterpolatePrev, kSsbo}}),
                                 4);
  bounds_ = ComputePipeline(ctx, shaders::deformBounds(),
                            bindings({{gpu::kBindDeformBoundsParams, kParams},
                                      {gpu::kBindDeformBoundsTets, kSsbo},
                                      {gpu::kBindDeformBoundsPosNew, kSsbo},
                                      {gpu::kBindDeformBoundsPosOld, kSsbo},
                                      {gpu::kBindDeformBoundsBox, kSsbo},
                                      {gpu::kBindDeformBoundsBrickMotion, kSsbo}}),
                            0);
  bricks_ = ComputePipeline(ctx, shaders::deformBricks(),
                            bindings({{gpu::kBindDeformBricksParams, kParams},
                                      {gpu::kBindDeformBricksBox, kSsbo},
                                      {gpu::kBindDeformBricksFlags, kSsbo},
                                      {gpu::kBindDeformBricksList, kSsbo},
                                      {gpu::kBindDeformBricksLag, kSsbo},
                                      {gpu::kBindDeformBricksRigid, kSsbo}}),
                            8);
  args_ = ComputePipeline(
      ctx, shaders::deformArgs(),
      bindings({{gpu::kBindDeformArgsParams, kParams}, {gpu::kBindDeformArgsBox, kSsbo}, {gpu::kBindDeformArgsArgs, kSsbo}}), 4);
  clear_ = ComputePipeline(ctx, shaders::deformClear(),
                           bindings({{gpu::kBindDeformClearParams, kParams},
                                     {gpu::kBindDeformClearBox, kSsbo},
                                     {gpu::kBindDeformClearSource, kSampled},
                                     {gpu::kBindDeformClearSourceMask, kSampled},
                                     {gpu::kBindDeformClearOut, kStorageImage},
                                     {gpu::kBindDeformClearOutMask, kStorageImage},
                                     {gpu::kBindDeformClearOwner, kSsbo},
                                     {gpu::kBindDeformClearBrickList, kSsbo}}),
                           0);
  claim_ = ComputePipeline(ctx, shaders::deformClaim(),
                           bindings({{gpu::kBindDeformClaimParams, kParams},
                                     {gpu::kBindDeformClaimTets, kSsbo},
                                     {gpu::kBindDeformClaimPos, kSsbo},
                                     {gpu::kBindDeformClaimBox, kSsbo},
                                     {gpu::kBindDeformClaimOwner, kSsbo},
                                     {gpu::kBindDeformClaimRestIdx, kSsbo},
                                     {gpu::kBindDeformClaimAffine, kSsbo},
                                     {gpu::kBindDeformClaimBrickFlags, kSsbo}}),
                           0);
  resolve_ = ComputePipeline(ctx, shaders::deformResolve(),
                             bindings({{gpu::kBindDeformResolveParams, kParams},
                                       {gpu::kBindDeformResolveAffine, kSsbo},
                                       {gpu::kBindDeformResolveBox, kSsbo},
                                       {gpu::kBindDeformResolveOwner, kSsbo},
                                       {gpu::kBindDeformResolveSource, kSampled},
                                       {gpu::kBindDeformResolveSourceMask, kSampled},
                                       {gpu::kBindDeformResolveOut, kStorageImage},
                                       {gpu::kBindDeformResolveOutMask, kStorageImage},
                                       {gpu::kBindDeformResolveBrickList, kSsbo},
                                       {gpu::kBindDeformResolveRigid, kSsbo}}),
                             0);

}

// The static data on the device (parameters, mesh records, rest positions, tets, limits), the
// per-frame buffers and the deformed images (copies of the sources).
void GpuDeformer::uploadStaticData(const DeformSetup& setup, const ValidatedDeformSetup& valid) {
  const Context& ctx = ctx_;
  const FineInterpolationData& d = *setup.interpolation;
  const fg::ImageDesc sd = source_.desc();
  const fg::ImageDesc md = sourceMask_.desc();
  params_ = Buffer(ctx, sizeof(gpu::DeformParams), VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT, Buffer::Memory::Device);
  if (!(setup.motionLagVoxels >= 0.0) || !(setup.motionLagVoxels <= 4.0))
    throw Error("deformation: the lag allowed during motion must be between 0 and 4 voxels");
  motionLag_ = float(setup.motionLagVoxels);
  p_.motionLagVoxels = motionLag_;  // deform_bounds.comp widens what a moved tet marks by it
  uploadToBuffer(ctx, params_, &p_, sizeof(p_));
  nodeInfo_ = uploaded(ctx, d.node);
  rest_ = uploaded(ctx, d.rest);
  blocks_ = uploaded(ctx, d.blocks);
  elementCorners_ = uploaded(ctx, d.elementCorners);
  coarseRest_ = uploaded(ctx, d.coarseRest);
  tetBuffer_ = uploaded(ctx, valid.tets);
  std::vector<Eigen::Vector4f> restIdx(nodes_);
  const Eigen::Matrix4f w2i = setup.worldToIndex.cast<float>();
  for (std::size_t f = 0; f < nodes_; ++f) {
    const Eigen::Vector3f X = d.rest[f].head<3>();
    restIdx[f] << w2i.topLeftCorner<3, 3>() * X + w2i.topRightCorner<3, 1>(), 1.0f;
  }
  restIdx_ = uploaded(ctx, restIdx);
  pos_ = uploaded(ctx, restIdx);
  prev_ = uploaded(ctx, restIdx);
  if (!(setup.commitVoxels >= 0.0) || !std::isfinite(setup.commitVoxels)) throw Error("deformation: the commit threshold must be a finite number >= 0");
  commit_ = float(setup.commitVoxels);
  rigidIds_ = setup.rigidIds;
  rigidBoxes_ = setup.rigidRestBoxes;
  if (rigidBoxes_.empty())  // the region's box: every brick a rigid handle could reach
    rigidBoxes_.assign(rigidIds_.size(), {Eigen::Vector3i(p_.regionVoxLo.x, p_.regionVoxLo.y, p_.regionVoxLo.z),
                                          Eigen::Vector3i(p_.regionVoxHi.x, p_.regionVoxHi.y, p_.regionVoxHi.z)});
  worldToIndex_ = setup.worldToIndex;
  const std::vector<std::uint32_t> noBricks(std::size_t(p_.brickCount), 0u);
  brickFlags_ = uploaded(ctx, noBricks);
  brickList_ = uploaded(ctx, noBricks);
  brickLag_ = uploaded(ctx, std::vector<float>(std::size_t(p_.brickCount), 0.0f));
  box_ = Buffer(ctx, sizeof(gpu::DeformBox), kStorageUsage, Buffer::Memory::Device);
  argsBuffer_ = Buffer(ctx, 16, kStorageUsage | VK_BUFFER_USAGE_INDIRECT_BUFFER_BIT, Buffer::Memory::Device);
  owner_ = Buffer(ctx, valid.ownerBytes, kStorageUsage, Buffer::Memory::Device);
  if (tets_ * 48 > ctx.properties().limits.maxStorageBufferRange) throw Error("deformation: the fine mesh is larger than this device's storage buffers allow");
  affine_ = Buffer(ctx, tets_ * 48, kStorageUsage, Buffer::Memory::Device);

  const VkImageUsageFlags usage = VK_IMAGE_USAGE_STORAGE_BIT | VK_IMAGE_USAGE_SAMPLED_BIT | VK_IMAGE_USAGE_TRANSFER_SRC_BIT | VK_IMAGE_USAGE_TRANSFER_DST_BIT;
  volume_ = Image(ctx, sd, usage, true);
  mask_ = Image(ctx, md, usage, true);
  ctx.submitAndWait([&](VkCommandBuffer cmd) {
    const VkImageCopy region{{VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1}, {0, 0, 0}, {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1}, {0, 0, 0}, {sd.width, sd.height, sd.depth}};
    for (auto [src, dst] : {std::pair<const Image*, const Image*>{&source_, &volume_}, {&sourceMask_, &mask_}}) {
      transitionImage(cmd, src->handle(), VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL);
      transitionImage(cmd, dst->handle(), VK_IMAGE_LAYOUT_UNDEFINED, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL);
      vkCmdCopyImage(cmd, src->handle(), VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, dst->handle(), VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, 1, &region);
      transitionImage(cmd, src->handle(), VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL);
      transitionImage(cmd, dst->handle(), VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL);
    }
  });
}

GpuDeformer::~GpuDeformer() {
  try {
    if (ownExecutor_) ownExecutor_->waitLastFrame();
  } catch (...) {
    // Device lost while shutting down: nothing more to wait for.
  }
}

void GpuDeformer::importResources(fg::FrameGraph& g, bool withState, const FrameImports& at) {
  const std::uint32_t slot = at.slot;
  const fg::ResourceHandle sourceVolume = at.sourceVolume, sourceMask = at.sourceMask;
  const Outputs& outputs = at.outputs;
  using fg::Access;
  Bound& h = h_;
  h = Bound{};
  strain_->beginFrame();
  auto buf = [&](const char* name, const Buffer& b, Access a) { return importBuffer(g, name, b, a); };
  h.params = buf("deform-params", params_, Access::StorageRead);
  h.nodeInfo = buf("fine-node-records", nodeInfo_, Access::StorageRead);
  h.rest = buf("fine-rest", rest_, Access::StorageRead);
  h.blocks = buf("fine-blocks", blocks_, Access::StorageRead);
  h.elementCorners = buf("coarse-elements", elementCorners_, Access::StorageRead);
  h.coarseRest = buf("coarse-rest", coarseRest_, Access::StorageRead);
  h.tets = buf("fine-tets", tetBuffer_, Access::StorageRead);
  h.restIdx = buf("fine-rest-index", restIdx_, Access::StorageRead);
  h.posNew = buf("fine-positions", pos_, Access::StorageReadWrite);
  h.posOld = buf("fine-positions-previous", prev_, Access::StorageReadWrite);
  h.box = buf("deform-box", box_, Access::StorageReadWrite);
  h.args = buf("deform-args", argsBuffer_, Access::IndirectRead);
  h.owner = buf("deform-owner", owner_, Access::StorageReadWrite);
  h.affine = buf("deform-tet-maps", affine_, Access::StorageReadWrite);
  h.brickFlags = buf("deform-brick-flags", brickFlags_, Access::StorageReadWrite);
  h.brickList = buf("deform-brick-list", brickList_, Access::StorageReadWrite);
  h.brickLag = buf("deform-brick-lag", brickLag_, Access::StorageReadWrite);
  if (withState) {
    const Slot& s = slots_[slot];
    h.positions = buf("coarse-positions", *s.positions, Access::HostWrite);
    h.rotations = buf("coarse-rotations", *s.rotations, Access::HostWrite);
    h.handles = buf("handle-transforms", *s.handles, Access::HostWrite);
  }
  writeRigidDraws(slots_[slot]);
  h.rigid = buf("rigid-handle-draws", *slots_[slot].rigid, Access::HostWrite);
  h.source = sourceVolume.valid() ? sourceVolume : importImage(g, "volume", source_, Access::Sampled);
  h.sourceMask = sourceMask.valid() ? sourceMask : importImage(g, "handle-mask", sourceMask_, Access::Sampled);
  h.volume = outputs.volume.valid() ? outputs.volume : importImage(g, "deformed-volume", volume_, Access::Sampled);
  h.mask = outputs.mask.valid() ? outputs.mask : importImage(g, "deformed-mask", mask_, Access::Sampled);
}

GpuDeformer::Outputs GpuDeformer::importOutputs(fg::FrameGraph& g) {
  h_ = Bound{};
  h_.onlyOutputs = true;
  strain_->beginFrame();
  h_.volume = importImage(g, "deformed-volume", volume_, fg::Access::Sampled);
  h_.mask = importImage(g, "deformed-mask", mask_, fg::Access::Sampled);
  return {h_.volume, h_.mask};
}

void GpuDeformer::setHandlePoses(const std::vector<Eigen::Matrix4f>& worldPoses) {
  if (!rigidIds_.empty() && worldPoses.size() != rigidIds_.size())
    throw Error("deformation: " + std::to_string(worldPoses.size()) + " handle poses for " + std::to_string(rigidIds_.size()) + " handles");
  for (const auto& T : worldPoses)
    if (!T.allFinite()) throw Error("deformation: a handle pose is not finite");
  poses_ = worldPoses;
}

namespace {

// A rigid handle's voxel box at rest (index space, widened by half a voxel) moved by two poses
// (index space, rest -> current): the union of the moved boxes and the largest motion of a point
// of the box along any axis (an affine displacement: largest at a corner).
void movedBox(const std::array<Eigen::Vector3i, 2>& rest, const Eigen::Matrix4d& now, const Eigen::Matrix4d& before, gpu::RigidDraw& d) {
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(1e30), hi = -lo;
  double motion = 0;
  for (int c = 0; c < 8; ++c) {
    const Eigen::Vector4d p((c & 1) ? rest[1].x() + 0.5 : rest[0].x() - 0.5, (c & 2) ? rest[1].y() + 0.5 : rest[0].y() - 0.5,
                            (c & 4) ? rest[1].z() + 0.5 : rest[0].z() - 0.5, 1.0);
    const Eigen::Vector3d a = (now * p).head<3>(), b = (before * p).head<3>();
    lo = lo.cwiseMin(a).cwiseMin(b);
    hi = hi.cwiseMax(a).cwiseMax(b);
    motion = std::max(motion, (a - b).cwiseAbs().maxCoeff());
  }
  d.boxLo = glm::vec4(float(lo.x()), float(lo.y()), float(lo.z()), float(motion));
  d.boxHi = glm::vec4(float(hi.x()), float(hi.y()), float(hi.z()), 0.0f);
}

}  // namespace

void GpuDeformer::writeRigidDraws(Slot& s) {
  std::vector<gpu::RigidDraw> draws;
  if (poses_.size() == rigidIds_.size()) {
    if (lastPoses_.size() != poses_.size()) lastPoses_ = poses_;
    for (std::size_t h = 0; h < rigidIds_.size(); ++h) {
      if (rigidIds_[h] == 0) continue;
      const Eigen::Matrix4d now = indexSpacePose(poses_[h].cast<double>(), worldToIndex_);
      const Eigen::Matrix4d before = indexSpacePose(lastPoses_[h].cast<double>(), worldToIndex_);
      gpu::RigidDraw d{};
      d.currentToRest = toGlm(now.inverse());
      d.id = glm::uvec4(rigidIds_[h], 0, 0, 0);
      movedBox(rigidBoxes_[h], now, before, d);
      draws.push_back(d);
    }
    lastPoses_ = poses_;
  }
  const VkDeviceSize bytes = 16 + std::max<std::size_t>(1, draws.size()) * sizeof(gpu::RigidDraw);
  if (!s.rigid || s.rigid->size() < bytes) s.rigid = std::make_unique<Buffer>(ctx_, bytes, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, Buffer::Memory::HostVisible);
  const glm::uvec4 head(std::uint32_t(draws.size()), 0, 0, 0);
  std::memcpy(s.rigid->mapped(), &head, 16);
  if (!draws.empty()) std::memcpy(static_cast<char*>(s.rigid->mapped()) + 16, draws.data(), draws.size() * sizeof(gpu::RigidDraw));
  s.rigid->flush();
}

DeformFrameStats GpuDeformer::runFrame(const CoarseFrameState& state, Redo redo) {
  return runOwn([&](fg::FrameGraph& g) { addPasses(g, state, redo); });
}

DeformFrameStats GpuDeformer::runFrameFromPositions(const std::vector<Eigen::Vector4f>& indexPositions, Redo redo) {
  return runOwn([&](fg::FrameGraph& g) { addPassesFromPositions(g, indexPositions, redo); });
}

DeformFrameStats GpuDeformer::settle(const CoarseFrameState& state, bool withStrain) {
  return runOwn([&](fg::FrameGraph& g) {
    addPasses(g, state, Redo::Bricks);
    if (withStrain) addStrainPass(g);
  });
}

DeformFrameStats GpuDeformer::runFrame(const std::vector<Eigen::Vector4f>& indexPositions) {
  if (indexPositions.size() != nodes_) throw Error("deformation: one position per fine node expected");
  for (const auto& p : indexPositions)
    if (!p.allFinite()) throw Error("deformation: a fine node position is not finite");
  if (ownExecutor_) ownExecutor_->waitLastFrame();
  uploadToBuffer(ctx_, pos_, indexPositions.data(), nodes_ * 16);
  uploadToBuffer(ctx_, prev_, indexPositions.data(), nodes_ * 16);
  return runOwn([&](fg::FrameGraph& g) {
    importResources(g, false);
    addResamplePasses(g, Redo::Region);
  });
}

DeformFrameStats GpuDeformer::runOwn(const std::function<void(fg::FrameGraph&)>& build) {
  if (!ownExecutor_) ownExecutor_ = std::make_unique<GraphExecutor>(ctx_, 1);
  if (!boxReadback_) boxReadback_ = std::make_unique<Buffer>(ctx_, sizeof(gpu::DeformBox), VK_BUFFER_USAGE_TRANSFER_DST_BIT, Buffer::Memory::HostVisible);
  GraphExecutor& x = *ownExecutor_;
  x.beginFrame();
  fg::FrameGraph g;
  build(g);
  const auto host = importBuffer(g, "deform-box-host", *boxReadback_, fg::Access::None);
  addReadbackPass(g, PassId::DeformBoxReadback, h_.box, host);
  g.compile();
  x.setGraph(&g);
  g.execute(x);
  x.setGraph(nullptr);
  x.submit();
  x.waitLastFrame();
  boxReadback_->invalidate();
  gpu::DeformBox b;
  std::memcpy(&b, boxReadback_->mapped(), sizeof(b));
  DeformFrameStats st;
  st.boxLo = Eigen::Vector3i(b.lo.x, b.lo.y, b.lo.z);
  st.boxHi = Eigen::Vector3i(b.hi.x, b.hi.y, b.hi.z);
  st.movedTets = b.movedTets;
  st.coveredVoxels = b.coveredVoxels;
  st.skippedTets = b.skippedTets;
  st.bricks = b.brickMode != 0;
  st.dirtyBricks = b.dirtyBrickCount;
  st.allBricks = b.allBricksDirty != 0;
  st.timings = x.completedTimings();
  return st;
}

std::vector<Eigen::Vector4f> GpuDeformer::readPositions() const {
  std::vector<Eigen::Vector4f> out(nodes_);
  downloadFromBuffer(ctx_, pos_, out.data(), nodes_ * 16);
  return out;
}

GpuDeformer::StrainOutputs GpuDeformer::addStrainPass(fg::FrameGraph& g) {
  if (h_.onlyOutputs || !h_.posNew.valid() || !h_.args.valid())
    throw Error("deformation: the strain passes need this frame's fine positions and resampling (addPasses first)");
  return strain_->add(g, {h_.params, h_.tets, h_.rest, h_.posNew, h_.args, h_.box, h_.owner, h_.brickList});
}

std::vector<float> GpuDeformer::runStrain(const std::vector<Eigen::Vector4f>& indexPositions) {
  runOwn([&](fg::FrameGraph& g) {
    addPassesFromPositions(g, indexPositions, Redo::Region);
    addStrainPass(g);
  });
  return readStrain();
}

std::vector<std::uint16_t> GpuDeformer::readVolume() const {
  const fg::ImageDesc d = volume_.desc();
  std::vector<std::uint16_t> out(std::size_t(d.width) * d.height * d.depth);
  downloadFromImage(ctx_, volume_, out.data(), out.size() * 2);
  return out;
}

std::vector<std::uint8_t> GpuDeformer::readMask() const {
  const fg::ImageDesc d = mask_.desc();
  std::vector<std::uint8_t> out(std::size_t(d.width) * d.height * d.depth);
  downloadFromImage(ctx_, mask_, out.data(), out.size());
  return out;
}

}  // namespace handson::vk
