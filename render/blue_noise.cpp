#include "blue_noise.h"

#include <algorithm>
#include <cmath>
#include <cstddef>

#include "sim/base/error.h"

namespace handson {

namespace {

// The energy field of a binary pattern on an n x n torus: each "on" pixel adds a Gaussian of
// its toroidal distance to every pixel. Kept up to date as pixels are turned on and off.
struct Energy {
  int n;
  std::vector<double> kernel;  // n x n: the Gaussian of the toroidal offset (dx, dy)
  std::vector<double> e;       // n x n
  std::vector<std::uint8_t> on;

  Energy(int size, double sigma) : n(size), kernel(std::size_t(size) * size), e(std::size_t(size) * size, 0.0), on(std::size_t(size) * size, 0) {
    for (int dy = 0; dy < n; ++dy)
      for (int dx = 0; dx < n; ++dx) {
        const double x = std::min(dx, n - dx), y = std::min(dy, n - dy);
        kernel[std::size_t(dy) * n + dx] = std::exp(-(x * x + y * y) / (2.0 * sigma * sigma));
      }
  }
  void set(int p, bool value) {
    if (bool(on[std::size_t(p)]) == value) return;
    on[std::size_t(p)] = value;
    const double s = value ? 1.0 : -1.0;
    const int px = p % n, py = p / n;
    for (int y = 0; y < n; ++y) {
      const int dy = (y - py + n) % n;
      for (int x = 0; x < n; ++x) e[std::size_t(y) * n + x] += s * kernel[std::size_t(dy) * n + (x - px + n) % n];
    }
  }
  // The "on" pixel with the most energy (the tightest cluster), or -1.
  int tightestCluster() const {
    int best = -1;
    for (int p = 0; p < n * n; ++p)
      if (on[std::size_t(p)] && (best < 0 || e[std::size_t(p)] > e[std::size_t(best)])) best = p;
    return best;
  }
  // The "off" pixel with the least energy (the largest void), or -1.
  int largestVoid() const {
    int best = -1;
    for (int p = 0; p < n * n; ++p)
      if (!on[std::size_t(p)] && (best < 0 || e[std::size_t(p)] < e[std::size_t(best)])) best = p;
    return best;
  }
};

}  // namespace

std::vector<std::uint32_t> voidAndClusterRanks(int n, double sigma) {
  if (n < 4 || n > 256 || !(sigma > 0.0)) throw Error("blue noise: the tile size must be 4..256 and sigma positive");
  const int total = n * n;
  // The initial pattern: a tenth of the pixels by a fixed linear congruential sequence, then
  // tightened (the tightest cluster's pixel moved to the largest void) until it is stable.
  Energy start(n, sigma);
  std::uint32_t state = 12345u;
  const int ones = std::max(1, total / 10);
  for (int placed = 0; placed < ones;) {
    state = state * 1664525u + 1013904223u;
    const int p = int((state >> 8) % std::uint32_t(total));
    if (!start.on[std::size_t(p)]) {
      start.set(p, true);
      ++placed;
    }
  }
  for (int guard = 0; guard < total; ++guard) {
    const int c = start.tightestCluster();
    start.set(c, false);
    const int v = start.largestVoid();
    start.set(v, true);
    if (v == c) break;
  }
  std::vector<std::uint32_t> rank(std::size_t(total), 0);
  // Phase 1: ranks below the initial count, removing the tightest clusters one by one.
  {
    Energy f = start;
    for (int r = ones - 1; r >= 0; --r) {
      const int c = f.tightestCluster();
      f.set(c, false);
      rank[std::size_t(c)] = std::uint32_t(r);
    }
  }
  // Phase 2: up to half, filling the largest voids.
  Energy f = start;
  int r = ones;
  for (; r < total / 2; ++r) {
    const int v = f.largestVoid();
    f.set(v, true);
    rank[std::size_t(v)] = std::uint32_t(r);
  }
  // Phase 3: the rest, with the roles swapped: the "off" pixels are now the minority, and the
  // tightest cluster of them is turned on next.
  Energy g(n, sigma);
  for (int p = 0; p < total; ++p)
    if (!f.on[std::size_t(p)]) g.set(p, true);
  for (; r < total; ++r) {
    const int c = g.tightestCluster();
    g.set(c, false);
    rank[std::size_t(c)] = std::uint32_t(r);
  }
  return rank;
}

const std::vector<std::uint32_t>& blueNoiseRanks() {
  static const std::vector<std::uint32_t> ranks = voidAndClusterRanks(kBlueNoiseSize);
  return ranks;
}

}  // namespace handson
