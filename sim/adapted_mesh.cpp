#include "adapted_mesh.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <string>

#include "sim/error.h"
#include "sim/tetgen_mesher.h"

namespace handson {

NestedMeshes buildImageAdaptedMeshes(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi, int coarseTets, int finePerCoarse,
                                     const std::function<double(const Eigen::Vector3d&)>& youngsAt, double contrast, const ProgressFn& progress,
                                     AdaptedMeshStats* stats) {
  if (!youngsAt) throw Error("meshing: no material function for the image-adapted mesh");
  if (!(contrast > 1.0) || !std::isfinite(contrast)) throw Error("meshing: the stiffness contrast that adds points must be a finite number > 1");
  NestedMeshes out = buildNestedMeshes(lo, hi, coarseTets, finePerCoarse);
  const TetMesh regular = std::move(out.fine);
  const std::vector<int> regularParent = std::move(out.fineParent);
  const KuhnGrid& cg = out.coarseGrid;
  const KuhnGrid& fg = out.fineGrid;
  const int m = out.refinement;
  AdaptedMeshStats st;
  out.fine = TetMesh{};
  out.fineParent.clear();
  out.regularFine = false;
  // Fine lattice nodes on cell faces keep one index across cells (conforming faces).
  std::vector<int> shared(fg.nodeCount(), -1);
  auto sharedNode = [&](int gi) {
    int& s = shared[std::size_t(gi)];
    if (s < 0) {
      s = int(out.fine.nodes.size());
      out.fine.nodes.push_back(fg.nodePosition(gi));
    }
    return s;
  };
  // The regular tets of each cell (for the fallback): regular fine tet t lies in cell parent / 6.
  const std::size_t cells = cg.cellCount();
  std::vector<std::vector<int>> regularOfCell(cells);
  for (std::size_t t = 0; t < regular.tets.size(); ++t) regularOfCell[std::size_t(regularParent[t] / 6)].push_back(int(t));
  out.cellTetStart.assign(cells + 1, 0);
  const int n2 = 2 * m;  // half-spacing lattice intervals per cell edge
  std::vector<double> youngs(std::size_t((n2 + 1) * (n2 + 1) * (n2 + 1)));
  auto hidx = [&](int a, int b, int c) { return std::size_t(a + (n2 + 1) * (b + (n2 + 1) * c)); };
  for (std::size_t cell = 0; cell < cells; ++cell) {
    if (cell % 64 == 0) reportProgress(progress, double(cell) / double(cells), "image-adapted fine mesh");
    const Eigen::Vector3i ci(int(cell) % cg.cells().x(), (int(cell) / cg.cells().x()) % cg.cells().y(), int(cell) / (cg.cells().x() * cg.cells().y()));
    const Eigen::Vector3i base = ci * m;  // the cell's first fine lattice node
    const Eigen::Vector3d origin = cg.origin() + cg.cell().cwiseProduct(ci.cast<double>());
    const Eigen::Vector3d half = fg.cell() / 2.0;
    // Local points: the surface lattice nodes first, then the interior ones, then structure points.
    std::vector<Eigen::Vector3d> pts;
    std::vector<int> globalOf;  // shared index of surface points, -1 for interior ones
    std::vector<int> localOf(std::size_t((m + 1) * (m + 1) * (m + 1)), -1);
    auto lidx = [&](int a, int b, int c) { return std::size_t(a + (m + 1) * (b + (m + 1) * c)); };
    for (int c = 0; c <= m; ++c)
      for (int b = 0; b <= m; ++b)
        for (int a = 0; a <= m; ++a) {
          const bool surface = a == 0 || b == 0 || c == 0 || a == m || b == m || c == m;
          const int gi = fg.nodeIndex(base.x() + a, base.y() + b, base.z() + c);
          localOf[lidx(a, b, c)] = int(pts.size());
          pts.push_back(fg.nodePosition(gi));
          globalOf.push_back(surface ? gi : -1);
        }
    // Surface triangles: each face square split along its Kuhn diagonal (both coordinates rising).
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
              return localOf[lidx(l.x(), l.y(), l.z())];
            };
            tris.push_back({node(0, 0), node(1, 0), node(1, 1)});
            tris.push_back({node(0, 0), node(1, 1), node(0, 1)});
          }
    }
    // Structure points on the half-spacing lattice.
    for (int c = 0; c <= n2; ++c)
      for (int b = 0; b <= n2; ++b)
        for (int a = 0; a <= n2; ++a) youngs[hidx(a, b, c)] = youngsAt(origin + half.cwiseProduct(Eigen::Vector3d(a, b, c)));
    auto jump = [&](double e0, double e1) { return std::max(e0, e1) >= contrast * std::min(e0, e1); };
    const std::size_t regularPoints = pts.size();
    for (int c = 1; c < n2; ++c)
      for (int b = 1; b < n2; ++b)
        for (int a = 1; a < n2; ++a) {
          if (a % 2 == 0 && b % 2 == 0 && c % 2 == 0) continue;  // a regular lattice node
          const double here = youngs[hidx(a, b, c)];
          if (jump(here, youngs[hidx(a - 1, b, c)]) || jump(here, youngs[hidx(a + 1, b, c)]) || jump(here, youngs[hidx(a, b - 1, c)]) ||
              jump(here, youngs[hidx(a, b + 1, c)]) || jump(here, youngs[hidx(a, b, c - 1)]) || jump(here, youngs[hidx(a, b, c + 1)])) {
            pts.push_back(origin + half.cwiseProduct(Eigen::Vector3d(a, b, c)));
            globalOf.push_back(-1);
          }
        }
    TetgenResult r = pts.size() > regularPoints ? tetrahedralizeSurface(pts, tris) : TetgenResult{};
    std::vector<int> index(pts.size(), -1);
    auto indexOf = [&](int l) {
      int& i = index[std::size_t(l)];
      if (i < 0) {
        if (globalOf[std::size_t(l)] >= 0) i = sharedNode(globalOf[std::size_t(l)]);
        else {
          i = int(out.fine.nodes.size());
          out.fine.nodes.push_back(pts[std::size_t(l)]);
        }
      }
      return i;
    };
    if (r.ok) {
      st.structurePoints += pts.size() - regularPoints;
      for (const auto& t : r.tets) out.fine.tets.push_back({indexOf(t[0]), indexOf(t[1]), indexOf(t[2]), indexOf(t[3])});
    } else {
      // Homogeneous cell (nothing to add) or TetGen refused it: the regular Kuhn tets.
      if (pts.size() > regularPoints) {
        ++st.fallbackCells;
        if (st.firstFailure.empty()) st.firstFailure = r.message;
      }
      for (int t : regularOfCell[cell]) {
        std::array<int, 4> tet{};
        for (int k = 0; k < 4; ++k) {
          const Eigen::Vector3i g = fg.nodeCoords(regular.tets[std::size_t(t)][std::size_t(k)]) - base;
          tet[std::size_t(k)] = indexOf(localOf[lidx(g.x(), g.y(), g.z())]);
        }
        out.fine.tets.push_back(tet);
      }
    }
    out.cellTetStart[cell + 1] = int(out.fine.tets.size());
  }
  out.cellTets.resize(out.fine.tets.size());
  out.fineParent.resize(out.fine.tets.size());
  for (std::size_t cell = 0; cell < cells; ++cell)
    for (int k = out.cellTetStart[cell]; k < out.cellTetStart[cell + 1]; ++k) {
      out.cellTets[std::size_t(k)] = k;
      Eigen::Vector3d c = Eigen::Vector3d::Zero();
      for (int v : out.fine.tets[std::size_t(k)]) c += out.fine.nodes[std::size_t(v)] / 4.0;
      const int t = cg.locate(c);
      // The centroid is inside the cell; the coarse tet there (any tet of the cell serves cell elements).
      out.fineParent[std::size_t(k)] = (t >= 0 && std::size_t(t / 6) == cell) ? t : int(cell) * 6;
    }
  out.coarseNodeInFine.resize(out.coarse.nodes.size());
  for (std::size_t n = 0; n < out.coarse.nodes.size(); ++n) {
    const Eigen::Vector3i ijk = cg.nodeCoords(int(n)) * m;
    out.coarseNodeInFine[n] = shared[std::size_t(fg.nodeIndex(ijk.x(), ijk.y(), ijk.z()))];
    if (out.coarseNodeInFine[n] < 0) throw Error("meshing: a coarse node is missing from the adapted fine mesh");
  }
  reportProgress(progress, 1.0, "image-adapted fine mesh");
  if (stats) *stats = st;
  return out;
}

}  // namespace handson
