#pragma once
// Volume resampling by tetrahedral rasterization (docs/gpu-deformation.md), the CPU
// reference: each deformed tet's voxels (centres inside it, barycentric coordinates >= -1e-9) take
// the source image sampled trilinearly at the rest position sum_k lambda_k X_k. Voxels of the
// region no tet covers keep the background value; overlaps (inverted or folded tets) go to the
// lowest-numbered tet, so the result is deterministic. Writes stay inside the region's voxels (a
// folded tet poking out of the box is clipped); outside the region the image is unchanged.
// With a handle-id mask, covered voxels also take the mask's id at the rest position (nearest
// voxel), so the handles' fine tets carry their ids where they moved; cleared voxels get 0.
// Handles drawn rigidly (RigidDraw: a sliding handle, whose surface nodes slide with the tissue so
// the fine tets straddling its surface would smear its outermost voxels) take first every covered
// voxel whose rest voxel under their pose is their own; a voxel the tets map onto such a handle's
// voxels elsewhere is tissue that slid there: it takes the value of the voxel nearest to its rest
// position outside those handles (within 2 voxels), mask 0.
#include <Eigen/Core>
#include <Eigen/LU>
#include <array>
#include <cstdint>
#include <vector>

#include "sim/quantized_volume.h"
#include "sim/rigid_transform.h"
#include "sim/tet_mesh.h"
#include "sim/volume.h"

namespace handson {

/// A voxel centre belongs to a tet when all its barycentric coordinates are >= -kRasterTolerance
/// (voxel centres on shared faces are claimed by both neighbours, the lower index wins, never by
/// neither); tets' voxel ranges are widened by kRasterBoxMargin voxels. The GPU passes
/// (shaders/deform_claim.comp) use the same numbers.
constexpr double kRasterTolerance = 1e-5;
constexpr double kRasterBoxMargin = 1e-4;

struct RasterStats {
  std::size_t regionVoxels = 0;  ///< voxels whose centres lie in the region (cleared first)
  std::size_t covered = 0;       ///< voxels written by a tet
  std::size_t overlaps = 0;      ///< voxel hits after the first (shared faces, folded tets)
  std::size_t skipped = 0;       ///< tets whose voxel range exceeded maxTetVoxels
};

/// A handle drawn where its rigid pose puts it: a voxel at index x is the handle's when the rest
/// mask's nearest voxel to currentToRest * x (inside the grid) holds `id` (> 0).
struct RigidDraw {
  std::uint8_t id = 0;
  Eigen::Matrix4d currentToRest = Eigen::Matrix4d::Identity();  ///< index space -> index space
};

/// A world pose (rest -> moved, homogeneous) in voxel index space: w2i T w2i^-1.
inline Eigen::Matrix4d indexSpacePose(const Eigen::Matrix4d& worldPose, const Eigen::Matrix4d& worldToIndex) {
  return worldToIndex * worldPose * worldToIndex.inverse();
}

/// The draws of the handles whose mask ids are `ids[i]` (0: not drawn rigidly) at world poses T[i].
std::vector<RigidDraw> rigidDraws(const VolumeGeometry& g, const std::vector<std::uint32_t>& ids, const std::vector<RigidTransform>& T);

/// The index box [lo, hi] of voxels (linear indices on g); lo > hi when there are none.
std::array<Eigen::Vector3i, 2> voxelIndexBox(const VolumeGeometry& g, const std::vector<std::uint32_t>& voxels);

/// tetOf's value at a voxel a rigidly drawn handle took (no tet: no strain).
constexpr std::int32_t kRigidVoxel = -2;

/// What rasterizeDeformed reads and writes besides the image.
struct RasterOptions {
  const std::vector<std::uint8_t>* restMask = nullptr;  ///< handle ids at rest (needed by outMask and rigid)
  std::vector<std::uint8_t>* outMask = nullptr;         ///< the ids where they moved
  std::uint64_t maxTetVoxels = UINT64_MAX;
  std::vector<std::int32_t>* tetOf = nullptr;           ///< per voxel: its tet, -1 none, kRigidVoxel
  std::vector<RigidDraw> rigid;
};

/// The default cap on a tet's voxel range: 64 times the largest rest tet's (at least 4096).
std::uint64_t defaultMaxTetVoxels(const TetMesh& mesh, const Eigen::Matrix4d& worldToIndex);

/// The world box [lo, hi] the mesh filled at rest, and the value its voxels are cleared to before
/// rasterizing.
struct RasterRegion {
  Eigen::Vector3d lo = Eigen::Vector3d::Zero(), hi = Eigen::Vector3d::Zero();
  float background = 0.0f;
};

/// `out` gets the deformed image on the source's grid, the region's voxels drawn from the mesh at its
/// deformed positions. `options.tetOf` (optional): per voxel of the grid, the tet that wrote it, -1
/// where none did (outside the region, or uncovered).
RasterStats rasterizeDeformed(const Volume& source, const TetMesh& mesh, const std::vector<Eigen::Vector3d>& deformed, const RasterRegion& region,
                              Volume& out, const RasterOptions& options = {});

/// The voxel index box [lo, hi] (inclusive, clamped to the grid) of the voxels whose centres lie in
/// the world box [regionLo, regionHi] up to 1e-3 mm; empty (lo > hi) when none.
void regionVoxelBox(const Eigen::Matrix4d& worldToIndex, const Eigen::Vector3i& dims, const Eigen::Vector3d& regionLo, const Eigen::Vector3d& regionHi,
                    Eigen::Vector3i& lo, Eigen::Vector3i& hi);
void regionVoxelBox(const VolumeGeometry& g, const Eigen::Vector3d& regionLo, const Eigen::Vector3d& regionHi, Eigen::Vector3i& lo, Eigen::Vector3i& hi);
/// Whether a world point lies in the region box (the same 1e-3 mm tolerance).
inline bool inRegion(const Eigen::Vector3d& w, const Eigen::Vector3d& lo, const Eigen::Vector3d& hi) {
  return ((w - lo).array() >= -1e-3).all() && ((hi - w).array() >= -1e-3).all();
}
/// Calls f(linear voxel index) for every voxel whose centre lies in the region; returns their count.
template <class F> std::size_t forEachRegionVoxel(const VolumeGeometry& g, const Eigen::Vector3d& regionLo, const Eigen::Vector3d& regionHi, F&& f) {
  Eigen::Vector3i lo, hi;
  regionVoxelBox(g, regionLo, regionHi, lo, hi);
  std::size_t n = 0;
  for (int k = lo.z(); k <= hi.z(); ++k)
    for (int j = lo.y(); j <= hi.y(); ++j)
      for (int i = lo.x(); i <= hi.x(); ++i)
        if (inRegion(g.toWorld(Eigen::Vector3d(i, j, k)), regionLo, regionHi)) {
          f(std::size_t(i) + std::size_t(g.dims.x()) * (std::size_t(j) + std::size_t(g.dims.y()) * std::size_t(k)));
          ++n;
        }
  return n;
}
/// `image` with the region's voxels replaced by a deformed copy held as 16-bit values over the
/// quantized window (what the GPU passes produce); returns the region's voxel count.
std::size_t takeRegionFromQuantized(Volume& image, const QuantizedVolume& q, const std::vector<std::uint16_t>& values, const Eigen::Vector3d& regionLo,
                                    const Eigen::Vector3d& regionHi);

}  // namespace handson
