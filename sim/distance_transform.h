#pragma once
// Exact Euclidean distance transform on an anisotropic voxel grid (Felzenszwalb & Huttenlocher's
// separable lower-envelope method, one pass per axis, O(voxels)).
#include <cstdint>
#include <vector>

#include <Eigen/Core>

#include "sim/volume.h"

namespace handson {

/// For each voxel, the squared distance in mm^2 to the nearest voxel where `inside` is 0
/// (0 for voxels outside). dims and spacing as in VolumeGeometry; inside is x-fastest.
std::vector<float> squaredDistanceToOutside(const std::vector<std::uint8_t>& inside, const Eigen::Vector3i& dims,
                                            const Eigen::Vector3d& spacing);

/// The distance transform of a region (linear indices on a grid) on the region's bounding box grown
/// by one voxel, so that every voxel of the region has its outside in the box.
struct RegionDistance {
  Eigen::Vector3i lo, dims;  ///< the box's first voxel (may lie one outside the grid) and its size
  std::vector<float> d2;     ///< per box voxel (x-fastest): squared mm to the nearest voxel outside the region, 0 outside
  std::size_t index(const Eigen::Vector3i& v) const {
    const Eigen::Vector3i r = v - lo;
    return std::size_t(r.x()) + std::size_t(dims.x()) * (std::size_t(r.y()) + std::size_t(dims.y()) * std::size_t(r.z()));
  }
  float at(const VolumeGeometry& g, std::uint32_t voxel) const { return d2[index(g.voxelOf(voxel))]; }
};
/// `region` must not be empty.
RegionDistance regionDistance(const std::vector<std::uint32_t>& region, const VolumeGeometry& g);
/// The region's deepest voxel: the largest distance to its outside, the first of `region` on ties
/// (`region` not empty).
std::uint32_t deepestVoxelOf(const std::vector<std::uint32_t>& region, const RegionDistance& d, const VolumeGeometry& g);

}  // namespace handson
