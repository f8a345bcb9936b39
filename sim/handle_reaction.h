#pragma once
// What the tissue does to a handle: the resultant force and torque of the elastic forces on its
// nodes (docs/simulation-outputs.md, "Reaction force and torque").
//
// Units: positions in the image's millimetres and moduli in pascals make K u pascal-square
// millimetres (1e-6 N); forces are reported in newtons and torques in newton-millimetres, about the
// handle's current centroid (the centroid of its fine nodes at rest, moved by the handle's
// transform). Sign: the force the tissue exerts on the handle (it pulls a stretched handle back).
#include <Eigen/Core>
#include <string>
#include <vector>

#include "sim/coarsening.h"
#include "sim/neo_hookean.h"

namespace handson {

struct HandleReaction {
  Eigen::Vector3d forceN = Eigen::Vector3d::Zero();
  Eigen::Vector3d torqueNmm = Eigen::Vector3d::Zero();  ///< about centreMm
  Eigen::Vector3d centreMm = Eigen::Vector3d::Zero();   ///< the handle's current centroid (world mm)
};

/// "tissue force 0.42 N, torque 3.1 N mm" for status lines; a coarse model's reaction is marked
/// approximate (docs/simulation-outputs.md: 1.2-2x the fine model's on the kidneys measured).
std::string formatReaction(const HandleReaction& r, bool coarse = false);

/// The rest centroid of each handle's fine nodes (fixed nodes left out).
std::vector<Eigen::Vector3d> handleRestCentroids(const TetMesh& fine, const FineConstraints& constraints);

/// The reactions on the fine mesh at positions x: per handle, the sum of the corotational elastic
/// forces of the fine tets on its nodes (and their moments); with `hyperelastic` (one per fine tet),
/// the Neo-Hookean forces instead. Throws handson::Error on a size mismatch.
std::vector<HandleReaction> fineHandleReactions(const TetMesh& fine, const std::vector<Mat12>& fineK, const FineConstraints& constraints,
                                                const std::vector<RigidTransform>& handles, const std::vector<Eigen::Vector3d>& x,
                                                const std::vector<NeoHookeanTet>* hyperelastic = nullptr);

}  // namespace handson
