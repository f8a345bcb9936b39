#pragma once
// The volume as the GPU sees it: values mapped linearly to 16-bit unsigned normalized integers over
// the volume's value window [lo, hi] (exact for int16 and uint8 data). The raymarch samples it, and
// region growing compares its integers, so the GPU passes and their CPU references see identical
// numbers.
#include <cstdint>
#include <vector>

#include "volume.h"

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

}  // namespace handson
