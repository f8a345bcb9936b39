#include "quantized_volume.h"

#include <algorithm>
#include <cmath>

#include "sim/base/error.h"

namespace handson {

QuantizedVolume quantizeVolume(const Volume& volume) {
  if (volume.empty()) throw Error("cannot display an empty volume");
  QuantizedVolume q;
  q.geometry = volume.geometry();
  auto [lo, hi] = volume.valueRange();
  if (!(hi > lo)) hi = lo + 1.0f;
  q.lo = lo;
  q.hi = hi;
  const std::size_t n = volume.voxelCount();
  q.data.resize(n);
  const double scale = 65535.0 / (double(hi) - double(lo));
  for (std::size_t i = 0; i < n; ++i) {
    const float v = volume.value(i);
    const double u = std::isnan(v) ? 0.0 : (double(v) - lo) * scale;
    q.data[i] = static_cast<std::uint16_t>(std::clamp(std::nearbyint(u), 0.0, 65535.0));
  }
  return q;
}

float QuantizedVolume::percentile(double p) const {
  constexpr int kBins = 4096;
  std::vector<std::uint64_t> hist(kBins, 0);
  for (std::uint16_t v : data) ++hist[v >> 4];
  const double target = std::clamp(p, 0.0, 1.0) * double(data.size());
  std::uint64_t acc = 0;
  for (int b = 0; b < kBins; ++b) {
    acc += hist[b];
    if (double(acc) >= target) return toValue((float(b) + 0.5f) / kBins);
  }
  return hi;
}

}  // namespace handson
