#pragma once
// Cutting the fine mesh along a planar quadrilateral (docs/cutting.md): the mesh separates along
// the faces between tets on either side of the quad's plane whose centroids project inside the
// quad, so the tissue on either side moves on its own. Each node of a cut face is copied once per
// group of its tets that stay joined around it through uncut faces (the tets keep their order and
// rest shape); a node at the cut's edge, whose tets are still joined around the cut's end, stays
// one. Cutting again (through an earlier cut, or across it) works the same way: faces an earlier cut
// separated are no longer shared.
#include <Eigen/Core>
#include <array>
#include <cstddef>
#include <vector>

#include "sim/tet_mesh.h"

namespace handson {

/// A planar convex quadrilateral, its corners in order around it (RAS mm).
struct CutQuad {
  std::array<Eigen::Vector3d, 4> corners;
};

/// The quad's plane: centre c, unit normal n (Newell's of the corners in order, so either winding
/// works), in-plane axes u, v, and the corners in the plane's coordinates (u, v) with their
/// winding's sign; `size` its longer diagonal.
struct CutPlane {
  Eigen::Vector3d c, n, u, v;
  std::array<Eigen::Vector2d, 4> q;
  double winding = 1.0;
  double size = 0.0;
  Eigen::Vector2d in(const Eigen::Vector3d& p) const { return {(p - c).dot(u), (p - c).dot(v)}; }
  /// The signed distance of p from the plane, along n.
  double height(const Eigen::Vector3d& p) const { return (p - c).dot(n); }
  /// Whether p projects inside the quad.
  bool contains(const Eigen::Vector3d& p) const;
};

/// The quad's plane. Throws handson::Error unless the quad is finite, of non-zero area, planar
/// (each corner within 1e-3 of its longer diagonal from the corners' best plane) and convex.
CutPlane cutPlane(const CutQuad& quad);
/// Throws as cutPlane.
void checkCutQuad(const CutQuad& quad);

struct MeshCut {
  TetMesh mesh;                 ///< the same tets in the same order, on copied nodes where the cut separates them
  std::vector<int> sourceNode;  ///< per node of `mesh`: the input node it copies (an input node is its own)
  std::size_t cutFaces = 0;     ///< faces separated by this cut
  std::vector<std::size_t> quadFaces;  ///< per quad (cutMeshAlong): the faces it separated that no earlier quad had
};

/// Disjoint sets over 0..n-1 (path halving; the smallest index of a set leads it).
struct DisjointSets {
  std::vector<int> parent;
  explicit DisjointSets(std::size_t n);
  int find(int a);
  void join(int a, int b);
};

/// Which tets use each node, in compressed rows (the tets of node n are tets[first[n] ..
/// first[n + 1]), ascending), and through it the tet across a face: built in one pass over the tets,
/// so a cut looks up only the faces near it.
struct TetIncidence {
  std::vector<int> first, tets;
  explicit TetIncidence(const TetMesh& mesh);
  /// The tet that shares tet t's face f (the face opposite its vertex f) with it, or -1 on the
  /// mesh's boundary and where a cut separated it. Throws handson::Error for a face of more than two tets.
  int across(const TetMesh& mesh, int t, int f) const;
};

/// The mesh cut by the quad. Throws handson::Error for a bad quad (checkCutQuad), one that separates
/// no face the mesh still shares, and one that would leave a single tet on its own.
MeshCut cutMesh(const TetMesh& mesh, const CutQuad& quad);
/// The mesh cut along a surface of several quads at once (a ruled surface: a finger's stroke): the
/// union of the faces each quad separates (each by its own plane's sides), each node of them split
/// into the groups of its tets joined around it through uncut faces. Quads applied one after another
/// would leave a seam where a joint between two runs along a plane of faces (a face on it, the
/// earlier quad's, keeps its nodes joined through the later quad's faces, and is not over the later
/// quad). cutMesh(mesh, q) is cutMeshAlong(mesh, {q}). Throws as cutMesh, and for no quad.
MeshCut cutMeshAlong(const TetMesh& mesh, const std::vector<CutQuad>& surface);

}  // namespace handson
