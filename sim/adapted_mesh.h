#pragma once
// An image-adapted fine mesh (docs/simulation-model.md, the image-adapted fine mesh): the
// coarse grid and the regular fine lattice as in buildNestedMeshes, but each coarse cell is meshed by
// TetGen (sim/tetgen_mesher.h) from
//   - its six faces, triangulated exactly as the regular fine mesh triangulates them (m x m squares,
//     each split along its Kuhn diagonal), kept unsplit, so neighbouring cells conform and the coarse
//     elements' faces are the regular ones;
//   - the regular interior lattice points (spacing h / m);
//   - extra points where the image has structure that matters to the mechanics: points of the
//     half-spacing lattice (h / 2m) whose Young's modulus differs by `contrast` or more from one of
//     their six half-spacing neighbours' (bone surfaces, vessel walls; not the noise between fat and
//     soft tissue, 3 against 6 kPa), so fine tets follow those boundaries and nothing is added elsewhere.
// A cell TetGen cannot mesh keeps its regular Kuhn tets (counted). Fine tets lie in one coarse cell,
// not necessarily one coarse tet: the coarse model needs cell elements on this mesh.
#include <functional>

#include "sim/base/progress.h"
#include "sim/tet_mesh.h"

namespace handson {

struct AdaptedMeshStats {
  std::size_t structurePoints = 0;  ///< points added at material boundaries
  std::size_t fallbackCells = 0;    ///< cells left with their regular tets (TetGen refused them)
  std::string firstFailure;         ///< TetGen's reason for the first such cell
};

/// What to mesh: the box, its coarse and fine resolutions and the image's stiffness.
struct AdaptedMeshSpec {
  Eigen::Vector3d lo{0, 0, 0}, hi{0, 0, 0};
  int coarseTets = 0, finePerCoarse = 0;  ///< as buildNestedMeshes
  std::function<double(const Eigen::Vector3d&)> youngsAt;  ///< Young's modulus at world point p (> 0)
  double contrast = 10.0;  ///< a jump of this factor or more between half-spacing neighbours adds a point
};

NestedMeshes buildImageAdaptedMeshes(const AdaptedMeshSpec& spec, const ProgressFn& progress = {}, AdaptedMeshStats* stats = nullptr);

}  // namespace handson
