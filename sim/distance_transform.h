#pragma once
// Exact Euclidean distance transform on an anisotropic voxel grid (Felzenszwalb & Huttenlocher's
// separable lower-envelope method, one pass per axis, O(voxels)).
#include <cstdint>
#include <vector>

#include <Eigen/Core>

namespace handson {

/// For each voxel, the squared distance in mm^2 to the nearest voxel where `inside` is 0
/// (0 for voxels outside). dims and spacing as in VolumeGeometry; inside is x-fastest.
std::vector<float> squaredDistanceToOutside(const std::vector<std::uint8_t>& inside, const Eigen::Vector3i& dims,
                                            const Eigen::Vector3d& spacing);

}  // namespace handson
