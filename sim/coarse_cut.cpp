// The coarse model on a cut fine mesh (docs/cutting.md, "The coarse model sees the cut"): each cell
// whose fine tets a cut separates becomes one element per piece of its tissue, the virtual node
// algorithm (Molino, Bao and Fedkiw 2004) on the coarse cells. A piece's corner is a coarse node of
// its own side: the copy of the corner's fine node the piece holds, or - where the piece holds none
// (the corner lies across the cut) - a virtual node shared with the pieces of that side around it.
#include <algorithm>
#include <unordered_map>

#include "sim/base/error.h"
#include "sim/coarsening.h"
#include "sim/coarse_pcg_workspace.h"
#include "sim/handle_reaction.h"
#include "sim/tissue_cut.h"

namespace handson {

namespace {

// The tets of one cell in the pieces joined through shared nodes (a piece joined to another by a
// single node - the crack's end - is one with it), each in the order of its first tet.
std::vector<std::vector<int>> piecesOf(const TetMesh& F, const std::vector<int>& tets) {
  DisjointSets u(tets.size());
  std::unordered_map<int, int> firstTet;
  for (std::size_t i = 0; i < tets.size(); ++i)
    for (const int v : F.tets[std::size_t(tets[i])])
      if (const auto [it, fresh] = firstTet.emplace(v, int(i)); !fresh) u.join(int(i), it->second);
  std::vector<std::vector<int>> pieces;
  std::vector<int> pieceOfRoot(tets.size(), -1);
  for (std::size_t i = 0; i < tets.size(); ++i) {
    int& p = pieceOfRoot[std::size_t(u.find(int(i)))];
    if (p < 0) {
      p = int(pieces.size());
      pieces.emplace_back();
    }
    pieces[std::size_t(p)].push_back(tets[i]);
  }
  if (pieces.empty()) pieces.emplace_back();  // a cell without tets stays one (empty) element
  return pieces;
}

std::vector<int> sortedNodes(const TetMesh& F, const std::vector<int>& tets) {
  std::vector<int> n;
  n.reserve(4 * tets.size());
  for (const int t : tets) n.insert(n.end(), F.tets[std::size_t(t)].begin(), F.tets[std::size_t(t)].end());
  std::sort(n.begin(), n.end());
  n.erase(std::unique(n.begin(), n.end()), n.end());
  return n;
}

bool share(const std::vector<int>& a, const std::vector<int>& b) {
  for (auto i = a.begin(), j = b.begin(); i != a.end() && j != b.end();) {
    if (*i == *j) return true;
    *i < *j ? ++i : ++j;
  }
  return false;
}

}  // namespace

// Per element (a piece of a cell) and corner c (an entry 8k + c): the copies of the corner's fine
// node the piece holds. Entries are joined when they hold the same copy, and an entry holding none
// (virtual) is joined to the entries at the same grid node whose pieces share a fine node with its
// own (joined tissue: the same side of the cut). Each group of entries is one coarse node: the
// corner's own where it holds the original fine node, else a new node at the same rest position, on
// the smallest copy it holds or on none (virtual).
void CoarseModel::separateCutCells(std::vector<std::vector<int>>& tetsOf) {
  const TetMesh& F = meshes_.fine;
  const std::vector<int>& source = meshes_.cutSource;
  if (source.size() != F.nodes.size()) throw Error("coarsening: the cut mesh's node sources do not fit its nodes");
  std::vector<char> split(F.nodes.size(), 0);
  for (std::size_t v = 0; v < source.size(); ++v)
    if (source[v] != int(v)) {
      if (source[v] < 0 || std::size_t(source[v]) >= v) throw Error("coarsening: a cut node copies no earlier node");
      split[v] = split[std::size_t(source[v])] = 1;
    }
  auto cut = std::make_unique<CutCells>();
  std::vector<std::vector<int>> pieces;
  std::vector<char> touched;  // per element: its cell holds a split node
  for (std::size_t cell = 0; cell < tetsOf.size(); ++cell) {
    bool any = false;
    for (const int t : tetsOf[cell])
      for (const int v : F.tets[std::size_t(t)]) any = any || split[std::size_t(v)];
    std::vector<std::vector<int>> ps = any ? piecesOf(F, tetsOf[cell]) : std::vector<std::vector<int>>{tetsOf[cell]};
    for (auto& p : ps) {
      cut->cell.push_back(int(cell));
      touched.push_back(any);
      pieces.push_back(std::move(p));
    }
  }
  const std::size_t ne = pieces.size();
  std::vector<std::vector<int>> nodesOf(ne);  // sorted fine nodes of the touched pieces (and, lazily, their neighbours)
  auto nodesOfPiece = [&](std::size_t k) -> const std::vector<int>& {
    if (nodesOf[k].empty()) nodesOf[k] = sortedNodes(F, pieces[k]);
    return nodesOf[k];
  };
  // The copies each entry holds, the entries at each grid node, and the joins.
  std::vector<std::vector<int>> copies(8 * ne);
  std::vector<int> gridOf(8 * ne);  // per entry: its grid node
  std::vector<std::vector<int>> entriesAt(nodes_.size());
  for (std::size_t k = 0; k < ne; ++k) {
    const std::array<int, 8> g = meshes_.coarseGrid.cellNodes(cut->cell[k]);
    for (int c = 0; c < 8; ++c) {
      const int original = nodeFine_[std::size_t(g[std::size_t(c)])];
      gridOf[8 * k + std::size_t(c)] = g[std::size_t(c)];
      entriesAt[std::size_t(g[std::size_t(c)])].push_back(int(8 * k) + c);
      if (!touched[k]) {
        copies[8 * k + std::size_t(c)] = {original};
        continue;
      }
      for (const int v : nodesOfPiece(k))
        if (source[std::size_t(v)] == original) copies[8 * k + std::size_t(c)].push_back(v);
    }
  }
  DisjointSets groups(8 * ne);
  std::unordered_map<int, int> entryOfCopy;
  for (std::size_t e = 0; e < copies.size(); ++e)
    for (const int v : copies[e])
      if (const auto [it, fresh] = entryOfCopy.emplace(v, int(e)); !fresh) groups.join(int(e), it->second);
  for (const auto& at : entriesAt)
    for (const int e : at) {
      if (!copies[std::size_t(e)].empty()) continue;
      for (const int o : at)
        if (o != e && share(nodesOfPiece(std::size_t(e / 8)), nodesOfPiece(std::size_t(o / 8)))) groups.join(e, o);
    }
  std::vector<int> group(copies.size());
  for (std::size_t e = 0; e < group.size(); ++e) group[e] = groups.find(int(e));
  assignCutCorners(*cut, {group, gridOf, copies});
  cut->elementOfTet.assign(F.tets.size(), -1);
  for (std::size_t k = 0; k < ne; ++k)
    for (const int t : pieces[k]) cut->elementOfTet[std::size_t(t)] = int(k);
  tetsOf = std::move(pieces);
  cut_ = std::move(cut);
}

// Each group of entries becomes one coarse node (above); each element's corner takes the group's
// node, and its fine node where the element's piece holds the node's copy (else -1: virtual there).
void CoarseModel::assignCutCorners(CutCells& cut, const CutEntries& in) {
  const std::vector<int>& group = in.group;
  const std::vector<std::vector<int>>& copies = in.copies;
  const std::size_t entries = group.size(), ne = entries / 8;
  std::vector<int> chosen(entries, -2);  // per group root: the fine node of its coarse node (-1: virtual)
  for (std::size_t e = 0; e < entries; ++e) {
    const int g = in.grid[e];
    const int original = nodeFine_[std::size_t(g)];
    int& ch = chosen[std::size_t(group[e])];
    for (const int v : copies[e])
      if (ch < 0 || v == original || (ch != original && v < ch)) ch = v;
    if (ch == -2) ch = -1;
  }
  std::vector<int> nodeOfGroup(entries, -1);
  for (std::size_t r = 0; r < entries; ++r) {
    if (group[r] != int(r)) continue;  // a root's entry is its own: its grid node is the group's
    const int g = in.grid[r];
    if (chosen[r] == nodeFine_[std::size_t(g)]) {
      nodeOfGroup[r] = g;
    } else {
      nodeOfGroup[r] = int(nodes_.size());
      nodes_.push_back(nodes_[std::size_t(g)]);
      nodeFine_.push_back(chosen[r]);
    }
  }
  cut.node.resize(ne);
  cut.fine.resize(ne);
  for (std::size_t e = 0; e < entries; ++e) {
    const int v = nodeOfGroup[std::size_t(group[e])];
    const int f = nodeFine_[std::size_t(v)];
    cut.node[e / 8][e % 8] = v;
    cut.fine[e / 8][e % 8] = f >= 0 && std::find(copies[e].begin(), copies[e].end(), f) != copies[e].end() ? f : -1;
  }
}

// A virtual corner may have no stiffness of its own (its piece's face nodes weigh other corners):
// each element with one is given springs from its virtual corners to its other corners in its own
// frame - zero for a rigid motion -, each kVirtualCornerStiffness times the element's mean corner
// stiffness (the median element's where it has none: a rigid organ's piece), so they change its
// stiffness by that fraction. (A model-wide scale would not do: bone is 10^6 times stiffer than fat.)
void CoarseModel::stiffenVirtualCorners() {
  if (!cut_) return;
  auto meanDiagonal = [](const Element& el) { return el.Kh.rows() > 0 ? el.Kh.diagonal().mean() : 0.0; };
  std::vector<double> scales;
  for (const auto& el : elements_)
    if (const double d = meanDiagonal(el); d > 0.0) scales.push_back(d);
  std::nth_element(scales.begin(), scales.begin() + std::ptrdiff_t(scales.size() / 2), scales.end());
  const double median = scales.empty() ? 1.0 : scales[scales.size() / 2];
  for (std::size_t e = 0; e < elements_.size(); ++e) {
    Element& el = elements_[e];
    const double own = meanDiagonal(el);
    const double k = kVirtualCornerStiffness * (own > 0.0 ? own : median);
    bool any = false;
    for (int c = 0; c < nc_; ++c) {
      if (cut_->fine[e][std::size_t(c)] >= 0) continue;
      any = true;
      for (int d = 0; d < nc_; ++d)
        if (d != c)
          for (int a = 0; a < 3; ++a) {
            el.Kh(3 * c + a, 3 * c + a) += k;
            el.Kh(3 * d + a, 3 * d + a) += k;
            el.Kh(3 * c + a, 3 * d + a) -= k;
            el.Kh(3 * d + a, 3 * c + a) -= k;
          }
    }
    if (any) finishElement(el);
  }
}

namespace {

// Whether node v's role differs between two sets of roles (the fixed outer boundary winning over a
// handle, as the model takes them): held, handle, or sliding spring.
struct RoleOf {
  const FineConstraints& c;
  std::vector<int> slideOf;
  explicit RoleOf(const FineConstraints& cons) : c(cons), slideOf(cons.handleOf.size(), -1) {
    for (std::size_t i = 0; i < cons.slide.size(); ++i) slideOf[std::size_t(cons.slide[i].node)] = int(i);
  }
  int handle(std::size_t v) const { return c.fixed[v] ? -1 : c.handleOf[v]; }
  bool same(const RoleOf& o, std::size_t v) const {
    if ((c.fixed[v] != 0) != (o.c.fixed[v] != 0) || handle(v) != o.handle(v) || (slideOf[v] < 0) != (o.slideOf[v] < 0)) return false;
    if (slideOf[v] < 0) return true;
    const SlideNode &a = c.slide[std::size_t(slideOf[v])], &b = o.c.slide[std::size_t(o.slideOf[v])];
    return a.handle == b.handle && a.stiffness == b.stiffness && a.normal == b.normal;
  }
};

}  // namespace

CoarseModel::CoarseModel(const CoarseModel& uncut, const NestedMeshes& meshes, const std::vector<Mat12>& fineK, const FineConstraints& cons,
                         const ProgressFn& progress)
    : meshes_(meshes), constraints_(cons), nodes_(meshes.coarse.nodes), nodeFine_(meshes.coarseNodeInFine), kind_(CoarseElement::Cell), nc_(8) {
  const TetMesh& F = meshes.fine;
  if (uncut.kind_ != CoarseElement::Cell || uncut.graded_ || uncut.cut_)
    throw Error("coarsening: a cut updates the uniform cell model of the uncut scene (rebuild a graded, tet or already cut model whole)");
  const std::size_t before = uncut.constraints_.handleOf.size();
  if (meshes.cutSource.size() != F.nodes.size() || F.nodes.size() < before || fineK.size() != F.tets.size() || cons.handleOf.size() != F.nodes.size() ||
      cons.fixed.size() != F.nodes.size() || meshes.fineParent.size() != F.tets.size() || uncut.elements_.size() != meshes.coarseGrid.cellCount() ||
      uncut.nodes_.size() != nodes_.size())
    throw Error("coarsening: the cut scene does not fit the model of the scene before the cut");
  for (std::size_t i = 0; i < F.nodes.size(); ++i)
    if (constraints_.fixed[i]) constraints_.handleOf[i] = -1;
  // The cells to condense again: those holding a copy, a node copied, or a node whose role changed.
  const RoleOf now(constraints_), then(uncut.constraints_);
  std::vector<char> changed(F.nodes.size(), 0);
  for (std::size_t v = 0; v < F.nodes.size(); ++v)
    if (v >= before || meshes.cutSource[v] != int(v)) {
      if (meshes.cutSource[v] < 0 || std::size_t(meshes.cutSource[v]) >= before) throw Error("coarsening: a cut node copies no node of the scene before the cut");
      changed[v] = changed[std::size_t(meshes.cutSource[v])] = 1;
    } else if (!now.same(then, v)) {
      changed[v] = 1;
    }
  std::vector<char> touchedCell(meshes.coarseGrid.cellCount(), 0);
  for (std::size_t t = 0; t < F.tets.size(); ++t)
    for (const int v : F.tets[t])
      if (changed[std::size_t(v)]) touchedCell[std::size_t(meshes.fineParent[t] / 6)] = 1;
  std::vector<std::vector<int>> tetsOf = ungradedTets();
  separateCutCells(tetsOf);
  takeUntouched(uncut, touchedCell);
  std::vector<char> rebuild(elements_.size());
  for (std::size_t e = 0; e < rebuild.size(); ++e) rebuild[e] = touchedCell[std::size_t(cut_->cell[e])];
  buildConforming(fineK, tetsOf, progress, &rebuild);
  stiffenVirtualCorners();
  finishBuild(progress);
}

// The untouched cells' elements (one each: an untouched cell holds no split node) and the
// reconstruction records of their nodes, from the uncut model, renumbered; the anchored skeleton's
// handle index follows the handle count (a retractor added with the cut moves it).
void CoarseModel::takeUntouched(const CoarseModel& uncut, const std::vector<char>& touchedCell) {
  std::vector<int> elementOfCell(touchedCell.size(), -1);
  for (std::size_t e = 0; e < cut_->cell.size(); ++e)
    if (!touchedCell[std::size_t(cut_->cell[e])]) elementOfCell[std::size_t(cut_->cell[e])] = int(e);
  const int oldAnchor = uncut.anchorHandle(), anchor = anchorHandle();
  auto handle = [&](int h) { return h == oldAnchor ? anchor : h; };
  elements_.resize(cut_->cell.size());
  for (std::size_t c = 0; c < touchedCell.size(); ++c) {
    if (touchedCell[c]) continue;
    Element& el = elements_[std::size_t(elementOfCell[c])];
    el = uncut.elements_[c];
    if (el.node != cut_->node[std::size_t(elementOfCell[c])]) throw Error("coarsening: an untouched cell's corners moved (internal)");
    for (auto& hb : el.handles) hb.handle = handle(hb.handle);
  }
  for (InteriorNode in : uncut.interior_)
    if (!touchedCell[std::size_t(in.element)]) {
      in.element = elementOfCell[std::size_t(in.element)];
      for (auto& g : in.g) g.handle = handle(g.handle);
      interior_.push_back(std::move(in));
    }
  for (BoundaryNode b : uncut.boundary_)
    if (!touchedCell[std::size_t(b.element)]) {
      b.element = elementOfCell[std::size_t(b.element)];
      boundary_.push_back(b);
    }
}

}  // namespace handson
