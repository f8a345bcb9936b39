#pragma once
// What the tissue feels, per fine tet (docs/simulation-outputs.md, "Strain"): the largest principal
// stretch minus one, max_i sigma_i(F) - 1, of the deformation gradient F = D_s D_m^-1 (3 x 3; D_s,
// D_m: the current and rest edge matrices of the tet, columns x_i - x_0 and X_i - X_0). Rotation-
// free (a rigid motion gives 0; the singular values of F do not see R), 0.01 for a 1 % stretch,
// negative only where every direction is compressed.
#include <Eigen/Core>
#include <cstdint>
#include <vector>

#include "sim/tet_mesh.h"
#include "sim/volume.h"

namespace handson {

/// Per tet of `mesh` at positions x. A degenerate rest tet, or non-finite positions, gives NaN for
/// that tet (the caller decides); an inverted one its stretch all the same (sigma >= 0).
std::vector<float> tetStrain(const TetMesh& mesh, const std::vector<Eigen::Vector3d>& x);

/// The strain on the image's grid: each voxel takes the strain of the deformed tet that covers it
/// (`tetOf` from rasterizeDeformed), 0 elsewhere (outside the simulated region). Float32.
Volume strainVolume(const VolumeGeometry& grid, const std::vector<std::int32_t>& tetOf, const std::vector<float>& strain);

}  // namespace handson
