#pragma once
// Volume resampling by tetrahedral rasterization (../shared/spec/methods.md section 6), the CPU
// reference: each deformed tet's voxels (centres inside it, barycentric coordinates >= -1e-9) take
// the source image sampled trilinearly at the rest position sum_k lambda_k X_k. Voxels of the
// region no tet covers keep the background value; overlaps (inverted or folded tets) go to the
// lowest-numbered tet, so the result is deterministic. Outside the region the image is unchanged.
#include <Eigen/Core>
#include <vector>

#include "sim/tet_mesh.h"
#include "sim/volume.h"

namespace handson {

struct RasterStats {
  std::size_t regionVoxels = 0;  ///< voxels whose centres lie in the region (cleared first)
  std::size_t covered = 0;       ///< voxels written by a tet
  std::size_t overlaps = 0;      ///< voxel hits after the first (shared faces, folded tets)
};

/// `out` gets the deformed image on the source's grid. `regionLo`/`regionHi`: the world box the mesh
/// filled at rest (cleared to `background` before rasterizing).
RasterStats rasterizeDeformed(const Volume& source, const TetMesh& mesh, const std::vector<Eigen::Vector3d>& deformed, const Eigen::Vector3d& regionLo,
                              const Eigen::Vector3d& regionHi, float background, Volume& out);

}  // namespace handson
