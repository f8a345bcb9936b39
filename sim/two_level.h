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

struct RefineOptions {
  RefineMethod method = RefineMethod::Analytic;
  int threads = 0;  ///< Analytic, Warped: threads for the element passes (0: the machine's hardware threads)
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

  const CoarseModel& coarse_;
  const std::vector<Mat12>& K_;
  std::vector<char> free_;
  RefineOptions options_;
  std::unique_ptr<Warped> warped_;
};

}  // namespace handson
