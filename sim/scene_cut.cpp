#include "sim/scene_cut.h"

#include <numeric>
#include <string>

#include "sim/base/error.h"

namespace handson {

namespace {

// Copies' roles: handle and held flags from their source, each slide spring shared among the
// copies of its node (its stiffness divided by their count).
void carryRoles(FineConstraints& c, const std::vector<int>& sourceNode) {
  const std::size_t before = c.handleOf.size();
  std::vector<int> copies(before, 1);
  for (std::size_t n = before; n < sourceNode.size(); ++n) {
    const auto s = std::size_t(sourceNode[n]);
    c.handleOf.push_back(c.handleOf[s]);
    c.fixed.push_back(c.fixed[s]);
    ++copies[s];
  }
  std::vector<std::vector<int>> copiesOf(before);
  for (std::size_t n = before; n < sourceNode.size(); ++n) copiesOf[std::size_t(sourceNode[n])].push_back(int(n));
  const std::size_t slides = c.slide.size();
  for (std::size_t i = 0; i < slides; ++i) {
    const auto s = std::size_t(c.slide[i].node);
    if (copies[s] == 1) continue;
    c.slide[i].stiffness /= double(copies[s]);
    for (int n : copiesOf[s]) {
      SlideNode copy = c.slide[i];
      copy.node = n;
      c.slide.push_back(copy);
    }
  }
}

int findRoot(std::vector<int>& parent, int a) {
  while (parent[std::size_t(a)] != a) a = parent[std::size_t(a)] = parent[std::size_t(parent[std::size_t(a)])];
  return a;
}

// A slide node left by the cut with none of the tissue's tets (only its organ's own, which have no
// stiffness: the organ moves rigidly; the tissue's side went to a copy) moves with its handle, as
// the organ's inner nodes do.
void holdRigidSlideNodes(const TetMesh& m, const std::vector<Mat12>& K, FineConstraints& c) {
  std::vector<char> stiff(m.nodes.size(), 0);
  for (std::size_t t = 0; t < m.tets.size(); ++t)
    if (!K[t].isZero(0.0))
      for (int n : m.tets[t]) stiff[std::size_t(n)] = 1;
  std::vector<SlideNode> kept;
  for (const SlideNode& sn : c.slide) {
    const auto n = std::size_t(sn.node);
    if (!stiff[n]) c.handleOf[n] = sn.handle;
    else kept.push_back(sn);
  }
  c.slide = std::move(kept);
}

// Throws unless every piece of tissue (stiff tets joined through shared faces: a piece joined to
// the rest by an edge or a corner alone would turn about it) holds a handle's or held node.
void refuseLoosePieces(const TetMesh& m, const std::vector<Mat12>& K, const FineConstraints& c) {
  const std::vector<int> across = faceNeighbours(m);
  std::vector<int> parent(m.tets.size());
  std::iota(parent.begin(), parent.end(), 0);
  std::vector<char> stiff(m.tets.size());
  for (std::size_t t = 0; t < m.tets.size(); ++t) stiff[t] = !K[t].isZero(0.0);
  for (std::size_t s = 0; s < across.size(); ++s) {
    const int t = int(s / 4), o = across[s];
    if (o < 0 || !stiff[std::size_t(t)] || !stiff[std::size_t(o)]) continue;
    const int a = findRoot(parent, t), b = findRoot(parent, o);
    if (a != b) parent[std::size_t(std::max(a, b))] = std::min(a, b);
  }
  std::vector<char> held(m.tets.size(), 0);
  std::vector<std::size_t> size(m.tets.size(), 0);
  for (std::size_t t = 0; t < m.tets.size(); ++t) {
    if (!stiff[t]) continue;
    const auto r = std::size_t(findRoot(parent, int(t)));
    ++size[r];
    for (int n : m.tets[t]) held[r] = held[r] || c.handleOf[std::size_t(n)] >= 0 || c.fixed[std::size_t(n)];
  }
  for (std::size_t r = 0; r < m.tets.size(); ++r)
    if (size[r] > 0 && !held[r])
      throw Error("cut: the cuts leave a piece of tissue (" + std::to_string(size[r]) +
                  " tets) that nothing holds, or that hangs by an edge; cut it off against a handle or the region's edge");
}

}  // namespace

SceneCutStats cutScene(SimScene& scene, const std::vector<CutQuad>& cuts) {
  SceneCutStats st;
  if (cuts.empty()) return st;
  TetMesh mesh = scene.meshes.fine;
  std::vector<int> source(mesh.nodes.size());
  std::iota(source.begin(), source.end(), 0);
  for (const CutQuad& q : cuts) {
    MeshCut c = cutMesh(mesh, q);
    st.cutFaces += c.cutFaces;
    for (int& s : c.sourceNode) s = source[std::size_t(s)];  // back to the scene's own nodes
    mesh = std::move(c.mesh);
    source = std::move(c.sourceNode);
  }
  FineConstraints constraints = scene.constraints;
  carryRoles(constraints, source);
  holdRigidSlideNodes(mesh, scene.fineK, constraints);
  refuseLoosePieces(mesh, scene.fineK, constraints);
  st.copiedNodes = mesh.nodes.size() - scene.meshes.fine.nodes.size();
  scene.meshes.fine = std::move(mesh);
  scene.constraints = std::move(constraints);
  countHandleNodes(scene, scene.handleNodeCount.size());
  return st;
}

}  // namespace handson
