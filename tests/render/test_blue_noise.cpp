// The jitter tile is blue noise: checked against the definition (little power at low spatial
// frequencies, computed by a brute-force DFT) and against white noise of the same density.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numbers>

#include "render/blue_noise.h"
#include "sim/base/error.h"

using namespace handson;

namespace {

// Mean power |F(k)|² over the frequencies 0 < |k| <= kmax of the binary pattern "rank < threshold",
// mean removed; white noise of density p has expected power n² p (1 - p) at every frequency.
double lowFrequencyPower(const std::vector<std::uint32_t>& rank, int n, std::uint32_t threshold, int kmax) {
  const double p = double(threshold) / double(n * n);
  double sum = 0.0;
  int count = 0;
  for (int ky = -kmax; ky <= kmax; ++ky)
    for (int kx = -kmax; kx <= kmax; ++kx) {
      if ((kx == 0 && ky == 0) || kx * kx + ky * ky > kmax * kmax) continue;
      double re = 0.0, im = 0.0;
      for (int y = 0; y < n; ++y)
        for (int x = 0; x < n; ++x) {
          const double v = (rank[std::size_t(y) * n + x] < threshold ? 1.0 : 0.0) - p;
          const double a = -2.0 * std::numbers::pi * (double(kx) * x + double(ky) * y) / n;
          re += v * std::cos(a);
          im += v * std::sin(a);
        }
      sum += re * re + im * im;
      ++count;
    }
  return sum / count;
}

}  // namespace

TEST(BlueNoise, TheTileIsAPermutationOfItsRanks) {
  const auto& r = blueNoiseRanks();
  ASSERT_EQ(r.size(), std::size_t(kBlueNoiseSize * kBlueNoiseSize));
  std::vector<std::uint32_t> sorted = r;
  std::sort(sorted.begin(), sorted.end());
  for (std::size_t i = 0; i < sorted.size(); ++i) ASSERT_EQ(sorted[i], i);
  EXPECT_EQ(&blueNoiseRanks(), &r) << "computed once";
  EXPECT_EQ(voidAndClusterRanks(kBlueNoiseSize), r) << "deterministic";
  EXPECT_THROW(voidAndClusterRanks(2), Error);
  EXPECT_THROW(voidAndClusterRanks(16, 0.0), Error);
}

TEST(BlueNoise, EveryThresholdHasLittleLowFrequencyPower) {
  // White noise: n² p (1 - p) at each frequency. Blue noise: a small fraction of it below a
  // quarter of the Nyquist band (|k| <= 8 of 32). A white-noise tile, as a control, is not.
  const int n = kBlueNoiseSize;
  const auto& r = blueNoiseRanks();
  std::vector<std::uint32_t> white(r.size());
  std::uint32_t s = 99u;
  for (std::size_t i = 0; i < white.size(); ++i) white[i] = std::uint32_t(i);
  for (std::size_t i = white.size() - 1; i > 0; --i) {  // Fisher-Yates with a fixed LCG
    s = s * 1664525u + 1013904223u;
    std::swap(white[i], white[(s >> 8) % (i + 1)]);
  }
  for (const double p : {0.1, 0.5, 0.9}) {
    const std::uint32_t threshold = std::uint32_t(p * n * n);
    const double expectedWhite = double(n) * n * p * (1.0 - p);
    EXPECT_LT(lowFrequencyPower(r, n, threshold, 8), 0.15 * expectedWhite) << "density " << p;
    EXPECT_GT(lowFrequencyPower(white, n, threshold, 8), 0.6 * expectedWhite) << "control at density " << p;
  }
}

TEST(BlueNoise, TheSparsestPointsAreEvenlySpaced) {
  // The first 5 % of the ranks (mean spacing sqrt(20) = 4.5 pixels): no two points closer than
  // 2.5 pixels on the torus. The first 10 %: at most 4 pairs closer than 2 pixels, where white
  // noise of that density has about 250 (each point has 12 pixel sites within 2, a tenth of them taken).
  const int n = kBlueNoiseSize;
  const auto& r = blueNoiseRanks();
  auto spacing = [&](double density, double& closest) {
    std::vector<std::pair<int, int>> pts;
    for (int i = 0; i < n * n; ++i)
      if (r[std::size_t(i)] < std::uint32_t(density * n * n)) pts.emplace_back(i % n, i / n);
    closest = 1e9;
    int near = 0;
    for (std::size_t a = 0; a < pts.size(); ++a)
      for (std::size_t b = a + 1; b < pts.size(); ++b) {
        const int dx = std::abs(pts[a].first - pts[b].first), dy = std::abs(pts[a].second - pts[b].second);
        const double x = std::min(dx, n - dx), y = std::min(dy, n - dy), d = std::sqrt(x * x + y * y);
        closest = std::min(closest, d);
        near += d < 2.0;
      }
    return near;
  };
  double closest = 0.0;
  spacing(0.05, closest);
  EXPECT_GE(closest, 2.5);
  EXPECT_LE(spacing(0.10, closest), 4);
}
