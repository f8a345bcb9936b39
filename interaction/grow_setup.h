#pragma once
// What region growing's CPU reference (interaction/region_grow.h) and its GPU pass
// (render/region_grow_pass.h) share: the criterion, the seed statistics that decide homogeneity,
// and the keys. Plain data, kept with region growing (render/ includes interaction/ for it, never the reverse).
#include <array>
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

/// How the fingers' extent d bounds the smoothed and core criteria (the paper criterion counts steps):
///  - Ball: the selection is the homogeneous region joined to the seed inside the ball of radius d;
///    a voxel's key is the smallest radius (squared) of a ball within which a path joins it to the seed.
///  - Path: a voxel's key is the length of its shortest path from the seed through the region, and
///    the selection for d is every voxel within d of path (a geodesic ball). A path steps to any of
///    the 26 neighbours, a step as long as the straight line between the voxels' centres, but a
///    step across an edge or a corner only where a path of face steps through voxels that pass
///    growth on joins the two as well: the region's 6-connectivity is the ball's, only its lengths
///    are closer to Euclidean (the 26-neighbour chamfer distance: within 8 % of the straight line in
///    uniform tissue). A region joined to the organ only by a detour - a neighbour reached through a
///    vein or a neck - waits until the fingers spread as far as the detour is long.
enum class GrowBound : std::uint8_t { Ball, Path };
const char* growBoundName(GrowBound b);
bool parseGrowBound(const std::string& s, GrowBound& out);
/// Path keys count 1/256 mm: a key of 2^32 is 16,777 m of path, and a step of a 0.5 mm grid is 128.
constexpr double kPathUnitsPerMm = 256.0;
/// Path step lengths in path units, indexed by the step's axes as a bit mask (bit a: the step
/// moves along axis a; index 0 unused): the straight line's length rounded to the nearest unit, at
/// least 1. Computed once here (in double) and handed to the GPU pass, so both add the same integers.
std::array<std::uint32_t, 8> growStepCosts(const Eigen::Vector3f& spacingMm);

/// What the GPU pass needs to reproduce the grower exactly.
struct GrowSetup {
  Eigen::Vector3i seed{0, 0, 0};
  GrowCriterion criterion = GrowCriterion::Smoothed;
  float seedValue = 0;   ///< u16 units: the seed's own value (paper) or its 3x3x3 sum (smoothed)
  float tolerance = 0;   ///< accept |value - seedValue| < tolerance (same units)
  float coreTolerance = 0;  ///< Core: a voxel passes growth on only if |value - seedValue| < this too
  Eigen::Vector3f spacing{1, 1, 1};
  GrowBound bound = GrowBound::Ball;  ///< smoothed and core: the keys' kind (paper: steps)
};

/// Key bound for an extent in mm: steps (paper), the bits of the float d^2 (Ball), which order like
/// the floats for non-negative values, or the path length d in path units (Path).
std::uint32_t growKeyBound(GrowCriterion c, GrowBound b, double extentMm, const Eigen::Vector3d& spacing);
/// How far from the seed (voxels, per axis) a selection of this extent can reach: the ball's
/// radius (Ball), the whole axis steps within the bound (Path: every step that moves along an axis
/// costs at least that axis's step), or the steps along any axis (paper: extent / the smallest spacing).
Eigen::Vector3i growReach(GrowCriterion c, GrowBound b, double extentMm, const Eigen::Vector3d& spacing);
/// Squared distance from the seed in mm^2, computed in float exactly as the shader does.
float growDistance2(const Eigen::Vector3i& voxel, const Eigen::Vector3i& seed, const Eigen::Vector3f& spacing);

}  // namespace handson
