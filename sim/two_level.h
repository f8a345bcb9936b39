#pragma once
// The speed-accuracy knob: the coarse model as the coarse-grid correction of a two-level solver on
// the fine corotational model. Starting from the coarse reconstruction, each refinement step
// linearizes the fine model at the current positions (the element Hessians, projected to positive
// semi-definite, applied element by element, nothing assembled) and runs a few preconditioned
// conjugate-gradient iterations on H dx = f(x), then backtracks on the energy; the preconditioner is block Jacobi plus the coarse correction P A_c^-1 P^T, with P
// built from the same shape functions as the reconstruction. More iterations per frame (or more
// frames) converge to the fine static answer; none gives the coarse model.
#include <vector>

#include "sim/coarsening.h"

namespace handson {

class FineRefiner {
 public:
  FineRefiner(const CoarseModel& coarse, const std::vector<Mat12>& fineK);

  /// One refinement step on fine positions x (Dirichlet nodes must already hold their values):
  /// `iterations` PCG iterations, then x += dx. `xc` is the coarse state the coarse matrix was
  /// factorized at (the last CoarseModel::solve). Returns the residual reduction |r_k| / |r_0|.
  double step(const std::vector<Eigen::Vector3d>& xc, std::vector<Eigen::Vector3d>& x, int iterations) const;

 private:
  const CoarseModel& coarse_;
  const std::vector<Mat12>& K_;
  std::vector<char> free_;
};

}  // namespace handson
