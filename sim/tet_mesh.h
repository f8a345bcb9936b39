#pragma once
// Tetrahedral meshes for the simulation (docs/simulation-model.md).
//
// KuhnGrid: a box of equal cells, each split into the six tetrahedra of the Kuhn (Freudenthal)
// triangulation, x_s0 >= x_s1 >= x_s2 in the cell's unit coordinates for each permutation s of the
// axes. All cells split the same way, so faces match between neighbours. The triangulation is the
// arrangement of the planes x_i = n and x_i - x_j = n (n integer, unit = one cell); a grid whose cells
// are 1/m of another's contains all of the coarser grid's planes, so each of its tetrahedra lies inside
// exactly one coarse tetrahedron (m^3 of them per coarse tet) and the coarse nodes are fine nodes.
// That nesting is what the coarsening needs (fine mesh conforming to the coarse elements).
#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <vector>

namespace handson {

struct TetMesh {
  std::vector<Eigen::Vector3d> nodes;   ///< rest positions (mm, world)
  std::vector<std::array<int, 4>> tets; ///< node indices (either orientation)

  /// Signed volume of a tet (positive when (x1-x0, x2-x0, x3-x0) is right-handed).
  double signedVolume(int t) const;
};

class KuhnGrid {
 public:
  KuhnGrid() = default;
  /// `cells` cells of size `cell` (mm) from `origin`. Throws handson::Error on an empty or absurd grid.
  KuhnGrid(const Eigen::Vector3d& origin, const Eigen::Vector3d& cell, const Eigen::Vector3i& cells);

  /// The same box with every cell split into m^3 cells.
  KuhnGrid refined(int m) const;

  const Eigen::Vector3d& origin() const { return origin_; }
  const Eigen::Vector3d& cell() const { return cell_; }
  const Eigen::Vector3i& cells() const { return cells_; }
  Eigen::Vector3i nodeDims() const { return cells_ + Eigen::Vector3i::Ones(); }
  std::size_t nodeCount() const;
  std::size_t tetCount() const { return std::size_t(cells_.prod()) * 6; }
  int nodeIndex(int i, int j, int k) const { return i + (cells_.x() + 1) * (j + (cells_.y() + 1) * k); }
  Eigen::Vector3i nodeCoords(int n) const;
  Eigen::Vector3d nodePosition(int n) const;

  TetMesh mesh() const;
  /// Cells in mesh() order: cell c holds tets 6c..6c+5.
  std::size_t cellCount() const { return std::size_t(cells_.prod()); }
  /// The 8 nodes of cell c: corner q is at +x if q & 1, +y if q & 2, +z if q & 4.
  std::array<int, 8> cellNodes(int c) const;
  /// The Kuhn (piecewise linear) interpolation weights of cell c's 8 corners at p (p clamped into the
  /// cell); on the cell's faces they depend only on that face's corners, so neighbours agree.
  /// `onBoundary`: p lies on a face of the cell (within 1e-9 of a cell).
  Eigen::Matrix<double, 8, 1> cellWeights(int c, const Eigen::Vector3d& p, bool* onBoundary = nullptr) const;
  /// The tet containing p and its barycentric coordinates (vertex order of mesh()); -1 outside the
  /// box. Points on shared faces go to one tet by a fixed rule (ties broken by axis order).
  int locate(const Eigen::Vector3d& p, Eigen::Vector4d* bary = nullptr) const;

 private:
  Eigen::Vector3d origin_{0, 0, 0}, cell_{1, 1, 1};
  Eigen::Vector3i cells_{0, 0, 0};
};

/// Coarse and fine meshes of one box, the fine one nested in the coarse one.
struct NestedMeshes {
  KuhnGrid coarseGrid, fineGrid;
  int refinement = 1;                  ///< fine cells per coarse cell edge (m)
  TetMesh coarse, fine;
  std::vector<int> fineParent;         ///< coarse tet containing each fine tet (its centroid)
  std::vector<int> coarseNodeInFine;   ///< fine node index of each coarse node
  /// The fine mesh is fineGrid's Kuhn mesh: every fine tet lies in one coarse tet. Otherwise (an
  /// image-adapted fine mesh, sim/adapted_mesh.h) every fine tet lies in one coarse grid cell, the
  /// cells' faces triangulated as in the regular mesh, and cellTetStart/cellTets list each cell's
  /// fine tets.
  bool regularFine = true;
  std::vector<int> cellTetStart, cellTets;
  /// A cut fine mesh (sim/scene_cut.h): per fine node, the node of the uncut mesh it copies (itself
  /// where it is no copy); empty while the mesh was never cut. The coarse model splits the cells a
  /// cut separates by it (CoarseModel, docs/cutting.md "The coarse model sees the cut").
  std::vector<int> cutSource;

  /// The fine tet containing p (within 1e-9 of the cell size), -1 outside the box.
  int locateFine(const Eigen::Vector3d& p) const;
};

/// The grid of cubic-ish cells over [lo, hi] with about `coarseTets` Kuhn tets (6 a cell).
KuhnGrid coarseGridFor(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi, int coarseTets);

/// A box [lo, hi] meshed with about `coarseTets` coarse tets (cubic cells) and each coarse tet split
/// into m^3 fine tets, m = the cube root of finePerCoarse rounded (>= 1).
NestedMeshes buildNestedMeshes(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi, int coarseTets, int finePerCoarse);

}  // namespace handson
