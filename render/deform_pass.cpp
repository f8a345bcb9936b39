#include "deform_pass.h"

#include <Eigen/LU>

#include <algorithm>
#include <climits>
#include <cmath>
#include <cstring>
#include <string>

#include "shaders/spirv.h"
#include "sim/error.h"
#include "sim/tet_raster.h"
#include "vk_context.h"

namespace handson::vk {

namespace {

VkDescriptorSetLayoutBinding binding(std::uint32_t b, VkDescriptorType type) { return {b, type, 1, VK_SHADER_STAGE_COMPUTE_BIT, nullptr}; }
// The parameters are a read-only storage buffer, not a uniform buffer: lavapipe (Mesa 22.3) inlines
// uniform-buffer values that steer loops into the shader and compiles a new variant every time the
// buffer is bound — every frame — keeping each one until the device is destroyed.
constexpr VkDescriptorType kParams = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
constexpr VkDescriptorType kSsbo = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
constexpr VkDescriptorType kSampled = VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER;
constexpr VkDescriptorType kStorageImage = VK_DESCRIPTOR_TYPE_STORAGE_IMAGE;

std::vector<VkDescriptorSetLayoutBinding> bindings(std::initializer_list<VkDescriptorType> types) {
  std::vector<VkDescriptorSetLayoutBinding> out;
  std::uint32_t b = 0;
  for (auto t : types) out.push_back(binding(b++, t));
  return out;
}

glm::mat4 toGlm(const Eigen::Matrix4d& m) {
  glm::mat4 g;
  for (int c = 0; c < 4; ++c)
    for (int r = 0; r < 4; ++r) g[c][r] = float(m(r, c));
  return g;
}

constexpr VkBufferUsageFlags kStorageUsage = VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT | VK_BUFFER_USAGE_TRANSFER_SRC_BIT;

template <class T> Buffer uploaded(const Context& ctx, const std::vector<T>& data, std::size_t minCount = 1) {
  const VkDeviceSize bytes = std::max(data.size(), minCount) * sizeof(T);
  Buffer b(ctx, bytes, kStorageUsage, Buffer::Memory::Device);
  if (!data.empty()) uploadToBuffer(ctx, b, data.data(), data.size() * sizeof(T));
  return b;
}

void readImage(const Context& ctx, const Image& img, void* dst, VkDeviceSize bytes) {
  Buffer host(ctx, bytes, VK_BUFFER_USAGE_TRANSFER_DST_BIT, Buffer::Memory::HostVisible);
  ctx.submitAndWait([&](VkCommandBuffer cmd) {
    transitionImage(cmd, img.handle(), VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL);
    copyImageToBuffer(cmd, img, host.handle());
    transitionImage(cmd, img.handle(), VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL);
  });
  host.invalidate();
  std::memcpy(dst, host.mapped(), bytes);
}

}  // namespace

std::uint64_t DeformFrameStats::boxVoxels() const {
  if ((boxLo.array() > boxHi.array()).any()) return 0;
  const Eigen::Vector3i d = boxHi - boxLo + Eigen::Vector3i::Ones();
  return std::uint64_t(d.x()) * std::uint64_t(d.y()) * std::uint64_t(d.z());
}

GpuDeformer::GpuDeformer(const Context& ctx, const Image& source, const Image& sourceMask, const DeformSetup& setup, std::uint32_t framesInFlight)
    : ctx_(ctx), source_(source), sourceMask_(sourceMask), nearest_(ctx, false), slots_(std::max<std::uint32_t>(1, framesInFlight)) {
  if (!setup.interpolation || !setup.fineTets) throw Error("deformation: no mesh data");
  const FineInterpolationData& d = *setup.interpolation;
  if (!ctx.storageExtendedFormats())
    throw Error("deformation: this Vulkan device cannot write 16-bit storage images (shaderStorageImageExtendedFormats)");
  {
    VkPhysicalDeviceSubgroupProperties sub{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_SUBGROUP_PROPERTIES};
    VkPhysicalDeviceProperties2 p2{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_PROPERTIES_2};
    p2.pNext = &sub;
    vkGetPhysicalDeviceProperties2(ctx.physicalDevice(), &p2);
    if (!(sub.supportedStages & VK_SHADER_STAGE_COMPUTE_BIT) || !(sub.supportedOperations & VK_SUBGROUP_FEATURE_ARITHMETIC_BIT))
      throw Error("deformation: this Vulkan device lacks subgroup arithmetic in compute shaders");
  }
  const fg::ImageDesc sd = source.desc();
  const fg::ImageDesc md = sourceMask.desc();
  if (sd.format != fg::Format::R16Unorm || md.format != fg::Format::R8Unorm || sd.width != md.width || sd.height != md.height || sd.depth != md.depth)
    throw Error("deformation: the source volume (R16) and mask (R8) must share one grid");
  nodes_ = d.node.size();
  tets_ = setup.fineTets->size();
  coarseNodes_ = d.coarseRest.size();
  if (d.cornersPerElement != 4 && d.cornersPerElement != 8) throw Error("deformation: coarse elements have 4 or 8 corners");
  if (d.elementCorners.size() % 2 != 0) throw Error("deformation: two corner records per coarse element expected");
  coarseElements_ = d.elementCount();
  handles_ = d.handleCount;
  if (nodes_ == 0 || tets_ == 0 || d.rest.size() != nodes_ || coarseNodes_ == 0 || coarseElements_ == 0)
    throw Error("deformation: empty or inconsistent mesh data");
  if (nodes_ > std::size_t(INT_MAX) || tets_ > std::size_t(INT_MAX)) throw Error("deformation: the fine mesh is too large");
  std::vector<std::array<std::uint32_t, 4>> tets(tets_);
  for (std::size_t t = 0; t < tets_; ++t)
    for (int c = 0; c < 4; ++c) {
      const int v = (*setup.fineTets)[t][std::size_t(c)];
      if (v < 0 || std::size_t(v) >= nodes_) throw Error("deformation: a fine tet refers to a missing node");
      tets[t][std::size_t(c)] = std::uint32_t(v);
    }
  static_assert(kRasterTolerance == 1e-5 && kRasterBoxMargin == 1e-4, "shaders/deform_claim.comp uses these numbers");
  for (const auto& n : d.node) {
    const std::size_t hc = 3 * std::size_t(d.cornersPerElement);  // H blocks before the handle blocks
    if (n[0] == FineInterpolationData::Interior && std::size_t(n[2]) + d.interiorBlocks(n[3]) <= d.blocks.size())
      for (std::uint32_t k = 0; k < n[3]; ++k) {
        const float hidx = d.blocks[std::size_t(n[2]) + hc + 13 * k].x();
        if (!(hidx >= 0.0f && hidx < float(handles_) && hidx == std::floor(hidx))) throw Error("deformation: a handle block refers to a missing handle");
      }
    const bool ok = n[0] == FineInterpolationData::Rest || (n[0] == FineInterpolationData::Handle && n[1] < handles_) ||
                    (n[0] == FineInterpolationData::Corner && n[1] < coarseNodes_) ||
                    (n[0] == FineInterpolationData::Boundary && n[1] < coarseElements_ && std::size_t(n[2]) + d.cornersPerElement / 4 <= d.blocks.size()) ||
                    (n[0] == FineInterpolationData::Interior && n[1] < coarseElements_ && std::size_t(n[2]) + d.interiorBlocks(n[3]) <= d.blocks.size());
    if (!ok) throw Error("deformation: a fine node's reconstruction record is out of range");
  }
  for (const auto& t : d.elementCorners)
    for (auto v : t)
      if (v >= coarseNodes_) throw Error("deformation: a coarse element refers to a missing node");

  const std::uint64_t maxGroups = ctx.properties().limits.maxComputeWorkGroupCount[0];
  if ((nodes_ + HANDSON_DEFORM_GROUP_X - 1) / HANDSON_DEFORM_GROUP_X > maxGroups || (tets_ + HANDSON_DEFORM_GROUP_X - 1) / HANDSON_DEFORM_GROUP_X > maxGroups)
    throw Error("deformation: the fine mesh (" + std::to_string(tets_) + " tets) needs more workgroups than this device dispatches at once (" +
                std::to_string(maxGroups * HANDSON_DEFORM_GROUP_X) + " invocations)");
  const Eigen::Vector3i dims(int(sd.width), int(sd.height), int(sd.depth));
  Eigen::Vector3i rlo, rhi;
  regionVoxelBox(setup.worldToIndex, dims, setup.regionLo, setup.regionHi, rlo, rhi);
  if ((rlo.array() > rhi.array()).any()) throw Error("deformation: the region lies outside the volume");
  const Eigen::Vector3i od = rhi - rlo + Eigen::Vector3i::Ones();
  const std::uint64_t ownerBytes = std::uint64_t(od.x()) * std::uint64_t(od.y()) * std::uint64_t(od.z()) * 4;
  if (ownerBytes > ctx.properties().limits.maxStorageBufferRange)
    throw Error("deformation: the region is larger than this device's storage buffers allow");

  p_.worldToIndex = toGlm(setup.worldToIndex);
  p_.indexToWorld = toGlm(setup.worldToIndex.inverse());
  p_.regionLo = glm::vec4(float(setup.regionLo.x()), float(setup.regionLo.y()), float(setup.regionLo.z()), setup.background);
  p_.regionHi = glm::vec4(float(setup.regionHi.x()), float(setup.regionHi.y()), float(setup.regionHi.z()), 0.0f);
  p_.regionVoxLo = glm::ivec4(rlo.x(), rlo.y(), rlo.z(), int(nodes_));
  p_.regionVoxHi = glm::ivec4(rhi.x(), rhi.y(), rhi.z(), int(tets_));
  p_.dims = glm::ivec4(dims.x(), dims.y(), dims.z(), int(handles_));
  p_.ownerDims = glm::ivec4(od.x(), od.y(), od.z(), int(coarseElements_));
  {
    TetMesh rest;  // the rest mesh in world space, for the default cap
    rest.nodes.reserve(nodes_);
    for (const auto& X : d.rest) rest.nodes.emplace_back(double(X.x()), double(X.y()), double(X.z()));
    rest.tets = *setup.fineTets;
    const std::uint64_t cap = setup.maxTetVoxels ? setup.maxTetVoxels : defaultMaxTetVoxels(rest, setup.worldToIndex);
    p_.limits = glm::uvec4(std::uint32_t(std::min<std::uint64_t>(cap, UINT32_MAX)), d.cornersPerElement, 0, 0);
  }

  interpolate_ = ComputePipeline(ctx, shaders::deformInterpolate(),
                                 bindings({kParams, kSsbo, kSsbo, kSsbo, kSsbo, kSsbo, kSsbo, kSsbo, kSsbo, kSsbo, kSsbo}), 4);
  bounds_ = ComputePipeline(ctx, shaders::deformBounds(), bindings({kParams, kSsbo, kSsbo, kSsbo, kSsbo}), 0);
  args_ = ComputePipeline(ctx, shaders::deformArgs(), bindings({kParams, kSsbo, kSsbo}), 4);
  clear_ = ComputePipeline(ctx, shaders::deformClear(), bindings({kParams, kSsbo, kSampled, kSampled, kStorageImage, kStorageImage, kSsbo}), 0);
  claim_ = ComputePipeline(ctx, shaders::deformClaim(), bindings({kParams, kSsbo, kSsbo, kSsbo, kSsbo, kSsbo, kSsbo}), 0);
  resolve_ = ComputePipeline(ctx, shaders::deformResolve(), bindings({kParams, kSsbo, kSsbo, kSsbo, kSampled, kSampled, kStorageImage, kStorageImage}), 0);
  strain_ = ComputePipeline(ctx, shaders::deformStrain(), bindings({kParams, kSsbo, kSsbo, kSsbo, kSsbo}), 0);
  strainRaster_ = ComputePipeline(ctx, shaders::deformStrainRaster(), bindings({kParams, kSsbo, kSsbo, kSsbo, kStorageImage}), 0);

  params_ = Buffer(ctx, sizeof(gpu::DeformParams), VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT, Buffer::Memory::Device);
  uploadToBuffer(ctx, params_, &p_, sizeof(p_));
  nodeInfo_ = uploaded(ctx, d.node);
  rest_ = uploaded(ctx, d.rest);
  blocks_ = uploaded(ctx, d.blocks);
  elementCorners_ = uploaded(ctx, d.elementCorners);
  coarseRest_ = uploaded(ctx, d.coarseRest);
  tetBuffer_ = uploaded(ctx, tets);
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
  box_ = Buffer(ctx, sizeof(gpu::DeformBox), kStorageUsage, Buffer::Memory::Device);
  argsBuffer_ = Buffer(ctx, 16, kStorageUsage | VK_BUFFER_USAGE_INDIRECT_BUFFER_BIT, Buffer::Memory::Device);
  owner_ = Buffer(ctx, ownerBytes, kStorageUsage, Buffer::Memory::Device);
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

void GpuDeformer::importResources(fg::FrameGraph& g, std::uint32_t slot, bool withState, fg::ResourceHandle sourceVolume, fg::ResourceHandle sourceMask,
                                  const Outputs& outputs) {
  using fg::Access;
  Bound& h = h_;
  h = Bound{};
  h.slot = slot;
  h.withState = withState;
  auto buf = [&](const char* name, const Buffer& b, Access a) { return g.importBuffer(name, {b.size()}, a); };
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
  if (withState) {
    const Slot& s = slots_[slot];
    h.positions = buf("coarse-positions", *s.positions, Access::HostWrite);
    h.rotations = buf("coarse-rotations", *s.rotations, Access::HostWrite);
    h.handles = buf("handle-transforms", *s.handles, Access::HostWrite);
  }
  h.source = sourceVolume.valid() ? sourceVolume : g.importImage("volume", source_.desc(), Access::Sampled);
  h.sourceMask = sourceMask.valid() ? sourceMask : g.importImage("handle-mask", sourceMask_.desc(), Access::Sampled);
  h.volume = outputs.volume.valid() ? outputs.volume : g.importImage("deformed-volume", volume_.desc(), Access::Sampled);
  h.mask = outputs.mask.valid() ? outputs.mask : g.importImage("deformed-mask", mask_.desc(), Access::Sampled);
}

GpuDeformer::Outputs GpuDeformer::importOutputs(fg::FrameGraph& g) {
  h_ = Bound{};
  h_.onlyOutputs = true;
  h_.volume = g.importImage("deformed-volume", volume_.desc(), fg::Access::Sampled);
  h_.mask = g.importImage("deformed-mask", mask_.desc(), fg::Access::Sampled);
  return {h_.volume, h_.mask};
}

GpuDeformer::Outputs GpuDeformer::addPasses(fg::FrameGraph& g, std::uint32_t slot, const CoarseFrameState& state, Redo redo, fg::ResourceHandle sourceVolume,
                                            fg::ResourceHandle sourceMask, const Outputs& outputs) {
  if (slot >= slots_.size()) throw Error("deformation: frame slot out of range");
  if (state.positions.size() != coarseNodes_ || state.rotations.size() != coarseElements_ || state.handles.size() != handles_)
    throw Error("deformation: the coarse state does not match the mesh");
  Slot& s = slots_[slot];
  auto hostBuffer = [&](std::unique_ptr<Buffer>& b, const void* data, std::size_t bytes) {
    const VkDeviceSize size = std::max<VkDeviceSize>(bytes, 64);
    if (!b || b->size() < size) b = std::make_unique<Buffer>(ctx_, size, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, Buffer::Memory::HostVisible);
    if (bytes) std::memcpy(b->mapped(), data, bytes);
    b->flush();
  };
  static_assert(sizeof(Eigen::Vector4f) == 16 && sizeof(Eigen::Matrix4f) == 64, "packed state layout");
  hostBuffer(s.positions, state.positions.data(), state.positions.size() * 16);
  hostBuffer(s.rotations, state.rotations.data(), state.rotations.size() * 16);
  hostBuffer(s.handles, state.handles.data(), state.handles.size() * 64);

  importResources(g, slot, true, sourceVolume, sourceMask, outputs);
  using fg::Access;
  const Bound hb = h_;
  const std::uint32_t nodeGroups = std::uint32_t((nodes_ + HANDSON_DEFORM_GROUP_X - 1) / HANDSON_DEFORM_GROUP_X);

  g.addPass(
      "deform-interpolate",
      [&](fg::PassBuilder& b) {
        b.read(hb.params, Access::StorageRead);
        for (auto r : {hb.nodeInfo, hb.rest, hb.blocks, hb.elementCorners, hb.coarseRest, hb.positions, hb.rotations, hb.handles})
          b.read(r, Access::StorageRead);
        b.write(hb.posNew, Access::StorageReadWrite);
        b.write(hb.posOld, Access::StorageWrite);
      },
      [this, hb, nodeGroups, commit = commit_](fg::Executor& e) {
        GraphExecutor& x = vulkanExecutor(e);
        vkCmdBindPipeline(x.cmd(), VK_PIPELINE_BIND_POINT_COMPUTE, interpolate_.pipeline());
        DescriptorWriter w;
        w.buffer(0, kParams, x.buffer(hb.params).handle());
        std::uint32_t i = 1;
        for (auto r : {hb.nodeInfo, hb.rest, hb.blocks, hb.elementCorners, hb.coarseRest, hb.positions, hb.rotations, hb.handles, hb.posNew, hb.posOld})
          w.buffer(i++, kSsbo, x.buffer(r).handle());
        w.push(ctx_, x.cmd(), interpolate_);
        vkCmdPushConstants(x.cmd(), interpolate_.layout(), VK_SHADER_STAGE_COMPUTE_BIT, 0, 4, &commit);
        vkCmdDispatch(x.cmd(), nodeGroups, 1, 1);
      });
  return addResamplePasses(g, redo);
}

GpuDeformer::Outputs GpuDeformer::addResamplePasses(fg::FrameGraph& g, Redo redo) {
  using fg::Access;
  const Bound hb = h_;
  const gpu::DeformParams p = p_;
  const std::uint32_t tetGroups = std::uint32_t((tets_ + HANDSON_DEFORM_GROUP_X - 1) / HANDSON_DEFORM_GROUP_X);
  g.addPass(
      "deform-reset", [&](fg::PassBuilder& b) { b.write(hb.box, Access::TransferDst); },
      [hb, p, redo](fg::Executor& e) {
        GraphExecutor& x = vulkanExecutor(e);
        gpu::DeformBox init{};
        if (redo == Redo::Region) {
          init.lo = glm::ivec4(p.regionVoxLo.x, p.regionVoxLo.y, p.regionVoxLo.z, 0);
          init.hi = glm::ivec4(p.regionVoxHi.x, p.regionVoxHi.y, p.regionVoxHi.z, 0);
        } else if (redo == Redo::WholeVolume) {
          init.lo = glm::ivec4(0);
          init.hi = glm::ivec4(p.dims.x - 1, p.dims.y - 1, p.dims.z - 1, 0);
        } else {
          init.lo = glm::ivec4(INT_MAX);
          init.hi = glm::ivec4(INT_MIN);
        }
        vkCmdUpdateBuffer(x.cmd(), x.buffer(hb.box).handle(), 0, sizeof(init), &init);
      });
  if (redo == Redo::Moved)
    g.addPass(
        "deform-bounds",
        [&](fg::PassBuilder& b) {
          b.read(hb.params, Access::StorageRead);
          b.read(hb.tets, Access::StorageRead);
          b.read(hb.posNew, Access::StorageRead);
          b.read(hb.posOld, Access::StorageRead);
          b.write(hb.box, Access::StorageReadWrite);
        },
        [this, hb, tetGroups](fg::Executor& e) {
          GraphExecutor& x = vulkanExecutor(e);
          vkCmdBindPipeline(x.cmd(), VK_PIPELINE_BIND_POINT_COMPUTE, bounds_.pipeline());
          DescriptorWriter()
              .buffer(0, kParams, x.buffer(hb.params).handle())
              .buffer(1, kSsbo, x.buffer(hb.tets).handle())
              .buffer(2, kSsbo, x.buffer(hb.posNew).handle())
              .buffer(3, kSsbo, x.buffer(hb.posOld).handle())
              .buffer(4, kSsbo, x.buffer(hb.box).handle())
              .push(ctx_, x.cmd(), bounds_);
          vkCmdDispatch(x.cmd(), tetGroups, 1, 1);
        });
  g.addPass(
      "deform-args",
      [&](fg::PassBuilder& b) {
        b.read(hb.params, Access::StorageRead);
        b.write(hb.box, Access::StorageReadWrite);
        b.write(hb.args, Access::StorageWrite);
      },
      [this, hb, whole = redo == Redo::WholeVolume ? 1u : 0u](fg::Executor& e) {
        GraphExecutor& x = vulkanExecutor(e);
        vkCmdBindPipeline(x.cmd(), VK_PIPELINE_BIND_POINT_COMPUTE, args_.pipeline());
        DescriptorWriter()
            .buffer(0, kParams, x.buffer(hb.params).handle())
            .buffer(1, kSsbo, x.buffer(hb.box).handle())
            .buffer(2, kSsbo, x.buffer(hb.args).handle())
            .push(ctx_, x.cmd(), args_);
        vkCmdPushConstants(x.cmd(), args_.layout(), VK_SHADER_STAGE_COMPUTE_BIT, 0, 4, &whole);
        vkCmdDispatch(x.cmd(), 1, 1, 1);
      });
  g.addPass(
      "deform-clear",
      [&](fg::PassBuilder& b) {
        b.read(hb.params, Access::StorageRead);
        b.read(hb.args, Access::IndirectRead);
        b.read(hb.box, Access::StorageRead);
        b.read(hb.source, Access::Sampled);
        b.read(hb.sourceMask, Access::Sampled);
        b.write(hb.volume, Access::StorageReadWrite);
        b.write(hb.mask, Access::StorageReadWrite);
        b.write(hb.owner, Access::StorageReadWrite);
      },
      [this, hb](fg::Executor& e) {
        GraphExecutor& x = vulkanExecutor(e);
        vkCmdBindPipeline(x.cmd(), VK_PIPELINE_BIND_POINT_COMPUTE, clear_.pipeline());
        DescriptorWriter()
            .buffer(0, kParams, x.buffer(hb.params).handle())
            .buffer(1, kSsbo, x.buffer(hb.box).handle())
            .sampledImage(2, x.image(hb.source).view(), nearest_.handle(), VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL)
            .sampledImage(3, x.image(hb.sourceMask).view(), nearest_.handle(), VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL)
            .storageImage(4, x.image(hb.volume).view())
            .storageImage(5, x.image(hb.mask).view())
            .buffer(6, kSsbo, x.buffer(hb.owner).handle())
            .push(ctx_, x.cmd(), clear_);
        vkCmdDispatchIndirect(x.cmd(), x.buffer(hb.args).handle(), 0);
      });
  g.addPass(
      "deform-claim",
      [&](fg::PassBuilder& b) {
        b.read(hb.params, Access::StorageRead);
        b.read(hb.tets, Access::StorageRead);
        b.read(hb.posNew, Access::StorageRead);
        b.read(hb.box, Access::StorageRead);
        b.read(hb.restIdx, Access::StorageRead);
        b.write(hb.owner, Access::StorageReadWrite);
        b.write(hb.affine, Access::StorageWrite);
      },
      [this, hb, tetGroups](fg::Executor& e) {
        GraphExecutor& x = vulkanExecutor(e);
        vkCmdBindPipeline(x.cmd(), VK_PIPELINE_BIND_POINT_COMPUTE, claim_.pipeline());
        DescriptorWriter()
            .buffer(0, kParams, x.buffer(hb.params).handle())
            .buffer(1, kSsbo, x.buffer(hb.tets).handle())
            .buffer(2, kSsbo, x.buffer(hb.posNew).handle())
            .buffer(3, kSsbo, x.buffer(hb.box).handle())
            .buffer(4, kSsbo, x.buffer(hb.owner).handle())
            .buffer(5, kSsbo, x.buffer(hb.restIdx).handle())
            .buffer(6, kSsbo, x.buffer(hb.affine).handle())
            .push(ctx_, x.cmd(), claim_);
        vkCmdDispatch(x.cmd(), tetGroups, 1, 1);
      });
  g.addPass(
      "deform-resolve",
      [&](fg::PassBuilder& b) {
        b.read(hb.params, Access::StorageRead);
        b.read(hb.args, Access::IndirectRead);
        b.read(hb.affine, Access::StorageRead);
        b.read(hb.owner, Access::StorageRead);
        b.read(hb.source, Access::Sampled);
        b.read(hb.sourceMask, Access::Sampled);
        b.write(hb.box, Access::StorageReadWrite);
        b.write(hb.volume, Access::StorageReadWrite);
        b.write(hb.mask, Access::StorageReadWrite);
      },
      [this, hb](fg::Executor& e) {
        GraphExecutor& x = vulkanExecutor(e);
        vkCmdBindPipeline(x.cmd(), VK_PIPELINE_BIND_POINT_COMPUTE, resolve_.pipeline());
        DescriptorWriter()
            .buffer(0, kParams, x.buffer(hb.params).handle())
            .buffer(1, kSsbo, x.buffer(hb.affine).handle())
            .buffer(2, kSsbo, x.buffer(hb.box).handle())
            .buffer(3, kSsbo, x.buffer(hb.owner).handle())
            .sampledImage(4, x.image(hb.source).view(), nearest_.handle(), VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL)
            .sampledImage(5, x.image(hb.sourceMask).view(), nearest_.handle(), VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL)
            .storageImage(6, x.image(hb.volume).view())
            .storageImage(7, x.image(hb.mask).view())
            .push(ctx_, x.cmd(), resolve_);
        vkCmdDispatchIndirect(x.cmd(), x.buffer(hb.args).handle(), 0);
      });
  g.exportResource(hb.volume, Access::Sampled);
  g.exportResource(hb.mask, Access::Sampled);
  return {hb.volume, hb.mask};
}

GpuDeformer::Outputs GpuDeformer::addPassesFromPositions(fg::FrameGraph& g, std::uint32_t slot, const std::vector<Eigen::Vector4f>& positions, Redo redo,
                                                         fg::ResourceHandle sourceVolume, fg::ResourceHandle sourceMask, const Outputs& outputs) {
  if (slot >= slots_.size()) throw Error("deformation: frame slot out of range");
  if (positions.size() != nodes_) throw Error("deformation: one position per fine node expected");
  for (const auto& p : positions)
    if (!p.allFinite()) throw Error("deformation: a fine node position is not finite");
  Slot& s = slots_[slot];
  const VkDeviceSize bytes = nodes_ * 16;
  if (!s.fine || s.fine->size() < bytes) s.fine = std::make_unique<Buffer>(ctx_, bytes, VK_BUFFER_USAGE_TRANSFER_SRC_BIT, Buffer::Memory::HostVisible);
  std::memcpy(s.fine->mapped(), positions.data(), bytes);
  s.fine->flush();
  importResources(g, slot, false, sourceVolume, sourceMask, outputs);
  using fg::Access;
  h_.fineUpload = g.importBuffer("fine-positions-upload", {s.fine->size()}, Access::HostWrite);
  const Bound hb = h_;
  // The positions last taken become the previous ones (for the moved box), then the upload.
  auto copyPass = [&](const char* name, fg::ResourceHandle from, fg::ResourceHandle to) {
    g.addPass(
        name,
        [&](fg::PassBuilder& b) {
          b.read(from, Access::TransferSrc);
          b.write(to, Access::TransferDst);
        },
        [from, to, bytes](fg::Executor& e) {
          GraphExecutor& x = vulkanExecutor(e);
          const VkBufferCopy c{0, 0, bytes};
          vkCmdCopyBuffer(x.cmd(), x.buffer(from).handle(), x.buffer(to).handle(), 1, &c);
        });
  };
  copyPass("deform-keep-previous", hb.posNew, hb.posOld);
  copyPass("deform-upload-positions", hb.fineUpload, hb.posNew);
  return addResamplePasses(g, redo);
}

void GpuDeformer::bind(GraphExecutor& x) {
  const Bound& h = h_;
  if (h.onlyOutputs) {
    x.bindImage(h.volume, volume_);
    x.bindImage(h.mask, mask_);
    if (h.strainVolume.valid()) x.bindImage(h.strainVolume, strainVolume_);
    return;
  }
  const Slot& s = slots_[h.slot];
  x.bindBuffer(h.params, params_);
  x.bindBuffer(h.nodeInfo, nodeInfo_);
  x.bindBuffer(h.rest, rest_);
  x.bindBuffer(h.blocks, blocks_);
  x.bindBuffer(h.elementCorners, elementCorners_);
  x.bindBuffer(h.coarseRest, coarseRest_);
  x.bindBuffer(h.tets, tetBuffer_);
  x.bindBuffer(h.restIdx, restIdx_);
  x.bindBuffer(h.posNew, pos_);
  x.bindBuffer(h.posOld, prev_);
  x.bindBuffer(h.box, box_);
  x.bindBuffer(h.args, argsBuffer_);
  x.bindBuffer(h.owner, owner_);
  x.bindBuffer(h.affine, affine_);
  if (h.fineUpload.valid()) x.bindBuffer(h.fineUpload, *s.fine);
  if (h.strain.valid()) x.bindBuffer(h.strain, *strainBuffer_);
  if (h.strainVolume.valid()) x.bindImage(h.strainVolume, strainVolume_);
  if (h.withState) {
    x.bindBuffer(h.positions, *s.positions);
    x.bindBuffer(h.rotations, *s.rotations);
    x.bindBuffer(h.handles, *s.handles);
  }
  x.bindImage(h.source, source_);
  x.bindImage(h.sourceMask, sourceMask_);
  x.bindImage(h.volume, volume_);
  x.bindImage(h.mask, mask_);
}

DeformFrameStats GpuDeformer::runFrame(const CoarseFrameState& state, Redo redo) {
  return runOwn([&](fg::FrameGraph& g) { addPasses(g, 0, state, redo); });
}

DeformFrameStats GpuDeformer::runFrame(const std::vector<Eigen::Vector4f>& indexPositions) {
  if (indexPositions.size() != nodes_) throw Error("deformation: one position per fine node expected");
  for (const auto& p : indexPositions)
    if (!p.allFinite()) throw Error("deformation: a fine node position is not finite");
  if (ownExecutor_) ownExecutor_->waitLastFrame();
  uploadToBuffer(ctx_, pos_, indexPositions.data(), nodes_ * 16);
  uploadToBuffer(ctx_, prev_, indexPositions.data(), nodes_ * 16);
  return runOwn([&](fg::FrameGraph& g) {
    importResources(g, 0, false);
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
  const auto host = g.importBuffer("deform-box-host", {boxReadback_->size()}, fg::Access::None);
  addReadbackPass(g, "deform-box-readback", h_.box, host);
  g.compile();
  x.setGraph(&g);
  bind(x);
  x.bindBuffer(host, *boxReadback_);
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
  st.movedTets = b.stats.x;
  st.coveredVoxels = b.stats.y;
  st.skippedTets = b.stats.z;
  st.timings = x.completedTimings();
  return st;
}

std::vector<Eigen::Vector4f> GpuDeformer::readPositions() const {
  std::vector<Eigen::Vector4f> out(nodes_);
  downloadFromBuffer(ctx_, pos_, out.data(), nodes_ * 16);
  return out;
}

std::vector<float> GpuDeformer::readStrainVolume() const {
  if (!strainBuffer_) throw Error("deformation: no strain computed yet");
  const fg::ImageDesc d = strainVolume_.desc();
  std::vector<float> out(std::size_t(d.width) * d.height * d.depth);
  readImage(ctx_, strainVolume_, out.data(), out.size() * sizeof(float));
  return out;
}

std::vector<std::uint16_t> GpuDeformer::readVolume() const {
  const fg::ImageDesc d = volume_.desc();
  std::vector<std::uint16_t> out(std::size_t(d.width) * d.height * d.depth);
  readImage(ctx_, volume_, out.data(), out.size() * 2);
  return out;
}

std::vector<std::uint8_t> GpuDeformer::readMask() const {
  const fg::ImageDesc d = mask_.desc();
  std::vector<std::uint8_t> out(std::size_t(d.width) * d.height * d.depth);
  readImage(ctx_, mask_, out.data(), out.size());
  return out;
}

}  // namespace handson::vk
