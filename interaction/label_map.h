#pragma once
// Label maps as handles (docs/touch-app.md, "Label maps"): organ labels that a user already has
// (TotalSegmentator, 3D-IRCADb, a Slicer segmentation) put on the image's grid, and the connected
// component of the label under a seed - what a tap in select mode, the "label-handle" UI action and
// `handson select --labels` make a handle of.
#include <Eigen/Core>

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "sim/volume.h"

namespace handson {

/// Labels on an image's grid: 0 is background, organs 1..65535.
struct LabelMap {
  VolumeGeometry geometry;             ///< the image's grid
  std::vector<std::uint16_t> labels;   ///< per voxel of `geometry`, x-fastest
  bool resampled = false;              ///< the file was on another grid: put on this one by nearest neighbour
  std::string note;                    ///< one line on what was done, for a warning ("" when nothing)
  std::uint16_t at(const Eigen::Vector3i& v) const;
};

/// `labels` on `target`'s grid: taken as they are when both share the grid (VolumeGeometry::sameGrid),
/// else resampled by nearest neighbour in physical space - each target voxel centre takes the label
/// of the label voxel whose centre is nearest in index space (round half up); centres outside the
/// label map are background. Throws handson::Error for a value that is not an integer in 0..65535
/// (NaN included: labels are never interpolated), for a map whose voxels cover none of the target's
/// centres, and for one that holds no label there.
LabelMap labelsOnGrid(const Volume& labels, const VolumeGeometry& target);

/// The voxels (linear indices, ascending) of the 26-connected component of the seed's label that
/// holds the seed: a whole organ as labelled, not its neighbours of another label. Throws
/// handson::Error when the seed lies outside the grid or on background (label 0).
std::vector<std::uint32_t> labelComponent(const LabelMap& map, const Eigen::Vector3i& seed);

/// The organ under a finger: a picked surface point lies on the boundary between the organ and what
/// is in front of it, so its nearest voxel may be either. Samples the ray's first `depthMm` behind
/// `hitWorld` (RAS mm) along `rayDirection` every half of the smallest spacing; the label holding
/// most samples (the earliest on a tie) wins, and its first voxel on the ray is returned. nullopt
/// when no sample is labelled.
std::optional<Eigen::Vector3i> labelledVoxelBehind(const LabelMap& map, const Eigen::Vector3d& hitWorld, const Eigen::Vector3d& rayDirection,
                                                   double depthMm);

}  // namespace handson
