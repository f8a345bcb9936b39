#pragma once
// Assembly and the static solve of the fine corotational model (the accuracy reference).
#include <Eigen/Core>
#include <memory>
#include <vector>

#include "sim/fem.h"
#include "sim/progress.h"
#include "sim/sparse_direct.h"
#include "sim/tet_mesh.h"

namespace handson {

/// A sparse symmetric matrix over the free degrees of freedom of a tet mesh, assembled from 12x12
/// element blocks into a fixed pattern (lower triangle, what the Cholesky reads): built once,
/// refilled every iteration without re-sorting.
class BlockAssembler {
 public:
  /// `dof[n]`: first free dof of node n (3 consecutive), or -1 for a Dirichlet node.
  BlockAssembler(const std::vector<std::array<int, 4>>& tets, const std::vector<int>& dof, int dofCount);
  void zero();
  /// Adds element block Ke (12x12, corner-major) of tet t.
  void add(int t, const Mat12& Ke);
  SparseMatrix& matrix() { return A_; }

 private:
  SparseMatrix A_;
  const std::vector<std::array<int, 4>>& tets_;
  std::vector<int> dof_;
  std::vector<int> slot_;  // per tet, per (a,b) node pair with dof(a) >= dof(b), per column c: value index of row 0
};

struct StaticSolveOptions {
  /// Converged when the largest node update of an iteration is below tolerance x the largest
  /// prescribed displacement (1e-6: a millionth of the handle's motion).
  double tolerance = 1e-6;
  int maxIterations = 200;
  /// Projected Newton (the exact Hessian with each element's negative eigenvalues clamped): about
  /// quadratic convergence. Off: plain warped-stiffness iterations (linear convergence, slow at
  /// large rotations), kept for comparison.
  bool newton = true;
  ProgressFn progress;
};

struct StaticSolveResult {
  std::vector<Eigen::Vector3d> x;  ///< deformed node positions
  int iterations = 0, factorizations = 0;
  double lastUpdate = 0.0;         ///< largest node update of the last iteration (mm)
  bool converged = false;
  int invertedTets = 0;            ///< tets with det F <= 0 at the end
};

/// Static equilibrium of the corotational model: internal forces vanish at the free nodes; nodes with
/// fixed[n] != 0 are held at x0[n]. Each iteration solves H dx = f(x) with a positive definite H
/// (projected Newton, or the warped stiffness sum R K_e R^T) by sparse Cholesky, then backtracks on
/// the elastic energy along dx. Throws handson::Error if the system is singular (no Dirichlet nodes).
StaticSolveResult solveStatic(const TetMesh& mesh, const std::vector<Mat12>& K, const std::vector<char>& fixed,
                              const std::vector<Eigen::Vector3d>& x0, const StaticSolveOptions& options = {});

/// Sum of corotational element forces at every node (zero at the free nodes of an equilibrium).
std::vector<Eigen::Vector3d> internalForces(const TetMesh& mesh, const std::vector<Mat12>& K, const std::vector<Eigen::Vector3d>& x);

/// Total corotational elastic energy of the mesh at positions x.
double elasticEnergy(const TetMesh& mesh, const std::vector<Mat12>& K, const std::vector<Eigen::Vector3d>& x);

/// Tets with det F <= 0 at positions x.
int countInvertedTets(const TetMesh& mesh, const std::vector<Eigen::Vector3d>& x);

/// Per-tet stiffness for a mesh and per-tet materials.
std::vector<Mat12> tetStiffnesses(const TetMesh& mesh, const std::vector<double>& youngs, const std::vector<double>& poisson);

}  // namespace handson
