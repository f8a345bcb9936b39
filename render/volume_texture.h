#pragma once
// Per-brick value ranges of the GPU's volume (sim/quantized_volume.h) for empty-space skipping.
// Plain data, no Vulkan: the CPU references use the same numbers.
#include <cstdint>
#include <vector>

#include "sim/quantized_volume.h"

namespace handson {

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
