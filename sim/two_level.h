#pragma once
// The speed-accuracy knob: the coarse model as the coarse-grid correction of a two-level solver on
// the fine corotational model. Starting from the coarse reconstruction, each refinement step
// linearizes the fine model at the current positions, runs a few preconditioned conjugate-gradient
// iterations on H dx = f(x) (nothing assembled), then backtracks on the energy; the preconditioner
// is block Jacobi plus the coarse correction P A_c^-1 P^T, with P built from the same shape
// functions as the reconstruction. More iterations per frame (or more frames) converge to the fine
// static answer; none gives the coarse model.
//
// Three linearizations (RefineMethod; docs/simulation.md, "Refinement"):
//  - Analytic (the default): the exact corotational Hessian with its negative part removed in
//    closed form, matrix-free. Per tet it is the warped stiffness R K R^T plus the twist terms (the
//    rotation's variation), whose eigenvalues are known from the polar decomposition; negative ones
//    are clamped. Applied from each tet's shape-function gradients and Lame parameters (stress
//    times gradient: ~150 flops and 30 numbers a tet instead of a 12x12 block), rotations by the
//    warm-started polar iteration, passes split over threads.
//  - Warped: the warped stiffness alone, the same way (no twist terms).
//  - Projected (the baseline, kept to compare): the exact corotational Hessian of every tet with its
//    negative eigenvalues clamped (a 12x12 eigendecomposition per tet per step), stored per tet.
#include <Eigen/Geometry>
#include <vector>

#include "sim/coarsening.h"

namespace handson {

enum class RefineMethod { Analytic, Warped, Projected };
const char* refineMethodName(RefineMethod m);

/// A cut fine mesh for the refinement to solve on instead of the coarse model's own (cutScene,
/// docs/cutting.md): the same tets in the same order (the stiffness and materials per tet hold), on
/// nodes copied where the cut separates them, with their roles. Each node reaches the coarse
/// correction through the coarse model's fine node it copies (`sourceNode`): the coarse model does
/// not see the cut, the fine steps do, so the refinement converges to the cut fine answer.
struct RefineCut {
  const TetMesh* mesh = nullptr;
  const FineConstraints* constraints = nullptr;
  const std::vector<int>* sourceNode = nullptr;
};

/// Fine positions x on the coarse model's mesh carried to a cut mesh, to start refining from: each
/// node where x puts its source, and the cut mesh's Dirichlet nodes where their roles put them
/// (prescribedPositions: a copy of a slide node the cut left on the organ's own tets moves with the
/// organ, wherever x put its source). Throws handson::Error on sizes that do not match.
std::vector<Eigen::Vector3d> positionsOnCut(const RefineCut& cut, const std::vector<RigidTransform>& handles, const std::vector<Eigen::Vector3d>& x);

struct RefineOptions {
  RefineMethod method = RefineMethod::Analytic;
  int threads = 0;  ///< Analytic, Warped: threads for the element passes (0: the machine's hardware threads)
  RefineCut cut;    ///< a cut fine mesh to solve on (its pointees outlive the refiner); none: the coarse model's
};

class FineRefiner {
 public:
  /// The projected method only (no material data): `fineK`, the rest stiffness per fine tet.
  FineRefiner(const CoarseModel& coarse, const std::vector<Mat12>& fineK);
  /// Any method. `youngs` and `poisson` per fine tet are the isotropic material `fineK` was built
  /// from (tetStiffnesses); the matrix-free methods read only them. Throws handson::Error on wrong sizes.
  FineRefiner(const CoarseModel& coarse, const std::vector<Mat12>& fineK, const std::vector<double>& youngs, const std::vector<double>& poisson,
              const RefineOptions& options = {});
  ~FineRefiner();
  FineRefiner(const FineRefiner&) = delete;
  FineRefiner& operator=(const FineRefiner&) = delete;

  RefineMethod method() const { return options_.method; }

  /// The fine mesh the steps solve on: the coarse model's, or the cut one (RefineOptions::cut).
  const TetMesh& fineMesh() const { return *fine_; }
  /// One refinement step on fine positions x (Dirichlet nodes must already hold their values) with
  /// the handles at `handles` (their sliding interfaces' planes held exactly, not by the springs:
  /// the slide nodes put on them, the steps projected onto them - a stiff spring slowed the
  /// conjugate gradients several-fold): `iterations` PCG iterations, then
  /// x += dx. `xc` is the coarse state the coarse matrix was factorized at (the last
  /// CoarseModel::solve). Returns the residual reduction |r_k| / |r_0|.
  double step(const std::vector<RigidTransform>& handles, const std::vector<Eigen::Vector3d>& xc, std::vector<Eigen::Vector3d>& x, int iterations) const;

  /// Analytic, Warped: the product H(x) p over all nodes (Dirichlet ones included), rotations at x
  /// from a cold start; for tests against the stored 12x12 blocks and the exact Hessian.
  std::vector<Eigen::Vector3d> product(const std::vector<Eigen::Vector3d>& x, const std::vector<Eigen::Vector3d>& p) const;

 private:
  using Springs = std::vector<NormalSpring>;
  double stepProjected(const Springs& springs, const std::vector<Eigen::Vector3d>& xc, std::vector<Eigen::Vector3d>& x, int iterations) const;
  double stepWarped(const Springs& springs, const std::vector<Eigen::Vector3d>& xc, std::vector<Eigen::Vector3d>& x, int iterations) const;
  struct Warped;  // the matrix-free methods' per-tet data and buffers (sim/refine_warped.cpp)
  using Field = std::vector<Eigen::Vector3d>;
  void sumThreadBuffers(Field& out) const;
  double linearizeWarped(const Field& x, Field& r, std::vector<Eigen::Matrix3d>& diag) const;
  void applyWarped(const Field& p, Field& out) const;
  double warpedEnergy(const Field& pos) const;

  void solveOn(const TetMesh& fine, const FineConstraints& constraints);
  const CoarseModel& coarse_;
  const std::vector<Mat12>& K_;
  const TetMesh* fine_ = nullptr;                  ///< the mesh solved on
  const FineConstraints* constraints_ = nullptr;  ///< its roles
  std::vector<int> source_;                        ///< per node of fine_: the coarse model's fine node (empty: the same)
  std::vector<char> free_;
  RefineOptions options_;
  std::unique_ptr<Warped> warped_;
};

}  // namespace handson
