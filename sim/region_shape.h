#pragma once
// The simulated region shaped by the handles (docs/simulation-model.md, "Region of interest").
//
// The coarse grid still spans the handles' padded bounding box, but only the grid cells within the
// padding of the handles themselves (their voxels at rest and at every pose they will reach) are
// simulated; every fine node on a cell outside that set is held at rest, like the box's faces. A
// kidney's box holds corners 60-70 mm from the kidney where nothing moves; its cells cost a frame
// as much as the cells beside the handle.
#include <Eigen/Core>
#include <vector>

#include "sim/tet_mesh.h"

namespace handson {

/// A handle as points (world mm): its voxel centres thinned to one per bucket of `bucketMm`, with
/// `surface` set for the points whose bucket has an empty neighbour bucket (the handle's outside).
struct HandlePoints {
  std::vector<Eigen::Vector3d> point;
  std::vector<char> surface;
  double bucketMm = 1.0;
};
HandlePoints thinHandlePoints(const std::vector<Eigen::Vector3d>& voxelCentres, double bucketMm);

/// Per cell of `grid`: 1 when the cell holds one of the points or its box lies within `padding` mm
/// of a surface point (the distance from the nearest point of the box).
std::vector<char> cellsNearPoints(const KuhnGrid& grid, const HandlePoints& points, double padding);

/// Sets `in` for every cell of `seed` and its 26 neighbours (both per cell of `grid`).
void markCellNeighbours(const KuhnGrid& grid, const std::vector<char>& seed, std::vector<char>& in);

/// True when one of a handle's outside points (at rest, world mm) moved by T comes within `margin`
/// of a cell outside `inRegion` (nearRegionBoundary): the region must be rebuilt around the handle.
bool outlineNearRegionBoundary(const KuhnGrid& grid, const std::vector<char>& inRegion, const std::vector<Eigen::Vector3d>& outline,
                               const Eigen::Matrix3d& R, const Eigen::Vector3d& t, double margin);

/// True when a ball of radius `margin` about p (world mm) reaches a cell of the grid outside
/// `inRegion`: a handle moved there has come close to the region's fixed boundary (the grid's own
/// box is checked by the caller).
bool nearRegionBoundary(const KuhnGrid& grid, const std::vector<char>& inRegion, const Eigen::Vector3d& p, double margin);

}  // namespace handson
