#pragma once
// Sliding interfaces between a handle and the tissue around it (docs/tissue-physics.md, "Organs
// slide"): frictionless and bilateral, in the small-sliding form.
//
// A handle's *slide nodes* are the fine nodes it selected that share a tet with a node it did not:
// its surface against the tissue. Under a sliding interface they are free nodes of the tissue, each
// held to the handle's surface in the normal direction only, by a stiff normal spring: with n the
// handle's outward normal at the node's rest position X (unit, rest frame) and T = (R, t) the
// handle's pose,
//   E_i = k_i / 2 (n_i' . (x_i - a_i))^2,   n_i' = R n_i,   a_i = T(X_i),
// so the node moves freely in the plane through a_i normal to n_i' (tangential motion free, no
// friction) and the normal gap n_i' . (x_i - a_i) is of order f_n / k_i either way (organs neither
// pull apart nor interpenetrate). k_i is kSlidePenalty times the node's own tissue stiffness (the
// trace of its 3x3 diagonal block over 3), so the gap is about 1/kSlidePenalty of the tissue's own
// displacement differences there. The tangent plane moves with the handle (small sliding): a node
// slid a distance s over a surface of radius of curvature r ends about s^2 / (2 r) off it.
//
// The handle's own tets (all four nodes selected by it) move rigidly with it: they carry no
// stiffness (their Young's modulus is 0), so the slide nodes feel only the tissue and their springs.
#include <Eigen/Core>
#include <cstdint>
#include <vector>

#include "sim/rigid_transform.h"
#include "sim/tet_mesh.h"
#include "sim/volume.h"

namespace handson {

/// The spring stiffness over the node's own tissue stiffness (see above): gaps of ~0.1 % of the
/// tissue's displacement differences, while the coarse model's iterations still converge.
constexpr double kSlidePenalty = 100.0;

/// A fine node on a handle's sliding interface.
struct SlideNode {
  int node = -1;                                     ///< fine node
  int handle = -1;                                   ///< 0-based handle index
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();  ///< the handle's outward unit normal at rest
  double stiffness = 0.0;                            ///< k_i (the fine stiffness's units per mm)
};

/// A spring that holds node `node` to the plane through `anchor` normal to `normal` (unit, world):
/// energy k/2 (normal . (x - anchor))^2.
struct NormalSpring {
  int node = -1;
  double stiffness = 0.0;
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ(), anchor = Eigen::Vector3d::Zero();
};

/// Per handle (handleCount of them), whether it slides: whether any slide node is its.
std::vector<char> slidingHandles(const std::vector<SlideNode>& slide, std::size_t handleCount);

/// The slide nodes' springs at the handles' poses (world frame). Throws handson::Error when a slide
/// node names a handle `handles` does not have.
std::vector<NormalSpring> slideSprings(const TetMesh& fine, const std::vector<SlideNode>& slide, const std::vector<RigidTransform>& handles);

/// f_i -= k n (n . (x_i - a)) for every spring (the springs' forces on the nodes, added to f).
void addSpringForces(const std::vector<NormalSpring>& springs, const std::vector<Eigen::Vector3d>& x, std::vector<Eigen::Vector3d>& f);
/// sum k/2 (n . (x_i - a))^2.
double springEnergy(const std::vector<NormalSpring>& springs, const std::vector<Eigen::Vector3d>& x);
/// The springs' planes held exactly instead (the refinement, sim/two_level.h): each spring's node put
/// on its plane, x_i -= n (n . (x_i - a)); and a field's normal parts removed, v_i -= n (n . v_i), so
/// that steps along it keep the nodes there.
void projectOntoSpringPlanes(const std::vector<NormalSpring>& springs, std::vector<Eigen::Vector3d>& x);
void removeNormalParts(const std::vector<NormalSpring>& springs, std::vector<Eigen::Vector3d>& v);

/// Tissue a handle encloses (unselected nodes that no path of tissue tets joins to a held node: a
/// cavity of the organ, the renal sinus inside a kidney's label) moves with the handle around it:
/// sliding all round, it would float, held by normal springs alone (a singular system where the
/// cavity is round). Claims each such node for the handle of a selected node it shares a tet with
/// (flood fill from the held nodes over the tets; `claimed` updated). Returns how many it claimed.
std::size_t claimEnclosedTissue(const TetMesh& fine, std::vector<int>& claimed, const std::vector<char>& fixed);

/// The fine nodes of `claimed` handle h (per node: the handle that selected it, or -1) that share a
/// tet with a node it did not select, and the tets all of whose nodes it selected (its own).
struct InterfaceNodes {
  std::vector<int> slideNodes;    ///< ascending
  std::vector<int> slideHandle;   ///< per slide node
  std::vector<char> handleTet;    ///< per fine tet: all four nodes selected by one handle
};
InterfaceNodes findInterfaceNodes(const TetMesh& fine, const std::vector<int>& claimed, const std::vector<char>& fixed);

/// A handle's voxels as a mask over their index box grown by one voxel (what maskNormal reads).
struct HandleMask {
  Eigen::Vector3i lo = Eigen::Vector3i::Zero(), dims = Eigen::Vector3i::Zero();
  std::vector<std::uint8_t> inside;  ///< per voxel of the box, x fastest
  std::vector<float> depthMm;        ///< per voxel of the box: distance (mm) to the nearest voxel outside the mask, 0 outside
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();  ///< world centroid of the voxels
  bool contains(const Eigen::Vector3i& v) const;
  /// The depth of p's nearest voxel below the mask's surface (mm; 0 outside the mask).
  double depthAt(const VolumeGeometry& grid, const Eigen::Vector3d& p) const;
};
/// Throws handson::Error for an empty list or a voxel outside `grid`.
HandleMask handleMask(const VolumeGeometry& grid, const std::vector<std::uint32_t>& voxels);

/// The outward unit normal of a handle's mask at a point p (world mm): the direction from the
/// centroid of the mask's voxel centres within rho = `radiusMm` + p's depth below the surface of p
/// to p (for a flat face exactly its normal at any depth: the neighbourhood always reaches `radiusMm`
/// past the surface; on a sphere of radius a, exactly radial). Falls back to the direction from the
/// mask's centroid when the neighbourhood's centroid is p itself; always a unit vector.
Eigen::Vector3d maskNormal(const VolumeGeometry& grid, const HandleMask& mask, const Eigen::Vector3d& p, double radiusMm);

}  // namespace handson
