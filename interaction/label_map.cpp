#include "interaction/label_map.h"

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <sstream>

#include "sim/volume.h"
#include "sim/base/error.h"

namespace handson {

namespace {

std::string dimsText(const Eigen::Vector3i& d) {
  std::ostringstream s;
  s << d.x() << "x" << d.y() << "x" << d.z();
  return s.str();
}

/// Every value an integer in 0..65535, or the first that is not.
void checkIntegerLabels(const Volume& labels) {
  if (labels.type() == ScalarType::UInt8) return;
  for (std::size_t i = 0; i < labels.voxelCount(); ++i) {
    const float v = labels.value(i);
    if (!(v >= 0.0f && v <= 65535.0f && v == std::floor(v))) {
      const Eigen::Vector3i p = labels.geometry().voxelOf(i);
      std::ostringstream msg;
      msg << "the label map holds " << v << " at voxel (" << p.x() << ", " << p.y() << ", " << p.z()
          << "): labels must be whole numbers from 0 (background) to 65535";
      throw Error(msg.str());
    }
  }
}

}  // namespace

std::uint16_t LabelMap::at(const Eigen::Vector3i& v) const {
  const std::size_t nx = std::size_t(geometry.dims.x()), ny = std::size_t(geometry.dims.y());
  return labels[std::size_t(v.x()) + nx * (std::size_t(v.y()) + ny * std::size_t(v.z()))];
}

LabelMap labelsOnGrid(const Volume& labels, const VolumeGeometry& target) {
  target.validate();
  labels.geometry().validate();
  checkIntegerLabels(labels);
  checkAllocation(target.voxelCount(), target.voxelCount() * sizeof(std::uint16_t), "the label map on the image's grid");
  LabelMap m;
  m.geometry = target;
  m.labels.assign(target.voxelCount(), 0);
  std::size_t inside = 0, labelled = 0;
  if (labels.geometry().sameGrid(target)) {
    for (std::size_t i = 0; i < m.labels.size(); ++i) m.labels[i] = std::uint16_t(labels.value(i));
    inside = m.labels.size();
  } else {
    // Label index of target index (i, j, k): M [i j k 1]^T with M = worldToIndex(labels) *
    // indexToWorld(target) (4x4), stepped along each row.
    const Eigen::Matrix4d M = labels.geometry().worldToIndex() * target.indexToWorld();
    const Eigen::Vector3i& d = target.dims;
    const Eigen::Vector3i& ld = labels.geometry().dims;
    const Eigen::Vector3d di = M.block<3, 1>(0, 0);
    std::size_t o = 0;
    for (int k = 0; k < d.z(); ++k)
      for (int j = 0; j < d.y(); ++j) {
        Eigen::Vector3d p = M.block<3, 1>(0, 1) * j + M.block<3, 1>(0, 2) * k + M.block<3, 1>(0, 3);
        for (int i = 0; i < d.x(); ++i, ++o, p += di) {
          const Eigen::Vector3d r = (p.array() + 0.5).floor();
          if ((r.array() < 0.0).any() || r.x() >= ld.x() || r.y() >= ld.y() || r.z() >= ld.z()) continue;
          ++inside;
          m.labels[o] = std::uint16_t(labels.value(int(r.x()), int(r.y()), int(r.z())));
        }
      }
    m.resampled = true;
    std::ostringstream note;
    note << "the label map's grid (" << dimsText(ld) << ") is not the image's (" << dimsText(d)
         << "): resampled by nearest neighbour in physical space";
    if (inside < m.labels.size()) note << "; " << std::fixed << std::setprecision(1) << (100.0 * double(m.labels.size() - inside) / double(m.labels.size())) << " % of the image lies outside it";
    m.note = note.str();
  }
  if (inside == 0) throw Error("the label map does not overlap the image: none of the image's voxels lies inside it");
  for (std::uint16_t v : m.labels) labelled += v != 0;
  if (labelled == 0) throw Error("the label map holds no label inside the image (every voxel there is background, 0)");
  return m;
}

std::vector<std::uint32_t> labelComponent(const LabelMap& map, const Eigen::Vector3i& seed) {
  const VolumeGeometry& g = map.geometry;
  if (!g.contains(seed)) {
    std::ostringstream msg;
    msg << "the seed voxel (" << seed.x() << ", " << seed.y() << ", " << seed.z() << ") lies outside the volume (" << dimsText(g.dims) << ")";
    throw Error(msg.str());
  }
  const std::uint16_t label = map.at(seed);
  if (label == 0) throw Error("the seed lies on background (label 0): choose a point on a labelled organ");
  std::vector<std::uint8_t> seen(map.labels.size(), 0);
  const std::size_t nx = std::size_t(g.dims.x()), nxy = nx * std::size_t(g.dims.y());
  std::vector<std::size_t> queue{std::size_t(seed.x()) + nx * std::size_t(seed.y()) + nxy * std::size_t(seed.z())};
  seen[queue[0]] = 1;
  std::size_t count = 1;
  while (!queue.empty()) {
    const std::size_t v = queue.back();
    queue.pop_back();
    const Eigen::Vector3i p = g.voxelOf(v);
    const Eigen::Vector3i lo = (p - Eigen::Vector3i::Ones()).cwiseMax(Eigen::Vector3i::Zero());
    const Eigen::Vector3i hi = (p + Eigen::Vector3i::Ones()).cwiseMin(g.dims - Eigen::Vector3i::Ones());
    for (int k = lo.z(); k <= hi.z(); ++k)
      for (int j = lo.y(); j <= hi.y(); ++j)
        for (int i = lo.x(); i <= hi.x(); ++i) {
          const std::size_t n = std::size_t(i) + nx * std::size_t(j) + nxy * std::size_t(k);
          if (seen[n] || map.labels[n] != label) continue;
          seen[n] = 1;
          ++count;
          queue.push_back(n);
        }
  }
  std::vector<std::uint32_t> out;
  out.reserve(count);
  for (std::size_t i = 0; i < seen.size(); ++i)
    if (seen[i]) out.push_back(std::uint32_t(i));
  return out;
}

std::optional<Eigen::Vector3i> labelledVoxelBehind(const LabelMap& map, const Eigen::Vector3d& hitWorld, const Eigen::Vector3d& rayDirection,
                                                   double depthMm) {
  const double len = rayDirection.norm();
  if (!(len > 0.0) || !hitWorld.allFinite() || !std::isfinite(len) || !(depthMm >= 0.0) || !std::isfinite(depthMm)) return std::nullopt;
  const Eigen::Vector3d dir = rayDirection / len;
  const double step = 0.5 * map.geometry.spacing.minCoeff();
  const int samples = int(std::min(4096.0, std::floor(depthMm / step))) + 1;
  struct Seen {
    std::uint16_t label;
    int count;
    Eigen::Vector3i first;
  };
  std::vector<Seen> seen;
  for (int s = 0; s < samples; ++s) {
    const auto voxel = nearestVoxel(map.geometry, hitWorld + dir * (step * s));
    if (!voxel || map.at(*voxel) == 0) continue;
    const Eigen::Vector3i v = *voxel;
    auto it = std::find_if(seen.begin(), seen.end(), [&](const Seen& e) { return e.label == map.at(v); });
    if (it == seen.end()) seen.push_back({map.at(v), 1, v});
    else ++it->count;
  }
  if (seen.empty()) return std::nullopt;
  // max_element keeps the first of equal counts: the earliest label on the ray.
  return std::max_element(seen.begin(), seen.end(), [](const Seen& a, const Seen& b) { return a.count < b.count; })->first;
}

}  // namespace handson
