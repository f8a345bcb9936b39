#pragma once
// `handson deform`'s resampling of the deformed volume: on the CPU (rasterizeDeformed) or through the
// GPU passes (GpuDeformer), sliding handles drawn where their poses put them, and the strain volume.
#include <Eigen/Core>
#include <cstdint>
#include <string>
#include <vector>

#include "render/vk_context.h"
#include "sim/coarsening.h"
#include "sim/sim_scene.h"
#include "sim/tet_raster.h"

namespace handson::cli {

/// The handles the resampling draws where their poses put them (those with a sliding interface):
/// the rest mask (handle i has id i + 1; empty when none) and each handle's id (0: drawn by the tets).
struct RigidHandles {
  std::vector<std::uint8_t> mask;
  std::vector<std::uint32_t> ids;
  std::vector<std::array<Eigen::Vector3i, 2>> boxes;  ///< each handle's voxels' index box
};
RigidHandles rigidHandlesOf(const Volume& image, const std::vector<SimHandle>& handles, const SimScene& scene);

/// The rasterization options of `scene` at poses T: the cap on a tet's voxels and the rigid handles
/// (pointing into `rigid`, which must outlive them).
RasterOptions rasterOptions(const Volume& image, const SimScene& scene, const RigidHandles& rigid, const std::vector<RigidTransform>& T);

/// What the GPU passes are given: the scene at poses T, the coarse state xc (with `model`) when
/// `fromCoarseState`, else the fine positions x.
struct GpuResampleInput {
  const SimScene* scene = nullptr;
  const CoarseModel* model = nullptr;
  std::vector<RigidTransform> T;  ///< the handles drawn rigidly
  const std::vector<Eigen::Vector3d>* xc = nullptr;
  const std::vector<Eigen::Vector3d>* x = nullptr;
  bool fromCoarseState = false;
  const RigidHandles* rigid = nullptr;
  /// The coarse state's handles where the model has more than those drawn (a retractor); empty: T.
  std::vector<RigidTransform> modelT;
};

struct GpuResample {
  Volume image;  ///< region voxels the GPU's, the rest the input's
  std::size_t regionVoxels = 0, covered = 0;
};

/// The GPU passes on a device of their own (any validation message is an error).
GpuResample resampleOnNewDevice(const vk::ContextOptions& options, const Volume& image, const GpuResampleInput& in);

/// Which tet covers each voxel of the image at fine positions x (-1 none, kRigidVoxel a rigid
/// handle's): the CPU rasterization with `raster`, for the strain volume after a GPU resampling.
std::vector<std::int32_t> voxelTets(const Volume& image, const SimScene& scene, const std::vector<Eigen::Vector3d>& x, RasterOptions raster);

}  // namespace handson::cli
