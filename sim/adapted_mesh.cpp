#include "adapted_mesh.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <string>

#include "sim/base/error.h"
#include "sim/tetgen_mesher.h"

namespace handson {

namespace {

// One coarse cell's points for TetGen: the fine lattice nodes (m + 1 a side; those on the cell's
// faces keep their fine lattice index, so neighbouring cells share them), then structure points.
struct CellPoints {
  int m = 0;
  std::vector<Eigen::Vector3d> pts;
  std::vector<int> globalOf;  ///< per point: its fine lattice node on the cell's faces, -1 inside it
  std::vector<int> localOf;   ///< per lattice node of the cell: its point
  std::size_t regularPoints = 0;
  std::size_t lidx(int a, int b, int c) const { return std::size_t(a + (m + 1) * (b + (m + 1) * c)); }
  int at(const Eigen::Vector3i& l) const { return localOf[lidx(l.x(), l.y(), l.z())]; }
};

CellPoints latticePoints(const KuhnGrid& fg, const Eigen::Vector3i& base, int m) {
  CellPoints cp;
  cp.m = m;
  cp.localOf.assign(std::size_t((m + 1) * (m + 1) * (m + 1)), -1);
  for (int c = 0; c <= m; ++c)
    for (int b = 0; b <= m; ++b)
      for (int a = 0; a <= m; ++a) {
        const bool surface = a == 0 || b == 0 || c == 0 || a == m || b == m || c == m;
        const int gi = fg.nodeIndex(base.x() + a, base.y() + b, base.z() + c);
        cp.localOf[cp.lidx(a, b, c)] = int(cp.pts.size());
        cp.pts.push_back(fg.nodePosition(gi));
        cp.globalOf.push_back(surface ? gi : -1);
      }
  cp.regularPoints = cp.pts.size();
  return cp;
}

// The cell's faces as triangles: each face square split along its Kuhn diagonal (both coordinates
// rising), exactly as the regular fine mesh splits it.
std::vector<std::array<int, 3>> surfaceTriangles(const CellPoints& cp) {
  const int m = cp.m;
  std::vector<std::array<int, 3>> tris;
  for (int axis = 0; axis < 3; ++axis) {
    const int p = (axis + 1) % 3, q = (axis + 2) % 3;
    for (int side : {0, m})
      for (int u = 0; u < m; ++u)
        for (int v = 0; v < m; ++v) {
          auto node = [&](int du, int dv) {
            Eigen::Vector3i l;
            l[axis] = side;
            l[p] = u + du;
            l[q] = v + dv;
            return cp.at(l);
          };
          tris.push_back({node(0, 0), node(1, 0), node(1, 1)});
          tris.push_back({node(0, 0), node(1, 1), node(0, 1)});
        }
  }
  return tris;
}

// Builds the adapted fine mesh cell by cell into the regular nested meshes' grids.
class AdaptedMeshBuilder {
 public:
  explicit AdaptedMeshBuilder(const AdaptedMeshSpec& spec)
      : spec_(spec), out_(buildNestedMeshes(spec.lo, spec.hi, spec.coarseTets, spec.finePerCoarse)), regular_(std::move(out_.fine)) {
    const std::vector<int> regularParent = std::move(out_.fineParent);
    out_.fine = TetMesh{};
    out_.fineParent.clear();
    out_.regularFine = false;
    shared_.assign(std::size_t(out_.fineGrid.nodeCount()), -1);
    // The regular tets of each cell (for the fallback): regular fine tet t lies in cell parent / 6.
    regularOfCell_.resize(out_.coarseGrid.cellCount());
    for (std::size_t t = 0; t < regular_.tets.size(); ++t) regularOfCell_[std::size_t(regularParent[t] / 6)].push_back(int(t));
    const int n2 = 2 * out_.refinement;
    youngs_.resize(std::size_t((n2 + 1) * (n2 + 1) * (n2 + 1)));
  }

  NestedMeshes build(const ProgressFn& progress, AdaptedMeshStats* stats) {
    const std::size_t cells = out_.coarseGrid.cellCount();
    out_.cellTetStart.assign(cells + 1, 0);
    for (std::size_t cell = 0; cell < cells; ++cell) {
      if (cell % 64 == 0) reportProgress(progress, double(cell) / double(cells), "image-adapted fine mesh");
      meshCell(cell);
      out_.cellTetStart[cell + 1] = int(out_.fine.tets.size());
    }
    assignParents();
    reportProgress(progress, 1.0, "image-adapted fine mesh");
    if (stats) *stats = st_;
    return std::move(out_);
  }

 private:
  // The fine mesh's node of a lattice node on a cell face: one index across cells (conforming faces).
  int sharedNode(int gi) {
    int& s = shared_[std::size_t(gi)];
    if (s < 0) {
      s = int(out_.fine.nodes.size());
      out_.fine.nodes.push_back(out_.fineGrid.nodePosition(gi));
    }
    return s;
  }

  // Points of the half-spacing lattice (h / 2m) whose Young's modulus differs by the contrast or
  // more from one of their six half-spacing neighbours'.
  void addStructurePoints(CellPoints& cp, const Eigen::Vector3d& origin) {
    const int n2 = 2 * cp.m;
    const Eigen::Vector3d half = out_.fineGrid.cell() / 2.0;
    auto hidx = [n2](int a, int b, int c) { return std::size_t(a + (n2 + 1) * (b + (n2 + 1) * c)); };
    for (int c = 0; c <= n2; ++c)
      for (int b = 0; b <= n2; ++b)
        for (int a = 0; a <= n2; ++a) youngs_[hidx(a, b, c)] = spec_.youngsAt(origin + half.cwiseProduct(Eigen::Vector3d(a, b, c)));
    auto jump = [this](double e0, double e1) { return std::max(e0, e1) >= spec_.contrast * std::min(e0, e1); };
    for (int c = 1; c < n2; ++c)
      for (int b = 1; b < n2; ++b)
        for (int a = 1; a < n2; ++a) {
          if (a % 2 == 0 && b % 2 == 0 && c % 2 == 0) continue;  // a regular lattice node
          const double here = youngs_[hidx(a, b, c)];
          if (jump(here, youngs_[hidx(a - 1, b, c)]) || jump(here, youngs_[hidx(a + 1, b, c)]) || jump(here, youngs_[hidx(a, b - 1, c)]) ||
              jump(here, youngs_[hidx(a, b + 1, c)]) || jump(here, youngs_[hidx(a, b, c - 1)]) || jump(here, youngs_[hidx(a, b, c + 1)])) {
            cp.pts.push_back(origin + half.cwiseProduct(Eigen::Vector3d(a, b, c)));
            cp.globalOf.push_back(-1);
          }
        }
  }

  void meshCell(std::size_t cell) {
    const KuhnGrid& cg = out_.coarseGrid;
    const int m = out_.refinement;
    const Eigen::Vector3i ci(int(cell) % cg.cells().x(), (int(cell) / cg.cells().x()) % cg.cells().y(), int(cell) / (cg.cells().x() * cg.cells().y()));
    const Eigen::Vector3i base = ci * m;  // the cell's first fine lattice node
    CellPoints cp = latticePoints(out_.fineGrid, base, m);
    addStructurePoints(cp, cg.origin() + cg.cell().cwiseProduct(ci.cast<double>()));
    const TetgenResult r = cp.pts.size() > cp.regularPoints ? tetrahedralizeSurface(cp.pts, surfaceTriangles(cp)) : TetgenResult{};
    std::vector<int> index(cp.pts.size(), -1);
    auto indexOf = [&](int l) {
      int& i = index[std::size_t(l)];
      if (i < 0) {
        if (cp.globalOf[std::size_t(l)] >= 0) {
          i = sharedNode(cp.globalOf[std::size_t(l)]);
        } else {
          i = int(out_.fine.nodes.size());
          out_.fine.nodes.push_back(cp.pts[std::size_t(l)]);
        }
      }
      return i;
    };
    if (r.ok) {
      st_.structurePoints += cp.pts.size() - cp.regularPoints;
      for (const auto& t : r.tets) out_.fine.tets.push_back({indexOf(t[0]), indexOf(t[1]), indexOf(t[2]), indexOf(t[3])});
      return;
    }
    // Homogeneous cell (nothing to add) or TetGen refused it: the regular Kuhn tets.
    if (cp.pts.size() > cp.regularPoints) {
      ++st_.fallbackCells;
      if (st_.firstFailure.empty()) st_.firstFailure = r.message;
    }
    for (int t : regularOfCell_[cell]) {
      std::array<int, 4> tet{};
      for (int k = 0; k < 4; ++k) tet[std::size_t(k)] = indexOf(cp.at(out_.fineGrid.nodeCoords(regular_.tets[std::size_t(t)][std::size_t(k)]) - base));
      out_.fine.tets.push_back(tet);
    }
  }

  // Each fine tet's coarse tet (the one holding its centroid; any tet of its cell serves cell
  // elements) and each coarse node's fine node.
  void assignParents() {
    const KuhnGrid& cg = out_.coarseGrid;
    out_.cellTets.resize(out_.fine.tets.size());
    out_.fineParent.resize(out_.fine.tets.size());
    for (std::size_t cell = 0; cell < cg.cellCount(); ++cell)
      for (int k = out_.cellTetStart[cell]; k < out_.cellTetStart[cell + 1]; ++k) {
        out_.cellTets[std::size_t(k)] = k;
        Eigen::Vector3d c = Eigen::Vector3d::Zero();
        for (int v : out_.fine.tets[std::size_t(k)]) c += out_.fine.nodes[std::size_t(v)] / 4.0;
        const int t = cg.locate(c);
        out_.fineParent[std::size_t(k)] = (t >= 0 && std::size_t(t / 6) == cell) ? t : int(cell) * 6;
      }
    out_.coarseNodeInFine.resize(out_.coarse.nodes.size());
    for (std::size_t n = 0; n < out_.coarse.nodes.size(); ++n) {
      const Eigen::Vector3i ijk = cg.nodeCoords(int(n)) * out_.refinement;
      out_.coarseNodeInFine[n] = shared_[std::size_t(out_.fineGrid.nodeIndex(ijk.x(), ijk.y(), ijk.z()))];
      if (out_.coarseNodeInFine[n] < 0) throw Error("meshing: a coarse node is missing from the adapted fine mesh");
    }
  }

  const AdaptedMeshSpec& spec_;
  NestedMeshes out_;
  const TetMesh regular_;
  std::vector<int> shared_;  ///< per fine lattice node: its node in the adapted mesh (-1: none yet)
  std::vector<std::vector<int>> regularOfCell_;
  std::vector<double> youngs_;  ///< one cell's half-spacing lattice (scratch)
  AdaptedMeshStats st_;
};

}  // namespace

NestedMeshes buildImageAdaptedMeshes(const AdaptedMeshSpec& spec, const ProgressFn& progress, AdaptedMeshStats* stats) {
  if (!spec.youngsAt) throw Error("meshing: no material function for the image-adapted mesh");
  if (!(spec.contrast > 1.0) || !std::isfinite(spec.contrast)) throw Error("meshing: the stiffness contrast that adds points must be a finite number > 1");
  return AdaptedMeshBuilder(spec).build(progress, stats);
}

}  // namespace handson
