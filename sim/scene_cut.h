#pragma once
// Cuts applied to a scene's fine mesh (docs/cutting.md): the mesh cut (sim/tissue_cut.h) and the
// fine nodes' roles carried to their copies, so the fine reference (solveFineStatic) sees the cut,
// and each node's source recorded (NestedMeshes::cutSource), so a coarse model built on the cut
// scene splits the cells the cut crosses (sim/coarse_cut.cpp).
#include <cstddef>
#include <vector>

#include "sim/sim_scene.h"
#include "sim/tissue_cut.h"

namespace handson {

struct SceneCutStats {
  std::size_t cutFaces = 0, copiedNodes = 0;
  std::vector<int> sourceNode;  ///< per node of the cut fine mesh: the scene's node it copies (itself if none)
};

/// Cuts the scene's fine mesh along the quads at once (cutMeshAlong: crossing cuts and the joints of
/// a polyline of quads alike). A copy of a node keeps its role as its side
/// gives it (docs/cutting.md): a held node stays held (the region's boundary, the anchored
/// skeleton: a cut through bone leaves both sides anchored); a handle's node stays the handle's
/// where the handle's own tets are, and is free where the cut took it off them; a slide node keeps
/// its spring (its stiffness from its own tets) where it has both the organ's and the tissue's
/// tets, moves with the organ where it has the organ's alone, and is free where it has the tissue's
/// alone. A piece of tissue the cuts leave not held at three points off one line (its position would
/// be undetermined) but touching one organ's sliding interface adheres to that organ (its nodes
/// become the handle's, their springs go: a sliver cut off between an incision and the organ).
/// Throws handson::Error (the scene unchanged) for a bad quad (cutMesh), a quad that separates no
/// face the others do not, and for a loose piece that touches no organ or several.
SceneCutStats cutScene(SimScene& scene, const std::vector<CutQuad>& cuts);

/// A retractor on a cut's lip: the tissue on one side of a cut, beside it, held as a handle so it
/// can be pulled away and open the incision.
struct CutLip {
  CutQuad quad;           ///< the cut (cutScene applied it)
  int side = 1;           ///< +1: the side the quad's normal (CutPlane::n) points to; -1: the other
  double widthMm = 10.0;  ///< how far from the cut's plane the lip reaches
};

/// Adds the lip as a handle (its index: the scene's handle count before; handleCentroid and
/// handleNodeCount grow with it): the free nodes of the stiff tets on that side whose centroid lies
/// within widthMm of the quad's plane and over the quad. Held nodes and other handles' stay theirs;
/// a slide node taken loses its spring. Throws handson::Error (the scene unchanged) for a side other
/// than +1 / -1, a width not above 0, or a lip with no free node.
int addLipHandle(SimScene& scene, const CutLip& lip);

/// The lip of the cut on the side away from `organ` (a point: the organ's centroid), `widthMm` wide.
CutLip lipAwayFrom(const CutQuad& quad, const Eigen::Vector3d& organ, double widthMm);

}  // namespace handson
