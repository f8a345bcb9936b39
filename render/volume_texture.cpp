#include "volume_texture.h"

#include <algorithm>
#include <cmath>

#include "shaders/shared.h"
#include "sim/base/error.h"

namespace handson {

void brickDims(const Eigen::Vector3i& dims, int& bx, int& by, int& bz) {
  const int b = int(gpu::kBrickSize);
  bx = (dims.x() + b - 1) / b;
  by = (dims.y() + b - 1) / b;
  bz = (dims.z() + b - 1) / b;
}

BrickGrid computeBrickGrid(const QuantizedVolume& volume) {
  BrickGrid g;
  const Eigen::Vector3i d = volume.geometry.dims;
  brickDims(d, g.bx, g.by, g.bz);
  g.ranges.assign(2 * g.count(), 0);
  const int b = int(gpu::kBrickSize);
  for (int z = 0; z < g.bz; ++z)
    for (int y = 0; y < g.by; ++y)
      for (int x = 0; x < g.bx; ++x) {
        const int x0 = std::max(x * b - 1, 0), x1 = std::min(x * b + b, d.x() - 1);
        const int y0 = std::max(y * b - 1, 0), y1 = std::min(y * b + b, d.y() - 1);
        const int z0 = std::max(z * b - 1, 0), z1 = std::min(z * b + b, d.z() - 1);
        std::uint32_t mn = 65535, mx = 0;
        for (int k = z0; k <= z1; ++k)
          for (int j = y0; j <= y1; ++j) {
            const std::uint16_t* row = volume.data.data() + std::size_t(d.x()) * (std::size_t(j) + std::size_t(d.y()) * k);
            for (int i = x0; i <= x1; ++i) {
              mn = std::min<std::uint32_t>(mn, row[i]);
              mx = std::max<std::uint32_t>(mx, row[i]);
            }
          }
        const std::size_t id = (std::size_t(z) * g.by + y) * g.bx + x;
        g.ranges[2 * id] = mn;
        g.ranges[2 * id + 1] = mx;
      }
  return g;
}

std::vector<std::uint32_t> brickOccupancy(const BrickGrid& grid, const std::vector<float>& lutAlpha) {
  const std::size_t n = lutAlpha.size();
  if (n < 2) throw Error("transfer function lookup table is too small");
  // prefix[i] = number of entries with non-zero opacity among the first i.
  std::vector<std::uint32_t> prefix(n + 1, 0);
  for (std::size_t i = 0; i < n; ++i) prefix[i + 1] = prefix[i] + (lutAlpha[i] > 0.0f ? 1u : 0u);
  std::vector<std::uint32_t> occ(grid.count(), 0);
  for (std::size_t b = 0; b < grid.count(); ++b) {
    const double lo = grid.ranges[2 * b] / 65535.0 * double(n - 1);
    const double hi = grid.ranges[2 * b + 1] / 65535.0 * double(n - 1);
    const std::size_t i0 = std::size_t(std::max(0.0, std::floor(lo)));
    const std::size_t i1 = std::min(n - 1, std::size_t(std::ceil(hi)));
    occ[b] = prefix[i1 + 1] - prefix[i0] > 0 ? 1u : 0u;
  }
  return occ;
}

}  // namespace handson
