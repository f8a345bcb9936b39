// The exact Euclidean distance transform (sim/distance_transform.h) against brute force.
#include <gtest/gtest.h>

#include <algorithm>
#include <limits>
#include <random>

#include "sim/distance_transform.h"

using namespace handson;

namespace {

// min over the outside voxels of the squared distance in mm (max float when there is none).
std::vector<float> bruteForce(const std::vector<std::uint8_t>& inside, const Eigen::Vector3i& n, const Eigen::Vector3d& h) {
  std::vector<float> out(inside.size(), std::numeric_limits<float>::max());
  auto at = [&](int i, int j, int k) { return std::size_t(i) + std::size_t(n.x()) * (std::size_t(j) + std::size_t(n.y()) * std::size_t(k)); };
  for (int k = 0; k < n.z(); ++k)
    for (int j = 0; j < n.y(); ++j)
      for (int i = 0; i < n.x(); ++i) {
        double best = std::numeric_limits<double>::infinity();
        for (int c = 0; c < n.z(); ++c)
          for (int b = 0; b < n.y(); ++b)
            for (int a = 0; a < n.x(); ++a)
              if (!inside[at(a, b, c)]) {
                const Eigen::Vector3d d((i - a) * h.x(), (j - b) * h.y(), (k - c) * h.z());
                best = std::min(best, d.squaredNorm());
              }
        if (best < std::numeric_limits<double>::infinity()) out[at(i, j, k)] = float(best);
      }
  return out;
}

}  // namespace

TEST(DistanceTransform, EqualsBruteForceOnBlobsOfAnAnisotropicGrid) {
  // Random balls on a 23 x 17 x 13 grid of 0.7 x 1.1 x 2.5 mm voxels (wider than the lines the y
  // and z passes take side by side, kBlock = 16), some touching the grid's faces so that whole lines
  // lie inside along one axis: the transform equals brute force to float rounding (it sums the
  // axes' squares in another order: 1e-6 relative).
  const Eigen::Vector3i n(23, 17, 13);
  const Eigen::Vector3d h(0.7, 1.1, 2.5);
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  for (int trial = 0; trial < 4; ++trial) {
    std::vector<std::uint8_t> inside(std::size_t(n.prod()), 0);
    for (int ball = 0; ball < 5; ++ball) {
      const Eigen::Vector3d c(u(rng) * n.x() * h.x(), u(rng) * n.y() * h.y(), u(rng) * n.z() * h.z());
      const double r = 2.0 + 8.0 * u(rng);
      for (int k = 0; k < n.z(); ++k)
        for (int j = 0; j < n.y(); ++j)
          for (int i = 0; i < n.x(); ++i)
            if ((Eigen::Vector3d(i * h.x(), j * h.y(), k * h.z()) - c).norm() <= r)
              inside[std::size_t(i) + std::size_t(n.x()) * (std::size_t(j) + std::size_t(n.y()) * std::size_t(k))] = 1;
    }
    const std::vector<float> got = squaredDistanceToOutside(inside, n, h), want = bruteForce(inside, n, h);
    for (std::size_t v = 0; v < got.size(); ++v) EXPECT_NEAR(got[v], want[v], 1e-6 * std::max(1.0f, want[v])) << "trial " << trial << " voxel " << v;
  }
  // Nothing outside: no distance (the largest float); nothing inside: all zero.
  const std::vector<float> full = squaredDistanceToOutside(std::vector<std::uint8_t>(std::size_t(n.prod()), 1), n, h);
  for (const float d : full) EXPECT_EQ(d, std::numeric_limits<float>::max());
  for (const float d : squaredDistanceToOutside(std::vector<std::uint8_t>(std::size_t(n.prod()), 0), n, h)) EXPECT_EQ(d, 0.0f);
}
