#pragma once
// A synthetic scene for stability sweeps (docs/simulation-outputs.md, "Stability") and their tests: a
// 60 x 40 x 40 mm box of 3 kPa tissue (nu 0.45) with fixed outer faces, a slab y in (24, 30) mm
// `contrast` times stiffer, and ball-shaped rigid handles.
#include <functional>
#include <vector>

#include "sim/coarsening.h"
#include "sim/static_solver.h"
#include "sim/tet_mesh.h"

namespace handson {

struct BoxScene {
  NestedMeshes meshes;
  std::vector<double> E, nu;
  std::vector<Mat12> K;
  FineConstraints c;
  /// 480 coarse tets, 27 fine per coarse (12,960 fine tets).
  explicit BoxScene(double contrast = 1.0);
  /// Fine nodes within r of ctr become handle `handle` (later balls win).
  void ball(const Eigen::Vector3d& ctr, double r, int handle);
};

/// The coarse (warm-started, `increments` steps) and fine (projected Newton per increment) answers
/// of a motion `at(fraction)`, with what went wrong.
struct StabilityOutcome {
  bool coarseFinite = false, coarseConverged = false, fineFinite = false, fineConverged = false;
  int coarseInverted = 0, fineInverted = 0;  ///< fine tets with det F <= 0
  std::vector<int> coarseInvertedAt, fineInvertedAt;  ///< the same after each increment (while finite)
  int coarseIterations = 0, fineIterations = 0;
  std::vector<Eigen::Vector3d> coarse, fine;  ///< fine node positions of each model
};
StabilityOutcome solveBoxMotion(const BoxScene& s, const std::function<std::vector<RigidTransform>(double)>& at, int increments,
                                CoarseElement element = CoarseElement::Cell);

}  // namespace handson
