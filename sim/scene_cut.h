#pragma once
// Cuts applied to a scene's fine mesh (docs/cutting.md): the mesh cut (sim/tissue_cut.h) and the
// fine nodes' roles carried to their copies, so the fine reference (solveFineStatic) sees the cut.
// The coarse model does not yet: a cut scene is for the fine reference alone.
#include <cstddef>
#include <vector>

#include "sim/sim_scene.h"
#include "sim/tissue_cut.h"

namespace handson {

struct SceneCutStats {
  std::size_t cutFaces = 0, copiedNodes = 0;
  std::vector<int> sourceNode;  ///< per node of the cut fine mesh: the scene's node it copies (itself if none)
};

/// Cuts the scene's fine mesh by each quad in turn. A copy of a node keeps its role as its side
/// gives it (docs/cutting.md): a held node stays held (the region's boundary, the anchored
/// skeleton: a cut through bone leaves both sides anchored); a handle's node stays the handle's
/// where the handle's own tets are, and is free where the cut took it off them; a slide node keeps
/// its spring (its stiffness from its own tets) where it has both the organ's and the tissue's
/// tets, moves with the organ where it has the organ's alone, and is free where it has the tissue's
/// alone. A piece of tissue the cuts leave not held at three points off one line (its position would
/// be undetermined) but touching one organ's sliding interface adheres to that organ (its nodes
/// become the handle's, their springs go: a sliver cut off between an incision and the organ).
/// Throws handson::Error (the scene unchanged) for a bad quad (cutMesh), and for a loose piece that
/// touches no organ or several.
SceneCutStats cutScene(SimScene& scene, const std::vector<CutQuad>& cuts);

}  // namespace handson
