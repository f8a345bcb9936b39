#include "tet_mesh.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>

#include "sim/base/error.h"

namespace handson {

namespace {
// The six permutations of the axes, in a fixed order; tet p of a cell follows kPerm[p].
constexpr int kPerm[6][3] = {{0, 1, 2}, {0, 2, 1}, {1, 0, 2}, {1, 2, 0}, {2, 0, 1}, {2, 1, 0}};

int permIndex(int a, int b) {
  for (int p = 0; p < 6; ++p)
    if (kPerm[p][0] == a && kPerm[p][1] == b) return p;
  return 0;
}
}  // namespace

double TetMesh::signedVolume(int t) const {
  const auto& v = tets[std::size_t(t)];
  const Eigen::Vector3d& x0 = nodes[std::size_t(v[0])];
  Eigen::Matrix3d d;
  d << nodes[std::size_t(v[1])] - x0, nodes[std::size_t(v[2])] - x0, nodes[std::size_t(v[3])] - x0;
  return d.determinant() / 6.0;
}

KuhnGrid::KuhnGrid(const Eigen::Vector3d& origin, const Eigen::Vector3d& cell, const Eigen::Vector3i& cells)
    : origin_(origin), cell_(cell), cells_(cells) {
  if (!origin.allFinite() || !cell.allFinite() || (cell.array() <= 0).any()) throw Error("tet grid: cell size must be positive and finite");
  if ((cells.array() < 1).any()) throw Error("tet grid: at least one cell along each axis");
  if (double(cells.x() + 1) * double(cells.y() + 1) * double(cells.z() + 1) > 2e8) throw Error("tet grid: more than 2e8 nodes requested");
}

KuhnGrid KuhnGrid::refined(int m) const {
  if (m < 1 || m > 64) throw Error("tet grid: refinement must be 1..64");
  return KuhnGrid(origin_, cell_ / double(m), cells_ * m);
}

std::size_t KuhnGrid::nodeCount() const { return std::size_t(cells_.x() + 1) * std::size_t(cells_.y() + 1) * std::size_t(cells_.z() + 1); }

Eigen::Vector3i KuhnGrid::nodeCoords(int n) const {
  const int nx = cells_.x() + 1, ny = cells_.y() + 1;
  return {n % nx, (n / nx) % ny, n / (nx * ny)};
}

Eigen::Vector3d KuhnGrid::nodePosition(int n) const { return origin_ + cell_.cwiseProduct(nodeCoords(n).cast<double>()); }

TetMesh KuhnGrid::mesh() const {
  TetMesh m;
  m.nodes.resize(nodeCount());
  for (std::size_t n = 0; n < m.nodes.size(); ++n) m.nodes[n] = nodePosition(int(n));
  m.tets.reserve(tetCount());
  for (int k = 0; k < cells_.z(); ++k)
    for (int j = 0; j < cells_.y(); ++j)
      for (int i = 0; i < cells_.x(); ++i)
        for (const auto& perm : kPerm) {
          Eigen::Vector3i c(i, j, k);
          std::array<int, 4> t{};
          t[0] = nodeIndex(c.x(), c.y(), c.z());
          for (int s = 0; s < 3; ++s) {
            c[perm[s]] += 1;
            t[std::size_t(s + 1)] = nodeIndex(c.x(), c.y(), c.z());
          }
          m.tets.push_back(t);
        }
  return m;
}

std::array<int, 8> KuhnGrid::cellNodes(int c) const {
  const int i = c % cells_.x(), j = (c / cells_.x()) % cells_.y(), k = c / (cells_.x() * cells_.y());
  std::array<int, 8> n{};
  for (int q = 0; q < 8; ++q) n[std::size_t(q)] = nodeIndex(i + (q & 1), j + ((q >> 1) & 1), k + ((q >> 2) & 1));
  return n;
}

Eigen::Matrix<double, 8, 1> KuhnGrid::cellWeights(int c, const Eigen::Vector3d& p, bool* onBoundary) const {
  const Eigen::Vector3i ijk(c % cells_.x(), (c / cells_.x()) % cells_.y(), c / (cells_.x() * cells_.y()));
  Eigen::Vector3d f = (p - origin_).cwiseQuotient(cell_) - ijk.cast<double>();
  const double eps = 1e-9;
  if (onBoundary) *onBoundary = (f.array() < eps).any() || (f.array() > 1.0 - eps).any();
  f = f.cwiseMax(0.0).cwiseMin(1.0);
  int ord[3] = {0, 1, 2};
  std::stable_sort(ord, ord + 3, [&](int a, int b) { return f[a] > f[b]; });
  // The Kuhn tet of the order: corners 0, e_o0, e_o0 + e_o1, 7.
  Eigen::Matrix<double, 8, 1> w = Eigen::Matrix<double, 8, 1>::Zero();
  const int q1 = 1 << ord[0], q2 = q1 | (1 << ord[1]);
  w[0] += 1.0 - f[ord[0]];
  w[q1] += f[ord[0]] - f[ord[1]];
  w[q2] += f[ord[1]] - f[ord[2]];
  w[7] += f[ord[2]];
  return w;
}

int KuhnGrid::locate(const Eigen::Vector3d& p, Eigen::Vector4d* bary) const {
  const Eigen::Vector3d u = (p - origin_).cwiseQuotient(cell_);
  if (!u.allFinite()) return -1;
  const double eps = 1e-9;
  if ((u.array() < -eps).any() || (u.array() > cells_.cast<double>().array() + eps).any()) return -1;
  Eigen::Vector3i c;
  Eigen::Vector3d f;
  for (int a = 0; a < 3; ++a) {
    c[a] = std::clamp(int(std::floor(u[a])), 0, cells_[a] - 1);
    f[a] = std::clamp(u[a] - c[a], 0.0, 1.0);
  }
  int ord[3] = {0, 1, 2};
  std::stable_sort(ord, ord + 3, [&](int a, int b) { return f[a] > f[b]; });
  const int p6 = permIndex(ord[0], ord[1]);
  if (bary) *bary = Eigen::Vector4d(1.0 - f[ord[0]], f[ord[0]] - f[ord[1]], f[ord[1]] - f[ord[2]], f[ord[2]]);
  return ((c.z() * cells_.y() + c.y()) * cells_.x() + c.x()) * 6 + p6;
}

int NestedMeshes::locateFine(const Eigen::Vector3d& p) const {
  if (regularFine) return fineGrid.locate(p);
  const int t = coarseGrid.locate(p);
  if (t < 0) return -1;
  const int cell = t / 6;
  int best = -1;
  double bestMin = -1e300;
  for (int k = cellTetStart[std::size_t(cell)]; k < cellTetStart[std::size_t(cell) + 1]; ++k) {
    const auto& v = fine.tets[std::size_t(cellTets[std::size_t(k)])];
    Eigen::Matrix3d D;
    D << fine.nodes[std::size_t(v[1])] - fine.nodes[std::size_t(v[0])], fine.nodes[std::size_t(v[2])] - fine.nodes[std::size_t(v[0])],
        fine.nodes[std::size_t(v[3])] - fine.nodes[std::size_t(v[0])];
    const Eigen::Vector3d l = D.inverse() * (p - fine.nodes[std::size_t(v[0])]);
    const double m = std::min({1.0 - l.sum(), l.x(), l.y(), l.z()});
    if (m >= 0) return cellTets[std::size_t(k)];
    if (m > bestMin) {
      bestMin = m;
      best = cellTets[std::size_t(k)];
    }
  }
  // On the cell's boundary within roundoff: the nearest tet by barycentric margin.
  return bestMin > -1e-9 ? best : -1;
}

KuhnGrid coarseGridFor(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi, int coarseTets) {
  if (!lo.allFinite() || !hi.allFinite() || ((hi - lo).array() <= 0).any()) throw Error("meshing: the region is empty");
  if (coarseTets < 6 || coarseTets > 10000000) throw Error("meshing: coarse tet count must be 6..1e7");
  const Eigen::Vector3d size = hi - lo;
  // Cubic cells: 6 * prod(ceil(size / h)) ~ coarseTets.
  double h = std::cbrt(size.prod() * 6.0 / coarseTets);
  Eigen::Vector3i cells;
  for (int it = 0; it < 60; ++it) {
    for (int a = 0; a < 3; ++a) cells[a] = std::max(1, int(std::lround(size[a] / h)));
    const double count = 6.0 * cells.cast<double>().prod();
    if (std::abs(count - coarseTets) <= 0.15 * coarseTets) break;
    h *= std::cbrt(count / coarseTets);
  }
  return KuhnGrid(lo, size.cwiseQuotient(cells.cast<double>()), cells);
}

NestedMeshes buildNestedMeshes(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi, int coarseTets, int finePerCoarse) {
  if (finePerCoarse < 1 || finePerCoarse > 100000) throw Error("meshing: fine tets per coarse tet must be 1..1e5");
  NestedMeshes out;
  out.coarseGrid = coarseGridFor(lo, hi, coarseTets);
  out.refinement = std::max(1, int(std::lround(std::cbrt(double(finePerCoarse)))));
  out.fineGrid = out.coarseGrid.refined(out.refinement);
  out.coarse = out.coarseGrid.mesh();
  out.fine = out.fineGrid.mesh();
  out.fineParent.resize(out.fine.tets.size());
  for (std::size_t t = 0; t < out.fine.tets.size(); ++t) {
    Eigen::Vector3d c = Eigen::Vector3d::Zero();
    for (int v : out.fine.tets[t]) c += out.fine.nodes[std::size_t(v)];
    out.fineParent[t] = out.coarseGrid.locate(c / 4.0);
  }
  const int m = out.refinement;
  out.coarseNodeInFine.resize(out.coarse.nodes.size());
  for (std::size_t n = 0; n < out.coarse.nodes.size(); ++n) {
    const Eigen::Vector3i ijk = out.coarseGrid.nodeCoords(int(n)) * m;
    out.coarseNodeInFine[n] = out.fineGrid.nodeIndex(ijk.x(), ijk.y(), ijk.z());
  }
  return out;
}

}  // namespace handson
