#pragma once
// The tissue at a point of the image, with bone told from contrast-enhanced soft tissue
// (docs/tissue-physics.md, "Bone and the skeleton").
//
// A CT's values cannot tell spongy bone (150-700 HU) from contrast-enhanced blood and organs (a
// venous-phase kidney is ~200 HU, an aorta ~180 HU), but anatomy can: spongy bone lies inside compact
// bone's shell. The material table's skeleton column (SkeletonRole) names the bands: a "yes" band's
// voxels are the skeleton wherever they are (compact bone); a "joined" band's voxels are the skeleton
// where a path through skeleton-band voxels (6-neighbour steps, their lengths in mm) of at most
// `reachMm` joins them to a "yes" voxel, and elsewhere take the material of the band below (the band
// of next lower values). The skeleton is anchored: the simulation holds its nodes at rest unless a
// handle holds them (sim/sim_scene.h).
#include <Eigen/Core>
#include <cstdint>
#include <vector>

#include "sim/materials.h"
#include "sim/volume.h"

namespace handson {

class TissueMap {
 public:
  /// The skeleton inside the world box [lo, hi] grown by reachMm (clipped to the image); `table` is
  /// resolved (image units). `useSkeleton` false: bands by value alone and no skeleton (the earlier
  /// rule, kept as an option). Throws handson::Error for a negative or non-finite reach.
  TissueMap(const Volume& image, const MaterialTable& table, const Eigen::Vector3d& lo, const Eigen::Vector3d& hi, double reachMm, bool useSkeleton = true);

  /// The material band at world point p: the image's trilinear value classified, a "joined" band off
  /// the skeleton taking the band below.
  int bandAt(const Eigen::Vector3d& p) const;
  /// The voxel nearest to world point p is skeleton (false outside the computed box).
  bool skeletonAt(const Eigen::Vector3d& p) const;
  std::size_t skeletonVoxelCount() const { return skeletonVoxels_; }
  const MaterialTable& table() const { return table_; }

 private:
  /// Linear index into the computed box of the voxel nearest p, or -1 outside it.
  long long boxIndex(const Eigen::Vector3d& p) const;
  void grow(double reachMm);

  const Volume& image_;
  const MaterialTable& table_;
  Eigen::Matrix4d toIndex_;
  Eigen::Vector3i boxLo_{0, 0, 0}, boxDims_{0, 0, 0};
  std::vector<std::uint8_t> skeleton_;  ///< per voxel of the box: 1 skeleton
  std::size_t skeletonVoxels_ = 0;
  bool useSkeleton_ = true;
};

}  // namespace handson
