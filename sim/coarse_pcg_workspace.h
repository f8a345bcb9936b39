#pragma once
// The matrix-free coarse solve's state (sim/coarse_pcg.cpp), private to CoarseModel.
#include <Eigen/Geometry>
#include "sim/sparse_direct.h"
#include <vector>

#include "sim/anderson.h"
#include "sim/coarsening.h"

namespace handson {

struct CoarseModel::PcgWorkspace {
  bool ready = false;
  std::vector<float> khf;                        ///< per element, K_h in single precision (3n x 3n, column-major), back to back: the CG products
  std::vector<Eigen::Matrix3d> elementR;         ///< R_e at the current iterate
  std::vector<char> hangs;                       ///< per element: a corner is a hanging node (graded)
  std::vector<int> active;                       ///< the elements with a free corner: the only ones a frame visits
  std::vector<Eigen::Quaterniond> elementQ;      ///< R_e as the polar iteration's warm start
  std::vector<int> freeNode;                     ///< coarse node of free node i (dof 3i)
  std::vector<int> adjStart, adjElement;         ///< free node i's elements: adjElement[adjStart[i] .. adjStart[i+1])
  std::vector<Eigen::Matrix3d> nodeR;            ///< Rn per free node, relative to refQ
  std::vector<Eigen::Quaterniond> refQ;          ///< the reference rotations the factor was taken at (rest: identity)
  double drift = 0;                              ///< the largest angle of an active element's R_e from its refQ (rad)
  /// Cholesky factor of A(refQ) (first A_0, the rest stiffness; the pattern analysed once): CHOLMOD's
  /// supernodal solve (sim/sparse_direct.h), measured 0.23 ms a back-solve against 0.35 ms with
  /// Eigen's simplicial factor (2,022 dofs, nnz(L) 278k).
  DirectSolver rest;
  Eigen::VectorXd r, d, res, z, p, q, tmp;
  Eigen::VectorXd rLast, pLast;  ///< the last iteration's residual and direction (one CG step an iteration)
  double rzLast = 0;
  AndersonAcceleration anderson{0};  ///< PcgOptions::andersonDepth; its pairs span a drag's calls
  PcgOptions options{2, 10.0, 3, 0};  ///< those the accelerator's pairs were taken with
  Eigen::VectorXd xFree;             ///< the free dofs' positions (Anderson's iterate)
  std::vector<Eigen::Vector3d> bestX;  ///< the call's iterate with the smallest plain update (a stall goes back to it)
};

}  // namespace handson
