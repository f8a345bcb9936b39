#pragma once
// What region growing's CPU reference (interaction/region_grow.h) and its GPU pass
// (render/region_grow_pass.h) share: the criterion, the seed statistics that decide homogeneity,
// and the keys. Plain data, so neither library depends on the other.
#include <cstdint>
#include <string>

#include <Eigen/Core>

namespace handson {

/// Paper: the paper's rule; Smoothed: 3x3x3 means in a ball (the earlier default); Core (default):
/// Smoothed, but growth passes only through the organ's core (see interaction/region_grow.h).
enum class GrowCriterion : std::uint8_t { Paper, Smoothed, Core };
const char* growCriterionName(GrowCriterion c);
bool parseGrowCriterion(const std::string& s, GrowCriterion& out);

/// Key of a voxel never reached.
constexpr std::uint32_t kUnreached = 0xffffffffu;

/// What the GPU pass needs to reproduce the grower exactly.
struct GrowSetup {
  Eigen::Vector3i seed{0, 0, 0};
  GrowCriterion criterion = GrowCriterion::Smoothed;
  float seedValue = 0;   ///< u16 units: the seed's own value (paper) or its 3x3x3 sum (smoothed)
  float tolerance = 0;   ///< accept |value - seedValue| < tolerance (same units)
  float coreTolerance = 0;  ///< Core: a voxel passes growth on only if |value - seedValue| < this too
  Eigen::Vector3f spacing{1, 1, 1};
};

/// Key bound for an extent in mm: steps (paper) or the bits of the float d^2 (smoothed), which
/// order like the floats for non-negative values.
std::uint32_t growKeyBound(GrowCriterion c, double extentMm, const Eigen::Vector3d& spacing);
/// How far from the seed (voxels, per axis) a selection of this extent can reach: the ball's
/// radius (smoothed, core), or the steps along any axis (paper: extent / the smallest spacing).
Eigen::Vector3i growReach(GrowCriterion c, double extentMm, const Eigen::Vector3d& spacing);
/// Squared distance from the seed in mm^2, computed in float exactly as the shader does.
float growDistance2(const Eigen::Vector3i& voxel, const Eigen::Vector3i& seed, const Eigen::Vector3f& spacing);

}  // namespace handson
