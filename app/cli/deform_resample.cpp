#include "deform_resample.h"

#include <algorithm>

#include "render/deform_pass.h"
#include "render/vk_resources.h"
#include "sim/base/error.h"
#include "sim/fine_interpolation.h"
#include "sim/quantized_volume.h"
#include "sim/sliding_interface.h"

namespace handson::cli {

RigidHandles rigidHandlesOf(const Volume& image, const std::vector<SimHandle>& handles, const SimScene& sc) {
  RigidHandles r;
  const std::vector<char> slides = slidingHandles(sc.constraints.slide, handles.size());
  if (std::none_of(slides.begin(), slides.end(), [](char s) { return s != 0; })) return {};
  for (std::size_t h = 0; h < handles.size(); ++h) r.ids.push_back(slides[h] ? std::uint32_t(h + 1) : 0);
  r.mask.assign(image.voxelCount(), 0);
  for (std::size_t h = 0; h < handles.size(); ++h) {
    for (std::uint32_t v : handles[h].voxels) r.mask[v] = std::uint8_t(h + 1);
    r.boxes.push_back(voxelIndexBox(image.geometry(), handles[h].voxels));
  }
  return r;
}

RasterOptions rasterOptions(const Volume& image, const SimScene& sc, const RigidHandles& rigid, const std::vector<RigidTransform>& T) {
  RasterOptions o;
  o.maxTetVoxels = defaultMaxTetVoxels(sc.meshes.fine, image.geometry().worldToIndex());
  if (rigid.mask.empty()) return o;
  o.restMask = &rigid.mask;
  o.rigid = rigidDraws(image.geometry(), rigid.ids, T);
  return o;
}

namespace {

std::vector<Eigen::Matrix4f> worldPoses(const std::vector<RigidTransform>& T) {
  std::vector<Eigen::Matrix4f> out;
  for (const auto& t : T) out.push_back(t.matrix().cast<float>());
  return out;
}

// Records that keep every fine node where it is told (positions computed elsewhere).
FineInterpolationData positionsOnly(const SimScene& sc) {
  FineInterpolationData data;
  data.node.assign(sc.meshes.fine.nodes.size(), {FineInterpolationData::Rest, 0, 0, 0});
  for (const auto& X : sc.meshes.fine.nodes) data.rest.emplace_back(float(X.x()), float(X.y()), float(X.z()), 1.0f);
  data.coarseRest = {Eigen::Vector4f(0, 0, 0, 1)};
  data.elementCorners = {{0, 0, 0, 0}, {0, 0, 0, 0}};
  return data;
}

// The GPU passes: the image quantized to 16 bits as the renderer holds it; the coarse state goes
// through the interpolation pass when in.fromCoarseState, else the fine positions are uploaded.
// Region voxels take the GPU's values; the rest of the image is copied from the input unchanged.
GpuResample resampleOnGpu(const vk::Context& ctx, const Volume& image, const GpuResampleInput& in) {
  const SimScene& sc = *in.scene;
  const QuantizedVolume q = quantizeVolume(image);
  const VolumeGeometry& g = q.geometry;
  const fg::ImageDesc desc{std::uint32_t(g.dims.x()), std::uint32_t(g.dims.y()), std::uint32_t(g.dims.z()), fg::Format::R16Unorm};
  const VkImageUsageFlags usage = VK_IMAGE_USAGE_SAMPLED_BIT | VK_IMAGE_USAGE_TRANSFER_DST_BIT | VK_IMAGE_USAGE_TRANSFER_SRC_BIT;
  vk::Image volume(ctx, desc, usage, true), mask(ctx, {desc.width, desc.height, desc.depth, fg::Format::R8Unorm}, usage, true);
  vk::uploadToImage(ctx, volume, q.data.data(), q.data.size() * 2, VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL);
  const bool rigid = in.rigid && !in.rigid->mask.empty();
  const std::vector<std::uint8_t> ids = rigid ? in.rigid->mask : std::vector<std::uint8_t>(q.data.size(), 0);
  vk::uploadToImage(ctx, mask, ids.data(), ids.size(), VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL);
  const FineInterpolationData data = in.fromCoarseState ? in.model->interpolationData() : positionsOnly(sc);
  vk::DeformSetup setup;
  setup.interpolation = &data;
  setup.fineTets = &sc.meshes.fine.tets;
  setup.regionLo = sc.lo;
  setup.regionHi = sc.hi;
  setup.background = q.toNormalized(image.valueRange().first);  // as on the CPU path
  setup.worldToIndex = g.worldToIndex();
  setup.commitVoxels = 0.0;
  const std::vector<RigidTransform>& stateT = in.modelT.empty() ? in.T : in.modelT;
  if (rigid) {
    setup.rigidIds = in.rigid->ids;
    setup.rigidRestBoxes = in.rigid->boxes;
    // Handles the model has beyond those drawn (a retractor) are drawn by their tets (id 0).
    setup.rigidIds.resize(std::max(setup.rigidIds.size(), stateT.size()), 0);
    setup.rigidRestBoxes.resize(setup.rigidIds.size(), setup.rigidRestBoxes.front());
  }
  vk::GpuDeformer gpu(ctx, volume, mask, setup, 1);
  if (rigid) gpu.setHandlePoses(worldPoses(stateT));
  vk::DeformFrameStats st;
  if (in.fromCoarseState) {
    st = gpu.runFrame(packFrameState(*in.xc, in.model->elementRotations(*in.xc), stateT), vk::Redo::Region);
  } else {
    std::vector<Eigen::Vector4f> idx(in.x->size());
    const Eigen::Matrix4d w2i = g.worldToIndex();
    for (std::size_t i = 0; i < idx.size(); ++i) idx[i] = (w2i * (*in.x)[i].homogeneous()).cast<float>();
    st = gpu.runFrame(idx);
  }
  GpuResample r{image, 0, st.coveredVoxels};
  r.regionVoxels = takeRegionFromQuantized(r.image, q, gpu.readVolume(), sc.lo, sc.hi);
  return r;
}

}  // namespace

GpuResample resampleOnNewDevice(const vk::ContextOptions& co, const Volume& image, const GpuResampleInput& in) {
  const vk::Context ctx(co);
  GpuResample r = resampleOnGpu(ctx, image, in);
  if (ctx.validationMessageCount()) throw Error("Vulkan validation messages were reported");
  return r;
}

std::vector<std::int32_t> voxelTets(const Volume& image, const SimScene& sc, const std::vector<Eigen::Vector3d>& x, RasterOptions raster) {
  std::vector<std::int32_t> tetOf;
  Volume unused;
  raster.tetOf = &tetOf;
  rasterizeDeformed(image, sc.meshes.fine, x, {sc.lo, sc.hi, image.valueRange().first}, unused, raster);
  return tetOf;
}

}  // namespace handson::cli
