#include "skeleton.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <queue>
#include <unordered_map>

#include "sim/base/error.h"

namespace handson {

TissueMap::TissueMap(const Volume& image, const MaterialTable& table, const Eigen::Vector3d& lo, const Eigen::Vector3d& hi, double reachMm, bool useSkeleton)
    : image_(image), table_(table), toIndex_(image.geometry().worldToIndex()), useSkeleton_(useSkeleton) {
  if (!(reachMm >= 0) || !std::isfinite(reachMm)) throw Error("skeleton: the reach must be a finite length >= 0");
  if (!useSkeleton_ || image.empty()) return;
  const bool any = std::any_of(table.bands().begin(), table.bands().end(), [](const MaterialBand& b) { return b.skeleton == SkeletonRole::Yes; });
  if (!any) return;  // no seed band: nothing can be skeleton
  // The box in voxel indices: the index-space bounds of the grown world box's 8 corners.
  const Eigen::Vector3i dims = image.geometry().dims;
  Eigen::Vector3d ilo = Eigen::Vector3d::Constant(1e300), ihi = -ilo;
  for (int c = 0; c < 8; ++c) {
    const Eigen::Vector3d w((c & 1) ? hi.x() + reachMm : lo.x() - reachMm, (c & 2) ? hi.y() + reachMm : lo.y() - reachMm,
                            (c & 4) ? hi.z() + reachMm : lo.z() - reachMm);
    const Eigen::Vector3d i = (toIndex_ * w.homogeneous()).head<3>();
    ilo = ilo.cwiseMin(i);
    ihi = ihi.cwiseMax(i);
  }
  for (int a = 0; a < 3; ++a) {
    const int l = int(std::clamp(std::floor(ilo[a]), 0.0, double(dims[a] - 1)));
    const int h = int(std::clamp(std::ceil(ihi[a]), 0.0, double(dims[a] - 1)));
    boxLo_[a] = l;
    boxDims_[a] = h - l + 1;
  }
  checkAllocation(0, std::size_t(boxDims_.cast<long long>().prod()), "the skeleton mask");
  skeleton_.assign(std::size_t(boxDims_.cast<long long>().prod()), 0);
  grow(reachMm);
}

// Dijkstra from the "yes" voxels through "joined" ones, up to reachMm. The mask holds 1 for skeleton,
// and (while growing) 2 for a "joined" voxel not reached yet; distances are kept for the voxels
// touched only (a few per cent of the box).
void TissueMap::grow(double reachMm) {
  const Eigen::Vector3i& n = boxDims_;
  const Eigen::Vector3d sp = image_.geometry().spacing;
  auto linear = [&](int i, int j, int k) { return std::size_t(i) + std::size_t(n.x()) * (std::size_t(j) + std::size_t(n.y()) * std::size_t(k)); };
  using Item = std::pair<double, std::size_t>;
  std::priority_queue<Item, std::vector<Item>, std::greater<Item>> queue;
  std::unordered_map<std::size_t, double> dist;
  for (int k = 0; k < n.z(); ++k)
    for (int j = 0; j < n.y(); ++j)
      for (int i = 0; i < n.x(); ++i) {
        const float v = image_.value(boxLo_.x() + i, boxLo_.y() + j, boxLo_.z() + k);
        const SkeletonRole role = table_.band(table_.classify(v)).skeleton;
        const std::size_t l = linear(i, j, k);
        if (role == SkeletonRole::Yes) {
          skeleton_[l] = 1;
          queue.push({0.0, l});
          dist[l] = 0.0;
        } else if (role == SkeletonRole::Joined) {
          skeleton_[l] = 2;
        }
      }
  while (!queue.empty()) {
    const auto [d, l] = queue.top();
    queue.pop();
    if (d > dist[l]) continue;
    skeleton_[l] = 1;
    const int i = int(l % std::size_t(n.x())), j = int((l / std::size_t(n.x())) % std::size_t(n.y())), k = int(l / (std::size_t(n.x()) * std::size_t(n.y())));
    const int step[6][3] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
    for (const auto& s : step) {
      const int a = i + s[0], b = j + s[1], c = k + s[2];
      if (a < 0 || b < 0 || c < 0 || a >= n.x() || b >= n.y() || c >= n.z()) continue;
      const std::size_t m = linear(a, b, c);
      if (skeleton_[m] != 2) continue;
      const double nd = d + (s[0] ? sp.x() : s[1] ? sp.y() : sp.z());
      if (nd > reachMm) continue;
      auto it = dist.find(m);
      if (it != dist.end() && it->second <= nd) continue;
      dist[m] = nd;
      queue.push({nd, m});
    }
  }
  skeletonVoxels_ = 0;
  for (auto& s : skeleton_) {
    if (s == 2) s = 0;
    skeletonVoxels_ += s;
  }
}

long long TissueMap::boxIndex(const Eigen::Vector3d& p) const {
  if (skeleton_.empty()) return -1;
  const std::optional<Eigen::Vector3i> v = nearestVoxel(image_.geometry(), p);
  if (!v) return -1;
  const Eigen::Vector3i r = *v - boxLo_;
  if ((r.array() < 0).any() || (r.array() >= boxDims_.array()).any()) return -1;
  return (long long)r.x() + (long long)boxDims_.x() * ((long long)r.y() + (long long)boxDims_.y() * (long long)r.z());
}

bool TissueMap::skeletonAt(const Eigen::Vector3d& p) const {
  const long long l = boxIndex(p);
  return l >= 0 && skeleton_[std::size_t(l)] == 1;
}

int TissueMap::bandAt(const Eigen::Vector3d& p) const {
  const int b = table_.classify(image_.sampleLinear((toIndex_ * p.homogeneous()).head<3>()));
  if (!useSkeleton_ || table_.band(b).skeleton != SkeletonRole::Joined || b == 0 || skeletonAt(p)) return b;
  return b - 1;
}

}  // namespace handson
