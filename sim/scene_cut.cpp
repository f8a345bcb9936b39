#include "sim/scene_cut.h"

#include <algorithm>
#include <cmath>
#include <string>

#include "sim/base/error.h"

namespace handson {

namespace {

// What the cut did to the scene's nodes: per node of the cut mesh, its source and whether that
// source was split (has a copy); per tet, whether it has stiffness (a sliding organ's own tets
// have none: it moves rigidly).
struct CutNodes {
  std::vector<int> source;
  std::vector<char> split;
  std::vector<char> stiffTet;
};

CutNodes cutNodes(const TetMesh& m, const std::vector<Mat12>& K, std::vector<int> source, std::size_t sceneNodes) {
  CutNodes c{std::move(source), {}, std::vector<char>(m.tets.size(), 0)};
  std::vector<int> count(sceneNodes, 0);
  for (int s : c.source) ++count[std::size_t(s)];
  c.split.resize(c.source.size());
  for (std::size_t n = 0; n < c.source.size(); ++n) c.split[n] = count[std::size_t(c.source[n])] > 1;
  for (std::size_t t = 0; t < m.tets.size(); ++t) c.stiffTet[t] = !K[t].isZero(0.0);
  return c;
}

// Copies' roles from their source: the handle and held flags, and a copy of each slide spring.
void carryRoles(FineConstraints& c, const std::vector<int>& source) {
  const std::size_t before = c.handleOf.size();
  std::vector<std::vector<int>> copiesOf(before);
  for (std::size_t n = before; n < source.size(); ++n) {
    const auto s = std::size_t(source[n]);
    c.handleOf.push_back(c.handleOf[s]);
    c.fixed.push_back(c.fixed[s]);
    copiesOf[s].push_back(int(n));
  }
  const std::size_t slides = c.slide.size();
  for (std::size_t i = 0; i < slides; ++i)
    for (int n : copiesOf[std::size_t(c.slide[i].node)]) {
      SlideNode copy = c.slide[i];
      copy.node = n;
      c.slide.push_back(copy);
    }
}

// The nodes the cut split take the role their own side gives them:
//  - a slide node with the organ's (stiffness-free) tets alone moves with its handle, as the organ's
//    inner nodes do; one with tissue tets alone was cut off the organ and is free (no spring); one
//    with both keeps its spring, of kSlidePenalty times its own tissue stiffness (as the scene makes it);
//  - a node a handle moves that has none of the handle's own tets left (glued: tets of its nodes
//    alone; sliding: the organ's) was cut off it and is free.
// Held nodes stay held (a cut along bone leaves the tissue anchored there).
void rolesBySide(const TetMesh& m, const std::vector<Mat12>& K, const CutNodes& cut, FineConstraints& c) {
  std::vector<char> rigid(m.nodes.size(), 0), stiff(m.nodes.size(), 0), ownHandle(m.nodes.size(), 0);
  std::vector<double> diag(m.nodes.size(), 0.0);
  for (std::size_t t = 0; t < m.tets.size(); ++t) {
    const auto& n = m.tets[t];
    const int h = c.handleOf[std::size_t(n[0])];
    bool allOfHandle = h >= 0;
    for (int a = 0; a < 4; ++a) allOfHandle = allOfHandle && c.handleOf[std::size_t(n[std::size_t(a)])] == h;
    for (int a = 0; a < 4; ++a) {
      const auto v = std::size_t(n[std::size_t(a)]);
      (cut.stiffTet[t] ? stiff : rigid)[v] = 1;
      ownHandle[v] = ownHandle[v] || !cut.stiffTet[t] || allOfHandle;
      diag[v] += K[t].block<3, 3>(3 * a, 3 * a).trace() / 3.0;
    }
  }
  for (std::size_t v = 0; v < m.nodes.size(); ++v)
    if (cut.split[v] && c.handleOf[v] >= 0 && !c.fixed[v] && !ownHandle[v]) c.handleOf[v] = -1;
  std::vector<SlideNode> kept;
  for (SlideNode sn : c.slide) {
    const auto v = std::size_t(sn.node);
    if (!cut.split[v]) {
      kept.push_back(sn);
    } else if (!stiff[v]) {
      c.handleOf[v] = sn.handle;
    } else if (rigid[v]) {
      sn.stiffness = kSlidePenalty * diag[v];
      kept.push_back(sn);
    }
  }
  c.slide = std::move(kept);
}

// Whether the held points seen so far fix a rigid body: three of them off one line (1e-3 mm apart).
struct RigidHold {
  int points = 0;  // 0, 1 (p0), 2 (p0, p1 apart), 3 (one off their line)
  Eigen::Vector3d p0, p1;
  void add(const Eigen::Vector3d& p) {
    if (points == 0) {
      p0 = p;
      points = 1;
    } else if (points == 1 && (p - p0).norm() > 1e-3) {
      p1 = p;
      points = 2;
    } else if (points == 2 && (p1 - p0).cross(p - p0).norm() > 1e-3 * (p1 - p0).norm()) {
      points = 3;
    }
  }
};

// Drops the spring of every slide node that a handle now moves (it adhered, or a retractor took it).
void dropSpringsOfHandleNodes(FineConstraints& c) {
  std::vector<SlideNode> kept;
  for (const SlideNode& sn : c.slide)
    if (c.handleOf[std::size_t(sn.node)] < 0) kept.push_back(sn);
  c.slide = std::move(kept);
}

// A piece held by nothing but its contact with one organ's sliding interface adheres to that organ:
// the organ whose slide nodes it holds, and nothing else held in it but that organ's own nodes.
// Returns the organ; throws for a piece that touches no organ, several, or an organ and something
// held (the region's edge, the skeleton, another handle: it would be torn between them).
int organOfLoosePiece(const TetMesh& m, const std::vector<int>& tets, const std::vector<int>& slideOf, const FineConstraints& c) {
  int organ = -1;
  bool other = false;
  for (int t : tets)
    for (int n : m.tets[std::size_t(t)]) {
      const int s = slideOf[std::size_t(n)];
      if (s >= 0) {
        const int h = c.slide[std::size_t(s)].handle;
        other = other || (organ >= 0 && h != organ);
        organ = h;
      }
    }
  for (int t : tets)
    for (int n : m.tets[std::size_t(t)]) other = other || c.fixed[std::size_t(n)] || (c.handleOf[std::size_t(n)] >= 0 && c.handleOf[std::size_t(n)] != organ);
  const std::string piece = "cut: the cuts leave a piece of tissue (" + std::to_string(tets.size()) + " tets) ";
  if (organ < 0) throw Error(piece + "that nothing holds, or that hangs by a point or an edge; cut it off against a handle or the region's edge");
  if (other) throw Error(piece + "held at fewer than three points, on an organ's surface and by something else; cut it off against a handle or the region's edge");
  return organ;
}

// Every piece of tissue the cut touched (stiff tets joined through shared faces, so a piece hanging
// by an edge is a piece of its own) must hold three handle's or held nodes off one line, or its
// position would be undetermined; one that does not adheres to the organ whose sliding interface
// alone holds it (organOfLoosePiece; throws otherwise): its free nodes become that handle's and
// their springs go. Each piece is searched from a stiff tet of a split node, breadth first, until
// it is held (the tets it reached are then known held: a search that meets one stops) or has none
// left to reach; the loose pieces adhere after all are found, so the order of the search does not
// matter, and a node two loose pieces would give to different organs refuses the cut.
void holdLoosePieces(const TetMesh& m, const CutNodes& cut, FineConstraints& c) {
  const TetIncidence inc(m);
  std::vector<int> slideOf(m.nodes.size(), -1);
  for (std::size_t i = 0; i < c.slide.size(); ++i) slideOf[std::size_t(c.slide[i].node)] = int(i);
  enum : char { kUnseen, kSearched, kHeld };
  std::vector<char> state(m.tets.size(), kUnseen);
  std::vector<std::vector<int>> loose;
  for (std::size_t start = 0; start < m.tets.size(); ++start) {
    if (state[start] != kUnseen || !cut.stiffTet[start]) continue;
    bool touched = false;
    for (int n : m.tets[start]) touched = touched || cut.split[std::size_t(n)];
    if (!touched) continue;
    std::vector<int> reached{int(start)};
    state[start] = kSearched;
    RigidHold hold;
    bool held = false;
    for (std::size_t i = 0; i < reached.size() && !held; ++i) {
      const int t = reached[i];
      for (int n : m.tets[std::size_t(t)])
        if (c.handleOf[std::size_t(n)] >= 0 || c.fixed[std::size_t(n)]) hold.add(m.nodes[std::size_t(n)]);
      held = hold.points == 3;
      for (int f = 0; f < 4 && !held; ++f) {
        const int o = inc.across(m, t, f);
        if (o < 0 || !cut.stiffTet[std::size_t(o)]) continue;
        held = state[std::size_t(o)] == kHeld;
        if (state[std::size_t(o)] == kUnseen) {
          state[std::size_t(o)] = kSearched;
          reached.push_back(o);
        }
      }
    }
    if (held) {
      for (int t : reached) state[std::size_t(t)] = kHeld;
    } else {
      loose.push_back(std::move(reached));  // the whole piece: no other search reaches it
    }
  }
  std::vector<int> organs;
  for (const auto& piece : loose) organs.push_back(organOfLoosePiece(m, piece, slideOf, c));
  for (std::size_t p = 0; p < loose.size(); ++p)
    for (int t : loose[p])
      for (int n : m.tets[std::size_t(t)]) {
        int& h = c.handleOf[std::size_t(n)];
        if (h >= 0 && h != organs[p]) throw Error("cut: the cuts leave pieces of tissue held only between two organs");
        if (!c.fixed[std::size_t(n)]) h = organs[p];
      }
  dropSpringsOfHandleNodes(c);
}

}  // namespace

SceneCutStats cutScene(SimScene& scene, const std::vector<CutQuad>& cuts) {
  SceneCutStats st;
  if (cuts.empty()) return st;
  MeshCut c = cutMeshAlong(scene.meshes.fine, cuts);  // at once: a polyline of quads leaves no seam at its joints
  for (std::size_t q = 0; q < c.quadFaces.size(); ++q)
    if (c.quadFaces[q] == 0)
      throw Error("cut: quad " + std::to_string(q + 1) + " separates no tissue the others do not (it misses the mesh, repeats or lies within another, or is narrower than the mesh's faces)");
  st.cutFaces = c.cutFaces;
  TetMesh mesh = std::move(c.mesh);
  std::vector<int> source = std::move(c.sourceNode);
  FineConstraints constraints = scene.constraints;
  carryRoles(constraints, source);
  const CutNodes cut = cutNodes(mesh, scene.fineK, std::move(source), scene.meshes.fine.nodes.size());
  rolesBySide(mesh, scene.fineK, cut, constraints);
  holdLoosePieces(mesh, cut, constraints);
  st.copiedNodes = mesh.nodes.size() - scene.meshes.fine.nodes.size();
  st.sourceNode = cut.source;
  std::vector<int>& original = scene.meshes.cutSource;  // composed over the cuts so far
  std::vector<int> composed(cut.source.size());
  for (std::size_t v = 0; v < composed.size(); ++v) composed[v] = original.empty() ? cut.source[v] : original[std::size_t(cut.source[v])];
  original = std::move(composed);
  scene.meshes.fine = std::move(mesh);
  scene.constraints = std::move(constraints);
  countHandleNodes(scene, scene.handleNodeCount.size());
  return st;
}

int addLipHandle(SimScene& scene, const CutLip& lip) {
  if ((lip.side != 1 && lip.side != -1) || !(lip.widthMm > 0.0) || !std::isfinite(lip.widthMm))
    throw Error("cut lip: its side must be +1 or -1 and its width above 0");
  const CutPlane P = cutPlane(lip.quad);
  const TetMesh& m = scene.meshes.fine;
  FineConstraints& c = scene.constraints;
  const int handle = c.handleCount;
  std::vector<int> taken;
  for (std::size_t t = 0; t < m.tets.size(); ++t) {
    if (scene.fineK[t].isZero(0.0)) continue;  // a sliding organ's own tets: not tissue
    Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
    for (int n : m.tets[t]) centroid += 0.25 * m.nodes[std::size_t(n)];
    const double h = lip.side * P.height(centroid);
    if (!(h > 0.0) || h > lip.widthMm || !P.contains(centroid)) continue;
    for (int n : m.tets[t])
      if (!c.fixed[std::size_t(n)] && c.handleOf[std::size_t(n)] < 0) taken.push_back(n);
  }
  std::sort(taken.begin(), taken.end());
  taken.erase(std::unique(taken.begin(), taken.end()), taken.end());
  if (taken.empty()) throw Error("cut lip: no free tissue on that side of the cut within " + std::to_string(lip.widthMm) + " mm");
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  for (int n : taken) {
    c.handleOf[std::size_t(n)] = handle;
    centre += m.nodes[std::size_t(n)] / double(taken.size());
  }
  dropSpringsOfHandleNodes(c);
  c.handleCount = handle + 1;
  scene.handleCentroid.push_back(centre);
  countHandleNodes(scene, std::size_t(c.handleCount));
  return handle;
}

CutLip lipAwayFrom(const CutQuad& quad, const Eigen::Vector3d& organ, double widthMm) {
  return {quad, cutPlane(quad).height(organ) > 0.0 ? -1 : 1, widthMm};
}

}  // namespace handson
