#include "deform_setup.h"

#include <Eigen/LU>

#include <algorithm>
#include <climits>
#include <cmath>
#include <string>

#include "render/render_params.h"
#include "sim/base/error.h"
#include "sim/tet_raster.h"
#include "sim/tissue_limits.h"
#include "vk_context.h"

namespace handson::vk {

namespace {

// The device features the passes need: 16-bit storage images, subgroup arithmetic and ballot.
void checkDevice(const Context& ctx) {
  if (!ctx.storageExtendedFormats())
    throw Error("deformation: this Vulkan device cannot write 16-bit storage images (shaderStorageImageExtendedFormats)");
  {
    VkPhysicalDeviceSubgroupProperties sub{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_SUBGROUP_PROPERTIES};
    VkPhysicalDeviceProperties2 p2{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_PROPERTIES_2};
    p2.pNext = &sub;
    vkGetPhysicalDeviceProperties2(ctx.physicalDevice(), &p2);
    if (!(sub.supportedStages & VK_SHADER_STAGE_COMPUTE_BIT) || !(sub.supportedOperations & VK_SUBGROUP_FEATURE_ARITHMETIC_BIT) ||
        !(sub.supportedOperations & VK_SUBGROUP_FEATURE_BALLOT_BIT))
      throw Error("deformation: this Vulkan device lacks subgroup arithmetic or ballot in compute shaders");
  }
}

// Each fine node's reconstruction record and handle blocks within range.
void checkNodeRecords(const FineInterpolationData& d, std::size_t coarseNodes, std::size_t coarseElements) {
  const std::size_t handles = d.handleCount;
  for (const auto& n : d.node) {
    const std::size_t hc = 3 * std::size_t(d.cornersPerElement);  // H blocks before the handle blocks
    if (n[0] == FineInterpolationData::Interior && std::size_t(n[2]) + d.interiorBlocks(n[3]) <= d.blocks.size())
      for (std::uint32_t k = 0; k < n[3]; ++k) {
        const float hidx = d.blocks[std::size_t(n[2]) + hc + 13 * k].x();
        // -1: the anchored skeleton (the identity, shaders/deform_interpolate.comp).
        if (!(hidx == -1.0f || (hidx >= 0.0f && hidx < float(handles) && hidx == std::floor(hidx)))) throw Error("deformation: a handle block refers to a missing handle");
      }
    const bool ok = n[0] == FineInterpolationData::Rest || (n[0] == FineInterpolationData::Handle && n[1] < handles) ||
                    (n[0] == FineInterpolationData::Corner && n[1] < coarseNodes) ||
                    (n[0] == FineInterpolationData::Boundary && n[1] < coarseElements && std::size_t(n[2]) + d.cornersPerElement / 4 <= d.blocks.size()) ||
                    (n[0] == FineInterpolationData::Interior && n[1] < coarseElements && std::size_t(n[2]) + d.interiorBlocks(n[3]) <= d.blocks.size());
    if (!ok) throw Error("deformation: a fine node's reconstruction record is out of range");
  }
}

// The per-tet strain limits and the rigidly drawn handles' ids and boxes.
void checkLimitsAndRigidHandles(const DeformSetup& setup, std::size_t tetCount, std::size_t handles) {
  if (setup.strainLimits) {
    if (setup.strainLimits->size() != tetCount)
      throw Error("deformation: " + std::to_string(setup.strainLimits->size()) + " strain limits for " + std::to_string(tetCount) + " fine tets");
    for (float l : *setup.strainLimits)
      if (!(l > 0.0f) && l != kRigidStrainLimit) throw Error("deformation: a strain limit is not a positive number (inf: none; -1: a sliding handle's own tet)");
  }

  if (!setup.rigidIds.empty() && handles != 0 && setup.rigidIds.size() != handles)
    throw Error("deformation: " + std::to_string(setup.rigidIds.size()) + " rigid-draw ids for " + std::to_string(handles) + " handles");
  for (auto id : setup.rigidIds)
    if (id > 255) throw Error("deformation: a handle drawn rigidly has an id beyond the mask's 255");
  if (!setup.rigidRestBoxes.empty() && setup.rigidRestBoxes.size() != setup.rigidIds.size())
    throw Error("deformation: one rest box per handle drawn rigidly expected");
  for (const auto& b : setup.rigidRestBoxes)
    if ((b[0].array() > b[1].array()).any()) throw Error("deformation: a rigid handle's rest box is empty");
}

}  // namespace

ValidatedDeformSetup validateDeformSetup(const Context& ctx, const fg::ImageDesc& sd, const fg::ImageDesc& md, const DeformSetup& setup) {
  ValidatedDeformSetup out;
  if (!setup.interpolation || !setup.fineTets) throw Error("deformation: no mesh data");
  const FineInterpolationData& d = *setup.interpolation;
  checkDevice(ctx);
  if (sd.format != fg::Format::R16Unorm || md.format != fg::Format::R8Unorm || sd.width != md.width || sd.height != md.height || sd.depth != md.depth)
    throw Error("deformation: the source volume (R16) and mask (R8) must share one grid");
  const std::size_t nodes = d.node.size();
  const std::size_t tetCount = setup.fineTets->size();
  const std::size_t coarseNodes = d.coarseRest.size();
  if (d.cornersPerElement != 4 && d.cornersPerElement != 8) throw Error("deformation: coarse elements have 4 or 8 corners");
  if (d.elementCorners.size() % 2 != 0) throw Error("deformation: two corner records per coarse element expected");
  const std::size_t coarseElements = d.elementCount();
  const std::size_t handles = d.handleCount;
  if (nodes == 0 || tetCount == 0 || d.rest.size() != nodes || coarseNodes == 0 || coarseElements == 0)
    throw Error("deformation: empty or inconsistent mesh data");
  if (nodes > std::size_t(INT_MAX) || tetCount > std::size_t(INT_MAX)) throw Error("deformation: the fine mesh is too large");
  out.tets.resize(tetCount);
  for (std::size_t t = 0; t < tetCount; ++t)
    for (int c = 0; c < 4; ++c) {
      const int v = (*setup.fineTets)[t][std::size_t(c)];
      if (v < 0 || std::size_t(v) >= nodes) throw Error("deformation: a fine tet refers to a missing node");
      out.tets[t][std::size_t(c)] = std::uint32_t(v);
    }
  static_assert(kRasterTolerance == 1e-5 && kRasterBoxMargin == 1e-4, "shaders/deform_claim.comp uses these numbers");
  checkNodeRecords(d, coarseNodes, coarseElements);
  for (const auto& t : d.elementCorners)
    for (auto v : t)
      if (v >= coarseNodes) throw Error("deformation: a coarse element refers to a missing node");

  checkLimitsAndRigidHandles(setup, tetCount, handles);

  const std::uint64_t maxGroups = ctx.properties().limits.maxComputeWorkGroupCount[0];
  if ((nodes + HANDSON_DEFORM_GROUP_X - 1) / HANDSON_DEFORM_GROUP_X > maxGroups || (tetCount + HANDSON_DEFORM_GROUP_X - 1) / HANDSON_DEFORM_GROUP_X > maxGroups)
    throw Error("deformation: the fine mesh (" + std::to_string(tetCount) + " tets) needs more workgroups than this device dispatches at once (" +
                std::to_string(maxGroups * HANDSON_DEFORM_GROUP_X) + " invocations)");
  const Eigen::Vector3i dims(int(sd.width), int(sd.height), int(sd.depth));
  Eigen::Vector3i rlo, rhi;
  regionVoxelBox(setup.worldToIndex, dims, setup.regionLo, setup.regionHi, rlo, rhi);
  if ((rlo.array() > rhi.array()).any()) throw Error("deformation: the region lies outside the volume");
  const Eigen::Vector3i od = rhi - rlo + Eigen::Vector3i::Ones();
  out.ownerBytes = std::uint64_t(od.x()) * std::uint64_t(od.y()) * std::uint64_t(od.z()) * 4;
  if (out.ownerBytes > ctx.properties().limits.maxStorageBufferRange)
    throw Error("deformation: the region is larger than this device's storage buffers allow");

  out.params.worldToIndex = toGlm(setup.worldToIndex);
  out.params.indexToWorld = toGlm(setup.worldToIndex.inverse());
  auto ivec3 = [](const Eigen::Vector3i& v) { return glm::ivec3(v.x(), v.y(), v.z()); };
  out.params.regionLo = glm::vec3(float(setup.regionLo.x()), float(setup.regionLo.y()), float(setup.regionLo.z()));
  out.params.background = setup.background;
  out.params.regionHi = glm::vec3(float(setup.regionHi.x()), float(setup.regionHi.y()), float(setup.regionHi.z()));
  out.params.motionLagVoxels = 0.0f;  // set by the deformer
  out.params.regionVoxLo = ivec3(rlo);
  out.params.fineNodeCount = int(nodes);
  out.params.regionVoxHi = ivec3(rhi);
  out.params.fineTetCount = int(tetCount);
  out.params.volumeDims = ivec3(dims);
  out.params.handleCount = int(handles);
  out.params.ownerDims = ivec3(od);
  out.params.coarseElementCount = int(coarseElements);
  const Eigen::Vector3i bd = (od + Eigen::Vector3i::Constant(HANDSON_DEFORM_BRICK - 1)) / HANDSON_DEFORM_BRICK;
  out.params.brickGrid = ivec3(bd);
  out.params.brickCount = bd.x() * bd.y() * bd.z();
  {
    TetMesh rest;  // the rest mesh in world space, for the default cap
    rest.nodes.reserve(nodes);
    for (const auto& X : d.rest) rest.nodes.emplace_back(double(X.x()), double(X.y()), double(X.z()));
    rest.tets = *setup.fineTets;
    const std::uint64_t cap = setup.maxTetVoxels ? setup.maxTetVoxels : defaultMaxTetVoxels(rest, setup.worldToIndex);
    out.params.maxTetVoxels = std::uint32_t(std::min<std::uint64_t>(cap, UINT32_MAX));
    out.params.cornersPerElement = d.cornersPerElement;
    out.params.writeOverLimit = setup.strainLimits ? 1u : 0u;
  }
  return out;
}

}  // namespace handson::vk
