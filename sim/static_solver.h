#pragma once
// Assembly and the static solve of the fine corotational model (the accuracy reference).
#include <algorithm>
#include <Eigen/Core>
#include <memory>
#include <vector>

#include "sim/fem.h"
#include "sim/base/progress.h"
#include "sim/sliding_interface.h"
#include "sim/sparse_direct.h"
#include "sim/tet_mesh.h"

namespace handson {

/// A sparse symmetric matrix over the free degrees of freedom of a mesh, assembled from element
/// blocks (3n x 3n for n-node elements, node-major) into a fixed pattern (lower triangle, what the
/// Cholesky reads): built once, refilled every iteration without re-sorting.
class BlockAssembler {
 public:
  /// `dof[n]`: first free dof of node n (3 consecutive), or -1 for a Dirichlet node.
  BlockAssembler(const std::vector<std::array<int, 4>>& tets, const std::vector<int>& dof, int dofCount);
  /// Elements of `nodesPerElement` nodes each, listed back to back in `elementNodes`.
  BlockAssembler(std::vector<int> elementNodes, int nodesPerElement, const std::vector<int>& dof, int dofCount);
  void zero();
  /// Adds element block Ke (3n x 3n, node-major) of element e.
  template <class M>
  void add(int e, const M& Ke) {
    double* val = A_.valuePtr();
    const int n = n_;
    const int* nodes = &nodes_[std::size_t(e) * std::size_t(n)];
    const int* slot = &slot_[std::size_t(e) * std::size_t(3 * n * n)];
    for (int a = 0; a < n; ++a)
      for (int b = 0; b < n; ++b) {
        const int ra = dof_[std::size_t(nodes[a])], cb = dof_[std::size_t(nodes[b])];
        if (ra < 0 || cb < 0 || ra < cb) continue;
        for (int c = 0; c < 3; ++c) {
          int s = slot[(a * n + b) * 3 + c];
          // Rows ra..ra+2 of column cb+c are consecutive in the pattern (those below the diagonal).
          for (int r = 0; r < 3; ++r)
            if (ra + r >= cb + c) val[s++] += Ke(3 * a + r, 3 * b + c);
        }
      }
  }
  SparseMatrix& matrix() { return A_; }

 private:
  SparseMatrix A_;
  std::vector<int> nodes_;
  int n_ = 4;
  std::vector<int> dof_;
  std::vector<int> slot_;  // per element, per (a,b) node pair with dof(a) >= dof(b), per column c: value index of row 0
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
  /// Normal springs to prescribed planes (sliding interfaces, sim/sliding_interface.h), added to the
  /// elastic energy: their nodes must be free.
  std::vector<NormalSpring> springs;
  ProgressFn progress;
};

struct StaticSolveResult {
  std::vector<Eigen::Vector3d> x;  ///< deformed node positions
  int iterations = 0, factorizations = 0;
  double lastUpdate = 0.0;         ///< largest node update of the last iteration (mm)
  bool converged = false;
  int invertedTets = 0;            ///< tets with det F <= 0 at the end
};

/// The free degrees of freedom of a static solve: per node the first of its 3 dofs (-1 for a Dirichlet
/// node, fixed != 0), their count, and the largest prescribed motion (of the Dirichlet nodes from rest
/// and of the springs' anchors). Throws handson::Error (`solve` names it) for a non-finite position,
/// or a spring on a fixed node or outside the mesh.
struct FreeDofs {
  std::vector<int> dof;
  int count = 0;
  double motion = 0.0;
  /// The largest distance between a and b over the free nodes (a Newton step's update).
  double largestUpdate(const std::vector<Eigen::Vector3d>& a, const std::vector<Eigen::Vector3d>& b) const {
    double u = 0.0;
    for (std::size_t i = 0; i < dof.size(); ++i)
      if (dof[i] >= 0) u = std::max(u, (a[i] - b[i]).norm());
    return u;
  }
};
FreeDofs freeDofs(const TetMesh& mesh, const std::vector<char>& fixed, const std::vector<Eigen::Vector3d>& x0, const std::vector<NormalSpring>& springs,
                  const char* solve);

/// The assembler of a static solve over the tets, then one one-node element per spring (its block
/// k n n^T on the node's diagonal, added by addSpringBlocks).
BlockAssembler tetAndSpringAssembler(const TetMesh& mesh, const std::vector<NormalSpring>& springs, const FreeDofs& free);
void addSpringBlocks(BlockAssembler& assembler, const TetMesh& mesh, const std::vector<NormalSpring>& springs);

/// Static equilibrium of the corotational model (plus options.springs): forces vanish at the free nodes; nodes with
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
