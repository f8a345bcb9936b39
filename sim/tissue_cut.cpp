#include "sim/tissue_cut.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <iterator>
#include <numeric>

#include "sim/base/error.h"

namespace handson {

namespace {

double cross2(const Eigen::Vector2d& a, const Eigen::Vector2d& b) { return a.x() * b.y() - a.y() * b.x(); }

}  // namespace

bool CutPlane::contains(const Eigen::Vector3d& p) const {
  const Eigen::Vector2d x = in(p);
  for (int i = 0; i < 4; ++i) {
    const Eigen::Vector2d e = q[std::size_t((i + 1) % 4)] - q[std::size_t(i)], d = x - q[std::size_t(i)];
    if (winding * (e.x() * d.y() - e.y() * d.x()) < -1e-12 * size * size) return false;
  }
  return true;
}

CutPlane cutPlane(const CutQuad& quad) {
  const auto& p = quad.corners;
  for (const auto& x : p)
    if (!x.allFinite()) throw Error("cut: a corner of the quad is not a finite point");
  CutPlane P;
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

TetIncidence::TetIncidence(const TetMesh& mesh) : first(mesh.nodes.size() + 1, 0), tets(4 * mesh.tets.size()) {
  for (const auto& t : mesh.tets)
    for (int n : t) ++first[std::size_t(n) + 1];
  std::partial_sum(first.begin(), first.end(), first.begin());
  std::vector<int> next(first.begin(), first.end() - 1);
  for (std::size_t t = 0; t < mesh.tets.size(); ++t)
    for (int n : mesh.tets[t]) tets[std::size_t(next[std::size_t(n)]++)] = int(t);
}

// Among the tets of the face's first node, those holding its other two.
int TetIncidence::across(const TetMesh& mesh, int t, int f) const {
  std::array<int, 3> face{};
  for (int i = 0, j = 0; i < 4; ++i)
    if (i != f) face[std::size_t(j++)] = mesh.tets[std::size_t(t)][std::size_t(i)];
  auto holds = [&](int o, int n) { return std::find(mesh.tets[std::size_t(o)].begin(), mesh.tets[std::size_t(o)].end(), n) != mesh.tets[std::size_t(o)].end(); };
  int found = -1;
  for (int k = first[std::size_t(face[0])]; k < first[std::size_t(face[0]) + 1]; ++k) {
    const int o = tets[std::size_t(k)];
    if (o == t || !holds(o, face[1]) || !holds(o, face[2])) continue;
    if (found >= 0) throw Error("cut: the mesh has a face shared by more than two tets");
    found = o;
  }
  return found;
}

namespace {

Eigen::Vector3d centroid(const TetMesh& m, int t) {
  const auto& n = m.tets[std::size_t(t)];
  return 0.25 * (m.nodes[std::size_t(n[0])] + m.nodes[std::size_t(n[1])] + m.nodes[std::size_t(n[2])] + m.nodes[std::size_t(n[3])]);
}

// The longest edge of any tet: no tet nearer the quad than that can hold one of its faces' tets.
double longestEdge(const TetMesh& m) {
  double longest = 0.0;
  for (const auto& t : m.tets)
    for (int i = 0; i < 4; ++i)
      for (int j = i + 1; j < 4; ++j) longest = std::max(longest, (m.nodes[std::size_t(t[std::size_t(i)])] - m.nodes[std::size_t(t[std::size_t(j)])]).norm());
  return longest;
}

// The faces the quad separates: shared, between tets whose centroids lie on either side of its
// plane, with their own centroid over the quad. Ascending slots (4 tet + f). Only tets whose
// centroid lies within `reach` (the mesh's longest edge) of the quad's plane and of its outline are
// looked at: a face's tets have centroids at most half an edge from each other and an edge from the face's.
std::vector<std::size_t> facesToCut(const TetMesh& mesh, const CutPlane& P, const TetIncidence& inc, const std::vector<Eigen::Vector3d>& centroids,
                                    const std::vector<char>& above, double reach) {
  Eigen::Vector2d lo = P.q[0], hi = P.q[0];
  for (const auto& q : P.q) {
    lo = lo.cwiseMin(q);
    hi = hi.cwiseMax(q);
  }
  lo.array() -= reach;
  hi.array() += reach;
  std::vector<std::size_t> cut;
  for (std::size_t t = 0; t < mesh.tets.size(); ++t) {
    const Eigen::Vector3d& c = centroids[t];
    const Eigen::Vector2d inPlane = P.in(c);
    if (std::abs(P.height(c)) > reach || (inPlane.array() < lo.array()).any() || (inPlane.array() > hi.array()).any()) continue;
    const auto& n = mesh.tets[t];
    for (int f = 0; f < 4; ++f) {
      const int o = inc.across(mesh, int(t), f);
      if (o < 0 || above[t] == above[std::size_t(o)]) continue;
      Eigen::Vector3d fc = Eigen::Vector3d::Zero();
      for (int i = 0; i < 4; ++i)
        if (i != f) fc += mesh.nodes[std::size_t(n[std::size_t(i)])] / 3.0;
      if (P.contains(fc)) cut.push_back(4 * t + std::size_t(f));
    }
  }
  return cut;
}

bool isCut(const std::vector<std::size_t>& cut, std::size_t slot) { return std::binary_search(cut.begin(), cut.end(), slot); }

// Splits each node of a cut face into the groups of its tets that stay joined around it through
// uncut faces holding it: the group of its lowest-numbered tet keeps the node, each other group
// (in the order of its lowest tet) takes a copy at the same rest position. A node at the cut's edge,
// whose tets an uncut face joins around the cut's end, stays one. `in` is the mesh before the cut
// (out.mesh starts as its copy), whose faces `inc` finds.
void splitNodes(MeshCut& out, const TetMesh& in, const TetIncidence& inc, const std::vector<std::size_t>& cut) {
  TetMesh& m = out.mesh;
  std::vector<int> onCut;
  for (std::size_t s : cut)
    for (int j = 0; j < 4; ++j)
      if (j != int(s % 4)) onCut.push_back(in.tets[s / 4][std::size_t(j)]);
  std::sort(onCut.begin(), onCut.end());
  onCut.erase(std::unique(onCut.begin(), onCut.end()), onCut.end());
  for (int v : onCut) {
    const int* ts = inc.tets.data() + inc.first[std::size_t(v)];  // ascending
    const int k = inc.first[std::size_t(v) + 1] - inc.first[std::size_t(v)];
    DisjointSets groups{std::size_t(k)};
    for (int i = 0; i < k; ++i)
      for (int f = 0; f < 4; ++f) {
        if (in.tets[std::size_t(ts[i])][std::size_t(f)] == v || isCut(cut, 4 * std::size_t(ts[i]) + std::size_t(f))) continue;  // the face must hold v
        const int o = inc.across(in, ts[i], f);
        if (o >= 0) groups.join(i, int(std::find(ts, ts + k, o) - ts));  // o holds v too: it shares the face
      }
    std::vector<int> copyOf(std::size_t(k), -1);  // per group leader: the node its tets take
    copyOf[std::size_t(groups.find(0))] = v;
    for (int i = 1; i < k; ++i) {
      int& node = copyOf[std::size_t(groups.find(i))];
      if (node < 0) {
        node = int(m.nodes.size());
        m.nodes.push_back(m.nodes[std::size_t(v)]);
        out.sourceNode.push_back(out.sourceNode[std::size_t(v)]);
      }
      if (node != v)
        for (int& n : m.tets[std::size_t(ts[i])])
          if (n == v) n = node;
    }
  }
}

// Whether face f of tet t, shared with tet o before the cut (o >= 0), still is in m (all three nodes).
bool stillShared(const TetMesh& m, int t, int f, int o) {
  if (o < 0) return false;
  const auto& a = m.tets[std::size_t(t)];
  const auto& b = m.tets[std::size_t(o)];
  int shared = 0;
  for (int i = 0; i < 4; ++i)
    if (i != f) shared += std::find(b.begin(), b.end(), a[std::size_t(i)]) != b.end();
  return shared == 3;
}

// Faces the cut separated (each once): cut faces whose two tets no longer share all three nodes (a
// face at the cut's edge keeps them, and so does every face of a quad narrower than the mesh's).
// Throws when it leaves a tet it touched joined to no other tet. Only the cut faces' tets can be.
std::size_t separatedFaces(const TetMesh& m, const TetMesh& in, const TetIncidence& inc, const std::vector<std::size_t>& cut) {
  std::vector<int> cutTets;
  for (std::size_t s : cut) cutTets.push_back(int(s / 4));
  cutTets.erase(std::unique(cutTets.begin(), cutTets.end()), cutTets.end());  // ascending already
  std::size_t count = 0;
  for (int t : cutTets) {
    bool touched = false, joined = false;
    for (int f = 0; f < 4; ++f) {
      const int o = inc.across(in, t, f);
      const bool shared = stillShared(m, t, f, o), isCutFace = isCut(cut, 4 * std::size_t(t) + std::size_t(f));
      touched = touched || (isCutFace && !shared);
      joined = joined || shared;
      count += isCutFace && !shared && o > t;
    }
    if (touched && !joined) throw Error("cut: it would leave a single tet on its own (cut further from the tissue's edge, or across it)");
  }
  return count;
}

}  // namespace

void checkCutQuad(const CutQuad& quad) { cutPlane(quad); }

MeshCut cutMesh(const TetMesh& mesh, const CutQuad& quad) { return cutMeshAlong(mesh, std::vector<CutQuad>{quad}); }

MeshCut cutMeshAlong(const TetMesh& mesh, const std::vector<CutQuad>& surface) {
  if (surface.empty()) throw Error("cut: no quad to cut along");
  std::vector<CutPlane> planes;
  for (const CutQuad& q : surface) planes.push_back(cutPlane(q));
  const TetIncidence inc(mesh);
  const double reach = longestEdge(mesh);
  std::vector<std::size_t> cut;                     // the union of the quads' faces, each quad's sides its own
  std::vector<std::vector<std::size_t>> ownFaces;  // per quad: its faces no earlier quad has
  std::vector<Eigen::Vector3d> centroids(mesh.tets.size());
  for (std::size_t t = 0; t < mesh.tets.size(); ++t) centroids[t] = centroid(mesh, int(t));
  std::vector<char> above(mesh.tets.size());
  for (const CutPlane& P : planes) {
    for (std::size_t t = 0; t < mesh.tets.size(); ++t) above[t] = P.height(centroids[t]) >= 0.0;
    std::vector<std::size_t> faces = facesToCut(mesh, P, inc, centroids, above, reach);
    std::sort(cut.begin(), cut.end());
    std::vector<std::size_t> own;
    std::set_difference(faces.begin(), faces.end(), cut.begin(), cut.end(), std::back_inserter(own));
    cut.insert(cut.end(), own.begin(), own.end());
    ownFaces.push_back(std::move(own));
  }
  std::sort(cut.begin(), cut.end());
  MeshCut out;
  out.mesh = mesh;
  out.sourceNode.resize(mesh.nodes.size());
  std::iota(out.sourceNode.begin(), out.sourceNode.end(), 0);
  splitNodes(out, mesh, inc, cut);
  out.cutFaces = separatedFaces(out.mesh, mesh, inc, cut);
  for (const auto& own : ownFaces) {  // the faces each quad separated that no earlier quad had
    std::size_t n = 0;
    for (std::size_t slot : own) n += !stillShared(out.mesh, int(slot / 4), int(slot % 4), inc.across(mesh, int(slot / 4), int(slot % 4)));
    out.quadFaces.push_back(n);
  }
  if (out.cutFaces == 0)
    throw Error("cut: the quad separates no tissue (it misses the mesh, follows an earlier cut, or is narrower than the mesh's faces)");
  return out;
}

}  // namespace handson
