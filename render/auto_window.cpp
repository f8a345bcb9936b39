#include "render/auto_window.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <vector>

namespace handson {

namespace {

constexpr double kLo = -50.0, kHi = 300.0, kBin = 2.0;     // the histogram's range and bin (HU)
constexpr double kPeakLo = -20.0, kPeakHi = 250.0;         // where the peak is sought
constexpr double kSmoothSigma = 5.0;                       // HU
constexpr std::size_t kMaxSamples = 4'000'000, kMinSamples = 500;

/// The index box (inclusive) of the voxels whose centres may lie in the clip: the clip box's
/// corners mapped to indices, widened by one voxel and clamped; the whole grid without a box.
void indexBounds(const Volume& v, const ClipRegion& clip, std::array<int, 3>& lo, std::array<int, 3>& hi) {
  const Eigen::Vector3i dims = v.dims();
  lo = {0, 0, 0};
  hi = {dims.x() - 1, dims.y() - 1, dims.z() - 1};
  if (!clip.box) return;
  std::array<double, 3> a{1e300, 1e300, 1e300}, b{-1e300, -1e300, -1e300};
  for (int k = 0; k < 8; ++k) {
    const Eigen::Vector3d w((k & 1) ? clip.hi.x : clip.lo.x, (k & 2) ? clip.hi.y : clip.lo.y, (k & 4) ? clip.hi.z : clip.lo.z);
    const Eigen::Vector3d idx = v.geometry().toIndex(w);
    for (int c = 0; c < 3; ++c) {
      a[std::size_t(c)] = std::min(a[std::size_t(c)], idx[c]);
      b[std::size_t(c)] = std::max(b[std::size_t(c)], idx[c]);
    }
  }
  for (int c = 0; c < 3; ++c) {
    const auto u = std::size_t(c);
    lo[u] = int(std::clamp(std::floor(a[u]) - 1.0, 0.0, double(hi[u])));
    hi[u] = int(std::clamp(std::ceil(b[u]) + 1.0, 0.0, double(hi[u])));
  }
}

/// The histogram smoothed by a Gaussian of kSmoothSigma (truncated at 3 sigma).
std::vector<double> smoothed(const std::vector<double>& h) {
  const int r = int(std::ceil(3.0 * kSmoothSigma / kBin));
  std::vector<double> kernel(std::size_t(2 * r + 1));
  for (int i = -r; i <= r; ++i) kernel[std::size_t(i + r)] = std::exp(-0.5 * std::pow(i * kBin / kSmoothSigma, 2.0));
  std::vector<double> out(h.size(), 0.0);
  for (std::size_t i = 0; i < h.size(); ++i)
    for (int j = -r; j <= r; ++j) {
      const long k = long(i) + j;
      if (k >= 0 && k < long(h.size())) out[i] += kernel[std::size_t(j + r)] * h[std::size_t(k)];
    }
  return out;
}

}  // namespace

bool clipKeeps(const ClipRegion& clip, const glm::dvec3& p) {
  if (clip.box && (p.x < clip.lo.x || p.y < clip.lo.y || p.z < clip.lo.z || p.x > clip.hi.x || p.y > clip.hi.y || p.z > clip.hi.z)) return false;
  if (clip.plane && glm::dot(glm::dvec3(clip.normal), p) < double(clip.offset)) return false;
  return true;
}

std::optional<TissuePeak> softTissuePeak(const Volume& volume, const ClipRegion& clip) {
  std::array<int, 3> lo, hi;
  indexBounds(volume, clip, lo, hi);
  const double count = double(hi[0] - lo[0] + 1) * double(hi[1] - lo[1] + 1) * double(hi[2] - lo[2] + 1);
  const int stride = std::max(1, int(std::ceil(std::cbrt(count / double(kMaxSamples)))));
  std::vector<double> hist(std::size_t((kHi - kLo) / kBin), 0.0);
  std::size_t samples = 0;
  // The index-to-world map x = A i + b (A 3x3, b 3x1), once: the clip test's position per sample.
  const Eigen::Matrix4d indexToWorld = volume.geometry().indexToWorld();
  const Eigen::Matrix3d A = indexToWorld.block<3, 3>(0, 0);
  const Eigen::Vector3d b = indexToWorld.block<3, 1>(0, 3);
  for (int k = lo[2]; k <= hi[2]; k += stride)
    for (int j = lo[1]; j <= hi[1]; j += stride)
      for (int i = lo[0]; i <= hi[0]; i += stride) {
        const double value = volume.value(i, j, k);
        if (!(value >= kLo && value < kHi)) continue;
        const Eigen::Vector3d w = A * Eigen::Vector3d(i, j, k) + b;
        if ((clip.box || clip.plane) && !clipKeeps(clip, glm::dvec3(w.x(), w.y(), w.z()))) continue;
        hist[std::size_t((value - kLo) / kBin)] += 1.0;
        ++samples;
      }
  if (samples < kMinSamples) return std::nullopt;
  const std::vector<double> s = smoothed(hist);
  const auto bin = [](double hu) { return std::size_t((hu - kLo) / kBin); };
  std::size_t peak = bin(kPeakLo);
  for (std::size_t i = bin(kPeakLo); i < bin(kPeakHi); ++i)
    if (s[i] > s[peak]) peak = i;
  if (!(s[peak] > 0.0)) return std::nullopt;
  // The half maximum's crossings on either side (the histogram's ends if it stays above).
  std::size_t left = peak, right = peak;
  while (left > 0 && s[left] > 0.5 * s[peak]) --left;
  while (right + 1 < s.size() && s[right] > 0.5 * s[peak]) ++right;
  TissuePeak out;
  out.value = kLo + (double(peak) + 0.5) * kBin;
  out.halfWidth = std::max(5.0, 0.5 * double(right - left) * kBin);
  out.samples = samples;
  return out;
}

std::optional<double> autoWindowShift(const TransferFunction& tf, const TissuePeak& peak) {
  if (tf.relative || !std::isfinite(tf.tissuePeak)) return std::nullopt;
  return peak.value - double(tf.tissuePeak);
}

std::optional<AutoWindow> autoWindowFor(const Volume& volume, const TransferFunction& tf, const ClipRegion& clip) {
  const auto peak = softTissuePeak(volume, clip);
  const auto shift = peak ? autoWindowShift(tf, *peak) : std::nullopt;
  if (!shift) return std::nullopt;
  return AutoWindow{*peak, *shift};
}

}  // namespace handson
