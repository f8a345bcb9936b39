// Graded cell elements (CoarseGrading; docs/simulation-model.md, "Graded cells"): coarse cells near
// the handles split into 8 half-size cells, the hanging nodes tied to the whole cells' faces.
//
// Why this conforms: a whole cell's face is interpolated piecewise linearly on the two triangles of
// its Kuhn diagonal; a half-size cell on that face is Kuhn-split the same way (its diagonal parallel
// to the whole cell's, and on it for the two quarters the diagonal crosses), so its face function,
// linear on each of its own triangles and equal to the whole cell's at its corners (the hanging
// nodes' weights are the whole cell's Kuhn weights there), is the whole cell's function on that
// quarter. Fine nodes on such a face therefore get the same position from both sides.
#include <unordered_map>

#include "sim/coarsening.h"
#include "sim/base/error.h"

namespace handson {

void CoarseModel::buildGradedLeaves(const CoarseGrading& grading, std::vector<std::vector<int>>& tetsOf) {
  const KuhnGrid& CG = meshes_.coarseGrid;
  const KuhnGrid& FG = meshes_.fineGrid;
  const int m = meshes_.refinement;
  if (kind_ != CoarseElement::Cell) throw Error("coarsening: graded cells need cell elements");
  if (!meshes_.regularFine || m < 2 || m % 2 != 0 || FG.cells() != CG.cells() * m)
    throw Error("coarsening: graded cells need the regular fine mesh with an even number of fine cells per coarse cell (got " +
                std::to_string(m) + ")");
  if (!std::isfinite(grading.splitWithinCells)) throw Error("coarsening: the graded split distance is not finite");
  graded_ = true;
  const Eigen::Vector3i C = CG.cells();
  const TetMesh& F = meshes_.fine;
  // Cells whose box, widened by the split distance, holds a handle node or a sliding interface's
  // node (so none of these is a hanging node: a slide node follows its handle's surface normally).
  std::vector<char> split(CG.cellCount(), 0);
  std::vector<char> near(F.nodes.size(), 0);
  for (std::size_t n = 0; n < F.nodes.size(); ++n) near[n] = constraints_.handleOf[n] >= 0;
  for (const SlideNode& s : constraints_.slide) near[std::size_t(s.node)] = 1;
  const double reach = grading.splitWithinCells * CG.cell().maxCoeff();
  for (std::size_t n = 0; n < F.nodes.size(); ++n) {
    if (!near[n]) continue;
    const Eigen::Vector3d p = F.nodes[n] - CG.origin();
    Eigen::Vector3i lo, hi;
    for (int a = 0; a < 3; ++a) {
      lo[a] = std::max(0, int(std::floor((p[a] - reach) / CG.cell()[a] - 1e-9)));
      hi[a] = std::min(C[a] - 1, int(std::floor((p[a] + reach) / CG.cell()[a] + 1e-9)));
    }
    for (int k = lo.z(); k <= hi.z(); ++k)
      for (int j = lo.y(); j <= hi.y(); ++j)
        for (int i = lo.x(); i <= hi.x(); ++i) split[std::size_t(i + C.x() * (j + C.y() * k))] = 1;
  }
  // Leaves in cell order; a lattice point (fine grid coordinates) is a coarse mesh node when it is
  // on the coarse grid, an added node otherwise.
  std::unordered_map<int, int> added;
  auto nodeAt = [&](const Eigen::Vector3i& g) {
    if (g.x() % m == 0 && g.y() % m == 0 && g.z() % m == 0) return CG.nodeIndex(g.x() / m, g.y() / m, g.z() / m);
    const int f = FG.nodeIndex(g.x(), g.y(), g.z());
    const auto [it, fresh] = added.emplace(f, int(nodes_.size()));
    if (fresh) {
      nodes_.push_back(F.nodes[std::size_t(f)]);
      nodeFine_.push_back(f);
    }
    return it->second;
  };
  auto addLeaf = [&](const Eigen::Vector3i& lo, int size) {
    Leaf L{lo, size, {}};
    for (int q = 0; q < 8; ++q) L.node[std::size_t(q)] = nodeAt(lo + size * Eigen::Vector3i(q & 1, q >> 1 & 1, q >> 2 & 1));
    leaves_.push_back(L);
  };
  const int h = m / 2;
  for (int c = 0; c < int(CG.cellCount()); ++c) {
    const Eigen::Vector3i lo = m * Eigen::Vector3i(c % C.x(), (c / C.x()) % C.y(), c / (C.x() * C.y()));
    if (!split[std::size_t(c)]) addLeaf(lo, m);
    else
      for (int q = 0; q < 8; ++q) addLeaf(lo + h * Eigen::Vector3i(q & 1, q >> 1 & 1, q >> 2 & 1), h);
  }
  // Each leaf's fine tets (fine cell c holds tets 6c .. 6c+5).
  const Eigen::Vector3i FC = FG.cells();
  tetsOf.assign(leaves_.size(), {});
  leafOfFineTet_.assign(F.tets.size(), -1);
  for (std::size_t e = 0; e < leaves_.size(); ++e) {
    const Leaf& L = leaves_[e];
    for (int k = 0; k < L.size; ++k)
      for (int j = 0; j < L.size; ++j)
        for (int i = 0; i < L.size; ++i) {
          const int cell = (L.lo.x() + i) + FC.x() * ((L.lo.y() + j) + FC.y() * (L.lo.z() + k));
          for (int t = 0; t < 6; ++t) {
            tetsOf[e].push_back(6 * cell + t);
            leafOfFineTet_[std::size_t(6 * cell + t)] = int(e);
          }
        }
  }
  // Hanging nodes: added nodes on a whole cell's faces or edges (the lattice points at half its size
  // that are not its corners), unless held (fixed or a handle's: those keep their own positions).
  hang_.assign(nodes_.size(), {});
  for (int c = 0; c < int(CG.cellCount()); ++c) {
    if (split[std::size_t(c)]) continue;
    const Eigen::Vector3i lo = m * Eigen::Vector3i(c % C.x(), (c / C.x()) % C.y(), c / (C.x() * C.y()));
    const auto corners = CG.cellNodes(c);
    for (int q = 0; q < 27; ++q) {
      const Eigen::Vector3i a(q % 3, q / 3 % 3, q / 9);
      if ((a.array() != 1).all() || (a.array() == 1).all()) continue;  // a corner, or the centre
      const auto it = added.find(FG.nodeIndex(lo.x() + h * a.x(), lo.y() + h * a.y(), lo.z() + h * a.z()));
      if (it == added.end()) continue;
      const auto v = std::size_t(it->second);
      const auto f = std::size_t(nodeFine_[v]);
      if (constraints_.fixed[f] || constraints_.handleOf[f] >= 0 || !hang_[v].empty()) continue;
      const Eigen::Matrix<double, 8, 1> w = CG.cellWeights(c, nodes_[v]);
      for (int k = 0; k < 8; ++k)
        if (w[k] > 1e-12) hang_[v].push_back({corners[std::size_t(k)], w[k]});
      hangingNodes_.push_back(int(v));
    }
  }
}

Eigen::Matrix<double, 8, 1> CoarseModel::elementWeights(int e, const Eigen::Vector3d& p, bool* onBoundary) const {
  if (!graded_) return meshes_.coarseGrid.cellWeights(cut_ ? cut_->cell[std::size_t(e)] : e, p, onBoundary);
  const Leaf& L = leaves_[std::size_t(e)];
  const KuhnGrid& FG = meshes_.fineGrid;
  const KuhnGrid cube(FG.nodePosition(FG.nodeIndex(L.lo.x(), L.lo.y(), L.lo.z())), FG.cell() * double(L.size), Eigen::Vector3i::Ones());
  return cube.cellWeights(0, p, onBoundary);
}

void CoarseModel::expandHanging(std::vector<Eigen::Vector3d>& x) const {
  for (const int v : hangingNodes_) {
    Eigen::Vector3d p = Eigen::Vector3d::Zero();
    for (const auto& [m, w] : hang_[std::size_t(v)]) p += w * x[std::size_t(m)];
    x[std::size_t(v)] = p;
  }
}

SparseMatrix CoarseModel::warpedStiffness(const std::vector<Eigen::Matrix3d>* R) const {
  // Corner c of an element maps to the free dofs {(d, w)}: itself, or a hanging node's free masters.
  std::vector<std::pair<int, double>> da, db;
  auto dofsOf = [&](int v, std::vector<std::pair<int, double>>& out) {
    out.clear();
    if (dof_[std::size_t(v)] >= 0) out.push_back({dof_[std::size_t(v)], 1.0});
    else if (graded_)
      for (const auto& [m, w] : hang_[std::size_t(v)])
        if (dof_[std::size_t(m)] >= 0) out.push_back({dof_[std::size_t(m)], w});
  };
  std::vector<Eigen::Triplet<double>> triplets;
  Eigen::MatrixXd K;
  for (std::size_t e = 0; e < elements_.size(); ++e) {
    const Element& el = elements_[e];
    K = el.Kh;
    if (R)
      for (int a = 0; a < nc_; ++a)
        for (int b = 0; b < nc_; ++b) K.block<3, 3>(3 * a, 3 * b) = (*R)[e] * el.Kh.block<3, 3>(3 * a, 3 * b) * (*R)[e].transpose();
    for (int a = 0; a < nc_; ++a) {
      dofsOf(el.node[std::size_t(a)], da);
      for (int b = 0; b < nc_; ++b) {
        dofsOf(el.node[std::size_t(b)], db);
        for (const auto& [i, wi] : da)
          for (const auto& [j, wj] : db)
            for (int r = 0; r < 3; ++r)
              for (int c = 0; c < 3; ++c) triplets.emplace_back(i + r, j + c, wi * wj * K(3 * a + r, 3 * b + c));
      }
    }
  }
  SparseMatrix A(dofCount_, dofCount_);
  A.setFromTriplets(triplets.begin(), triplets.end());
  return A;
}

}  // namespace handson
