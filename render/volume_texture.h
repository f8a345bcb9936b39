#pragma once
// The volume as the GPU sees it: values mapped linearly to 16-bit unsigned normalized integers over
// the volume's value window [lo, hi] (exact for int16 and uint8 data), plus per-brick value ranges
// for empty-space skipping. Plain data, no Vulkan: the CPU references use the same numbers.
#include <cstdint>
#include <vector>

#include "sim/volume.h"

namespace handson {

struct QuantizedVolume {
  VolumeGeometry geometry;
  float lo = 0.0f, hi = 1.0f;       ///< value window: u16 0 -> lo, 65535 -> hi
  std::vector<std::uint16_t> data;  ///< x-fastest, like Volume

  float toValue(float normalized) const { return lo + normalized * (hi - lo); }
  float toNormalized(float value) const { return (value - lo) / (hi - lo); }
  /// Value at the p-th percentile (0..1), from a 4096-bin histogram.
  float percentile(double p) const;
};

/// Quantizes a volume over its own value range (a constant volume gets a unit window).
QuantizedVolume quantizeVolume(const Volume& volume);

/// Per-brick min/max of the u16 values over the brick and a one-voxel apron (see shaders/shared.h).
struct BrickGrid {
  int bx = 0, by = 0, bz = 0;
  std::vector<std::uint32_t> ranges;  ///< 2 per brick: min, max
  std::size_t count() const { return std::size_t(bx) * by * bz; }
};

/// CPU reference of shaders/brick_minmax.comp.
BrickGrid computeBrickGrid(const QuantizedVolume& volume);
/// Brick extents for a volume's dims.
void brickDims(const Eigen::Vector3i& dims, int& bx, int& by, int& bz);

/// 1 for bricks where the transfer function can give a non-zero opacity, else 0. The lookup table
/// interpolates linearly, so a brick's range covers entries floor(min) .. ceil(max).
std::vector<std::uint32_t> brickOccupancy(const BrickGrid& grid, const std::vector<float>& lutAlpha);

}  // namespace handson
