#pragma once
// The voxel nearest a world point, for the interaction code that walks rays and seeds through a grid.
#include <Eigen/Core>

#include <optional>

#include "sim/volume.h"

namespace handson {

/// The voxel whose centre is nearest `world` (RAS mm), if it lies in the grid; nullopt for a point
/// outside it or a non-finite one.
inline std::optional<Eigen::Vector3i> nearestVoxel(const VolumeGeometry& g, const Eigen::Vector3d& world) {
  const Eigen::Vector3d idx = g.toIndex(world).array().round();
  if (!idx.allFinite() || (idx.array().abs() > 1e9).any()) return std::nullopt;
  const Eigen::Vector3i v = idx.cast<int>();
  if (!g.contains(v)) return std::nullopt;
  return v;
}

/// The linear (x-fastest) index of a voxel in the grid.
inline std::size_t linearIndex(const VolumeGeometry& g, const Eigen::Vector3i& v) {
  return std::size_t(v.x()) + std::size_t(g.dims.x()) * (std::size_t(v.y()) + std::size_t(g.dims.y()) * std::size_t(v.z()));
}

}  // namespace handson
