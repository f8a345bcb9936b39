// The selection's boundary rim (interaction/region_grow.h: withBoundaryRim; docs/region-growing.md).
#include <algorithm>
#include <cmath>
#include <iterator>
#include <string>

#include "interaction/region_grow.h"
#include "sim/base/error.h"

namespace handson {

std::vector<std::uint32_t> withBoundaryRim(const RegionGrower& grower, const std::vector<std::uint32_t>& voxels) {
  return withBoundaryRim(BoundaryRimRule(grower), voxels);
}

std::vector<std::uint32_t> withBoundaryRim(const BoundaryRimRule& grower, const std::vector<std::uint32_t>& voxels) {
  const QuantizedVolume& volume = *grower.volume;
  const GrowSetup& setup = grower.setup;
  const Eigen::Vector3i d = volume.geometry.dims;
  const std::size_t n = volume.data.size();
  if (n != std::size_t(d.x()) * std::size_t(d.y()) * std::size_t(d.z())) throw Error("boundary rim: the volume's data does not fit its grid");
  // The selection's mean per voxel: the seed statistics are one voxel's value (paper) or a 3x3x3 sum.
  const double mean = setup.criterion == GrowCriterion::Paper ? double(setup.seedValue) : double(setup.seedValue) / 27.0;
  if (!std::is_sorted(voxels.begin(), voxels.end())) throw Error("boundary rim: the voxels must be in ascending order");
  std::vector<bool> in(n, false);
  for (std::uint32_t v : voxels) {
    if (v >= n) throw Error("boundary rim: voxel " + std::to_string(v) + " lies outside the volume");
    in[v] = true;
  }
  const std::ptrdiff_t stride[3] = {1, std::ptrdiff_t(d.x()), std::ptrdiff_t(d.x()) * d.y()};
  std::vector<std::uint32_t> rim;
  for (std::uint32_t v : voxels) {
    const int p[3] = {int(v % std::uint32_t(d.x())), int(v / std::uint32_t(d.x()) % std::uint32_t(d.y())),
                      int(v / (std::uint32_t(d.x()) * std::uint32_t(d.y())))};
    for (int axis = 0; axis < 3; ++axis)
      for (int dir = -1; dir <= 1; dir += 2) {
        // The candidate one step out, and the voxel one step beyond it.
        const int beyond = p[axis] + 2 * dir;
        if (beyond < 0 || beyond >= d[axis]) continue;
        const std::size_t c = std::size_t(std::ptrdiff_t(v) + dir * stride[axis]);
        if (in[c] || grower.accepts(c)) continue;
        const double x = volume.data[c], out = volume.data[std::size_t(std::ptrdiff_t(c) + dir * stride[axis])];
        if (std::abs(x - mean) < std::abs(x - out)) rim.push_back(std::uint32_t(c));
      }
  }
  std::sort(rim.begin(), rim.end());
  rim.erase(std::unique(rim.begin(), rim.end()), rim.end());
  std::vector<std::uint32_t> out;
  out.reserve(voxels.size() + rim.size());
  std::merge(voxels.begin(), voxels.end(), rim.begin(), rim.end(), std::back_inserter(out));
  return out;
}

}  // namespace handson
