#include "region_shape.h"

#include <algorithm>
#include <cmath>
#include <unordered_map>

#include "sim/base/error.h"

namespace handson {

namespace {
std::int64_t bucketKey(const Eigen::Vector3i& b) {
  // 21 bits an axis: buckets within +-1e6 of the origin (+-1 km at 1 mm).
  auto u = [](int v) { return std::int64_t(v + (1 << 20)) & ((std::int64_t(1) << 21) - 1); };
  return (u(b.x()) << 42) | (u(b.y()) << 21) | u(b.z());
}

// The cells of `grid` whose boxes overlap [lo, hi], as an index range per axis (empty: lo > hi).
void cellRange(const KuhnGrid& grid, const Eigen::Vector3d& lo, const Eigen::Vector3d& hi, Eigen::Vector3i& a, Eigen::Vector3i& b) {
  for (int k = 0; k < 3; ++k) {
    a[k] = std::max(0, int(std::floor((lo[k] - grid.origin()[k]) / grid.cell()[k])));
    b[k] = std::min(grid.cells()[k] - 1, int(std::floor((hi[k] - grid.origin()[k]) / grid.cell()[k])));
  }
}

double boxDistance2(const KuhnGrid& grid, const Eigen::Vector3i& c, const Eigen::Vector3d& p) {
  const Eigen::Vector3d lo = grid.origin() + grid.cell().cwiseProduct(c.cast<double>()), hi = lo + grid.cell();
  return (p - p.cwiseMax(lo).cwiseMin(hi)).squaredNorm();
}
}  // namespace

HandlePoints thinHandlePoints(const std::vector<Eigen::Vector3d>& voxelCentres, double bucketMm) {
  if (!(bucketMm > 0) || !std::isfinite(bucketMm)) throw Error("region: the bucket size must be positive");
  HandlePoints out;
  out.bucketMm = bucketMm;
  std::unordered_map<std::int64_t, int> first;
  std::vector<Eigen::Vector3i> bucket;
  for (const auto& p : voxelCentres) {
    if (!p.allFinite()) throw Error("region: a handle point is not finite");
    const Eigen::Vector3i b = (p / bucketMm).array().floor().cast<int>();
    if (first.emplace(bucketKey(b), int(out.point.size())).second) {
      out.point.push_back(p);
      bucket.push_back(b);
    }
  }
  out.surface.assign(out.point.size(), 0);
  static const int kNeighbour[6][3] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
  for (std::size_t i = 0; i < bucket.size(); ++i)
    for (const auto& d : kNeighbour)
      if (!first.count(bucketKey(bucket[i] + Eigen::Vector3i(d[0], d[1], d[2])))) out.surface[i] = 1;
  return out;
}

std::vector<char> cellsNearPoints(const KuhnGrid& grid, const HandlePoints& points, double padding) {
  if (!(padding >= 0) || !std::isfinite(padding)) throw Error("region: the padding must be a finite length >= 0");
  std::vector<char> in(grid.cellCount(), 0);
  const Eigen::Vector3i n = grid.cells();
  auto index = [&](const Eigen::Vector3i& c) { return std::size_t(c.x() + n.x() * (c.y() + n.y() * c.z())); };
  const double pad2 = padding * padding;
  const Eigen::Vector3d r = Eigen::Vector3d::Constant(padding);
  for (std::size_t i = 0; i < points.point.size(); ++i) {
    const Eigen::Vector3d& p = points.point[i];
    // The cell holding the point (a point on the grid's upper faces in the last cell, as locate()).
    const Eigen::Vector3d u = (p - grid.origin()).cwiseQuotient(grid.cell());
    if ((u.array() >= -1e-9).all() && (u.array() <= n.cast<double>().array() + 1e-9).all()) {
      Eigen::Vector3i c;
      for (int k = 0; k < 3; ++k) c[k] = std::clamp(int(std::floor(u[k])), 0, n[k] - 1);
      in[index(c)] = 1;
    }
    Eigen::Vector3i a, b;
    if (!points.surface[i]) continue;
    cellRange(grid, p - r, p + r, a, b);
    for (int z = a.z(); z <= b.z(); ++z)
      for (int y = a.y(); y <= b.y(); ++y)
        for (int x = a.x(); x <= b.x(); ++x) {
          const Eigen::Vector3i c(x, y, z);
          char& flag = in[index(c)];
          if (!flag && boxDistance2(grid, c, p) <= pad2) flag = 1;
        }
  }
  return in;
}

void markCellNeighbours(const KuhnGrid& grid, const std::vector<char>& seed, std::vector<char>& in) {
  const Eigen::Vector3i n = grid.cells();
  if (seed.size() != grid.cellCount() || in.size() != grid.cellCount()) throw Error("region: one flag per cell needed");
  for (int z = 0; z < n.z(); ++z)
    for (int y = 0; y < n.y(); ++y)
      for (int x = 0; x < n.x(); ++x) {
        if (!seed[std::size_t(x + n.x() * (y + n.y() * z))]) continue;
        for (int dz = std::max(0, z - 1); dz <= std::min(n.z() - 1, z + 1); ++dz)
          for (int dy = std::max(0, y - 1); dy <= std::min(n.y() - 1, y + 1); ++dy)
            for (int dx = std::max(0, x - 1); dx <= std::min(n.x() - 1, x + 1); ++dx) in[std::size_t(dx + n.x() * (dy + n.y() * dz))] = 1;
      }
}

bool outlineNearRegionBoundary(const KuhnGrid& grid, const std::vector<char>& inRegion, const std::vector<Eigen::Vector3d>& outline,
                               const Eigen::Matrix3d& R, const Eigen::Vector3d& t, double margin) {
  for (const Eigen::Vector3d& p : outline)
    if (nearRegionBoundary(grid, inRegion, R * p + t, margin)) return true;
  return false;
}

bool nearRegionBoundary(const KuhnGrid& grid, const std::vector<char>& inRegion, const Eigen::Vector3d& p, double margin) {
  if (inRegion.size() != grid.cellCount()) return false;  // no shaped region: the box alone
  const Eigen::Vector3i n = grid.cells();
  const Eigen::Vector3d r = Eigen::Vector3d::Constant(std::max(0.0, margin));
  Eigen::Vector3i a, b;
  cellRange(grid, p - r, p + r, a, b);
  for (int z = a.z(); z <= b.z(); ++z)
    for (int y = a.y(); y <= b.y(); ++y)
      for (int x = a.x(); x <= b.x(); ++x) {
        const Eigen::Vector3i c(x, y, z);
        if (!inRegion[std::size_t(x + n.x() * (y + n.y() * z))] && boxDistance2(grid, c, p) <= margin * margin) return true;
      }
  return false;
}

}  // namespace handson
