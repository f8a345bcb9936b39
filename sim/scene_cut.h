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
};

/// Cuts the scene's fine mesh by each quad in turn. A copy of a node keeps its role: a handle's
/// node, a held one (the region's boundary, the anchored skeleton: a cut through bone leaves both
/// sides anchored) or a slide node, whose spring is shared among its copies. Throws handson::Error
/// (the scene unchanged) for a bad quad (cutMesh), and when the cuts leave a piece of tissue that
/// nothing holds (no handle's or held node: its position would be undetermined).
SceneCutStats cutScene(SimScene& scene, const std::vector<CutQuad>& cuts);

}  // namespace handson
