#include "sim/tissue_cut.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <numeric>

#include "sim/base/error.h"

namespace handson {

namespace {

// The quad's plane: centre c, unit normal n (Newell's, so any corner order around it works), and
// the corners in the plane's coordinates (u, v) with their winding's sign.
struct QuadPlane {
  Eigen::Vector3d c, n, u, v;
  std::array<Eigen::Vector2d, 4> q;
  double winding = 1.0;
  double size = 0.0;  // the longer diagonal
  Eigen::Vector2d in(const Eigen::Vector3d& p) const { return {(p - c).dot(u), (p - c).dot(v)}; }
  double height(const Eigen::Vector3d& p) const { return (p - c).dot(n); }
  bool contains(const Eigen::Vector3d& p) const {
    const Eigen::Vector2d x = in(p);
    for (int i = 0; i < 4; ++i) {
      const Eigen::Vector2d e = q[(i + 1) % 4] - q[i], d = x - q[i];
      if (winding * (e.x() * d.y() - e.y() * d.x()) < -1e-12 * size * size) return false;
    }
    return true;
  }
};

double cross2(const Eigen::Vector2d& a, const Eigen::Vector2d& b) { return a.x() * b.y() - a.y() * b.x(); }

QuadPlane planeOf(const CutQuad& quad) {
  const auto& p = quad.corners;
  for (const auto& x : p)
    if (!x.allFinite()) throw Error("cut: a corner of the quad is not a finite point");
  QuadPlane P;
  P.size = std::max((p[2] - p[0]).norm(), (p[3] - p[1]).norm());
  Eigen::Vector3d newell = Eigen::Vector3d::Zero();
  for (int i = 0; i < 4; ++i) newell += p[std::size_t(i)].cross(p[std::size_t((i + 1) % 4)]);
  if (!(P.size > 0.0) || !(newell.norm() > 1e-9 * P.size * P.size)) throw Error("cut: the quad has no area");
  P.n = newell.normalized();
  P.c = 0.25 * (p[0] + p[1] + p[2] + p[3]);
  for (const auto& x : p)
    if (std::abs(P.height(x)) > 1e-3 * P.size) throw Error("cut: the quad's corners do not lie in one plane");
  const Eigen::Vector3d e = p[1] - p[0];
  P.u = (e - P.n * P.n.dot(e)).normalized();
  P.v = P.n.cross(P.u);
  for (int i = 0; i < 4; ++i) P.q[std::size_t(i)] = P.in(p[std::size_t(i)]);
  double sign = 0.0;
  for (int i = 0; i < 4; ++i) {
    const double turn = cross2(P.q[std::size_t((i + 1) % 4)] - P.q[std::size_t(i)], P.q[std::size_t((i + 2) % 4)] - P.q[std::size_t((i + 1) % 4)]);
    if (!(std::abs(turn) > 1e-9 * P.size * P.size) || (sign != 0.0 && turn * sign < 0.0)) throw Error("cut: the quad is not convex");
    sign = turn;
  }
  P.winding = sign > 0.0 ? 1.0 : -1.0;
  return P;
}

}  // namespace

DisjointSets::DisjointSets(std::size_t n) : parent(n) { std::iota(parent.begin(), parent.end(), 0); }

int DisjointSets::find(int a) {
  while (parent[std::size_t(a)] != a) a = parent[std::size_t(a)] = parent[std::size_t(parent[std::size_t(a)])];
  return a;
}

void DisjointSets::join(int a, int b) {
  a = find(a);
  b = find(b);
  if (a != b) parent[std::size_t(std::max(a, b))] = std::min(a, b);
}

// Found by sorting the faces' node triples.
std::vector<int> faceNeighbours(const TetMesh& mesh) {
  struct Face {
    std::array<int, 3> key;
    int slot;  // 4 tet + f
  };
  std::vector<Face> faces;
  faces.reserve(4 * mesh.tets.size());
  for (std::size_t t = 0; t < mesh.tets.size(); ++t)
    for (int f = 0; f < 4; ++f) {
      std::array<int, 3> k{};
      for (int i = 0, j = 0; i < 4; ++i)
        if (i != f) k[std::size_t(j++)] = mesh.tets[t][std::size_t(i)];
      std::sort(k.begin(), k.end());
      faces.push_back({k, int(4 * t) + f});
    }
  std::sort(faces.begin(), faces.end(), [](const Face& a, const Face& b) { return a.key < b.key || (a.key == b.key && a.slot < b.slot); });
  std::vector<int> across(faces.size(), -1);
  for (std::size_t i = 0; i + 1 < faces.size(); ++i) {
    if (faces[i].key != faces[i + 1].key) continue;
    if (i + 2 < faces.size() && faces[i + 2].key == faces[i].key) throw Error("cut: the mesh has a face shared by more than two tets");
    across[std::size_t(faces[i].slot)] = faces[i + 1].slot / 4;
    across[std::size_t(faces[i + 1].slot)] = faces[i].slot / 4;
  }
  return across;
}

namespace {

Eigen::Vector3d centroid(const TetMesh& m, int t) {
  const auto& n = m.tets[std::size_t(t)];
  return 0.25 * (m.nodes[std::size_t(n[0])] + m.nodes[std::size_t(n[1])] + m.nodes[std::size_t(n[2])] + m.nodes[std::size_t(n[3])]);
}

// The faces the quad separates: shared, between tets whose centroids lie on either side of its
// plane, with their own centroid over the quad. Per slot (4 tet + f).
std::vector<char> facesToCut(const TetMesh& mesh, const QuadPlane& P, const std::vector<int>& across, const std::vector<char>& above) {
  std::vector<char> cut(across.size(), 0);
  for (std::size_t s = 0; s < across.size(); ++s) {
    const int t = int(s / 4), o = across[s];
    if (o < 0 || above[std::size_t(t)] == above[std::size_t(o)]) continue;
    const auto& n = mesh.tets[std::size_t(t)];
    Eigen::Vector3d fc = Eigen::Vector3d::Zero();
    for (int i = 0; i < 4; ++i)
      if (i != int(s % 4)) fc += mesh.nodes[std::size_t(n[std::size_t(i)])] / 3.0;
    if (!P.contains(fc)) continue;
    cut[s] = 1;
  }
  return cut;
}

// Splits each node of a cut face by side: the tets on the side of the node's lowest-numbered tet
// keep the node, those on the other side take a copy - unless an uncut face holding the node joins
// tets of both sides (the cut's edge: the node stays shared). Tets of one side that meet only along
// an edge are not slit apart.
void splitNodes(MeshCut& out, const std::vector<int>& across, const std::vector<char>& cut, const std::vector<char>& above) {
  TetMesh& m = out.mesh;
  std::vector<std::vector<int>> tetsOf(m.nodes.size());
  std::vector<char> onCut(m.nodes.size(), 0);
  for (std::size_t t = 0; t < m.tets.size(); ++t)
    for (int i = 0; i < 4; ++i) {
      tetsOf[std::size_t(m.tets[t][std::size_t(i)])].push_back(int(t));
      if (cut[4 * t + std::size_t(i)])
        for (int j = 0; j < 4; ++j)
          if (j != i) onCut[std::size_t(m.tets[t][std::size_t(j)])] = 1;
    }
  const std::size_t inputNodes = m.nodes.size();
  for (std::size_t v = 0; v < inputNodes; ++v) {
    if (!onCut[v]) continue;
    const std::vector<int>& ts = tetsOf[v];  // ascending
    const char keep = above[std::size_t(ts[0])];
    bool edge = false;
    for (int t : ts)
      for (int f = 0; f < 4 && !edge; ++f) {
        const std::size_t slot = 4 * std::size_t(t) + std::size_t(f);
        const int o = across[slot];
        if (m.tets[std::size_t(t)][std::size_t(f)] == int(v) || o < 0 || cut[slot]) continue;  // the face must hold v
        edge = above[std::size_t(o)] != above[std::size_t(t)];
      }
    if (edge) continue;
    const int copy = int(m.nodes.size());
    m.nodes.push_back(m.nodes[v]);
    out.sourceNode.push_back(out.sourceNode[v]);
    for (int t : ts)
      if (above[std::size_t(t)] != keep)
        for (int& n : m.tets[std::size_t(t)])
          if (n == int(v)) n = copy;
  }
}

// Whether the face in slot s (4 t + f) is still shared by its two tets (all three nodes) in m.
bool stillShared(const TetMesh& m, const std::vector<int>& across, std::size_t s) {
  const int t = int(s / 4), o = across[s];
  if (o < 0) return false;
  const auto& a = m.tets[std::size_t(t)];
  int shared = 0;
  for (int i = 0; i < 4; ++i)
    if (i != int(s % 4)) shared += std::find(m.tets[std::size_t(o)].begin(), m.tets[std::size_t(o)].end(), a[std::size_t(i)]) != m.tets[std::size_t(o)].end();
  return shared == 3;
}

// Faces the cut separated (each once): cut faces whose two tets no longer share all three nodes (a
// face at the cut's edge keeps them, and so does every face of a quad narrower than the mesh's).
// Throws when it leaves a tet it touched joined to no other tet.
std::size_t separatedFaces(const TetMesh& m, const std::vector<int>& across, const std::vector<char>& cut) {
  std::size_t count = 0;
  for (std::size_t t = 0; t < m.tets.size(); ++t) {
    bool touched = false, joined = false;
    for (std::size_t s = 4 * t; s < 4 * t + 4; ++s) {
      const bool shared = stillShared(m, across, s);
      touched = touched || (cut[s] && !shared);
      joined = joined || shared;
      count += cut[s] && !shared && across[s] > int(t);
    }
    if (touched && !joined) throw Error("cut: it would leave a single tet on its own (cut further from the tissue's edge, or across it)");
  }
  return count;
}

}  // namespace

void checkCutQuad(const CutQuad& quad) { planeOf(quad); }

MeshCut cutMesh(const TetMesh& mesh, const CutQuad& quad) {
  const QuadPlane P = planeOf(quad);
  const std::vector<int> across = faceNeighbours(mesh);
  std::vector<char> above(mesh.tets.size());
  for (std::size_t t = 0; t < mesh.tets.size(); ++t) above[t] = P.height(centroid(mesh, int(t))) >= 0.0;
  const std::vector<char> cut = facesToCut(mesh, P, across, above);
  MeshCut out;
  out.mesh = mesh;
  out.sourceNode.resize(mesh.nodes.size());
  std::iota(out.sourceNode.begin(), out.sourceNode.end(), 0);
  splitNodes(out, across, cut, above);
  out.cutFaces = separatedFaces(out.mesh, across, cut);
  if (out.cutFaces == 0)
    throw Error("cut: the quad separates no tissue (it misses the mesh, follows an earlier cut, or is narrower than the mesh's faces)");
  return out;
}

}  // namespace handson
