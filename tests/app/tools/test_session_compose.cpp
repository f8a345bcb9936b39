#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "app/tools/session_compose.h"
#include "sim/base/error.h"
#include "sim/phantom.h"

namespace {

using handson::distanceToOutside2d;

TEST(SessionCompose, TheDistanceTransformIsTheBruteForceEuclideanDistance) {
  // Random blobs on a 37 x 23 grid: every cell's value equals the smallest distance to an outside
  // cell, the ring beyond the border included (brute force over all of them). Exact up to rounding.
  std::mt19937 rng(7);
  const int nx = 37, ny = 23;
  for (int trial = 0; trial < 20; ++trial) {
    std::vector<std::uint8_t> in(std::size_t(nx) * ny, 0);
    for (int b = 0; b < 4; ++b) {
      const double cx = std::uniform_real_distribution<double>(0, nx)(rng), cy = std::uniform_real_distribution<double>(0, ny)(rng);
      const double r = std::uniform_real_distribution<double>(2, 12)(rng);
      for (int j = 0; j < ny; ++j)
        for (int i = 0; i < nx; ++i)
          if (std::hypot(i - cx, j - cy) < r) in[std::size_t(i) + std::size_t(nx) * j] = 1;
    }
    if (trial == 0) std::fill(in.begin(), in.end(), 1);  // all inside: the border alone bounds it
    const std::vector<double> d = distanceToOutside2d(in, nx, ny);
    for (int j = 0; j < ny; ++j)
      for (int i = 0; i < nx; ++i) {
        double best = 1e300;
        for (int q = -1; q <= ny; ++q)
          for (int p = -1; p <= nx; ++p) {
            const bool inside = p >= 0 && q >= 0 && p < nx && q < ny && in[std::size_t(p) + std::size_t(nx) * q];
            if (!inside) best = std::min(best, std::hypot(p - i, q - j));
          }
        ASSERT_NEAR(d[std::size_t(i) + std::size_t(nx) * j], best, 1e-9) << "trial " << trial << " cell " << i << "," << j;
      }
  }
  EXPECT_THROW(distanceToOutside2d(std::vector<std::uint8_t>(5), 2, 2), handson::Error);
  EXPECT_THROW(distanceToOutside2d({}, 0, 3), handson::Error);
}

TEST(SessionCompose, BadRequestsAreRefusedWithAReason) {
  const handson::Phantom p = handson::makePhantom(handson::PhantomOptions{6.0, 12.0, 1});
  handson::ComposeOptions o;
  o.organ = 4;
  o.anchor = 4;
  try {
    handson::composeFullSession(p.ct, p.labels, o, "");
    FAIL() << "the same label twice";
  } catch (const handson::Error& e) {
    EXPECT_NE(std::string(e.what()).find("different labels"), std::string::npos) << e.what();
  }
  o.anchor = 77;
  try {
    handson::composeFullSession(p.ct, p.labels, o, "");
    FAIL() << "an absent label";
  } catch (const handson::Error& e) {
    EXPECT_NE(std::string(e.what()).find("label 77 (anchor) is not in the label map"), std::string::npos) << e.what();
  }
  o.anchor = 11;
  o.dragMm = std::nan("");
  EXPECT_THROW(handson::composeFullSession(p.ct, p.labels, o, ""), handson::Error);
  o.dragMm = 20.0;
  o.viewport = {16, 16};
  EXPECT_THROW(handson::composeFullSession(p.ct, p.labels, o, ""), handson::Error);
}

}  // namespace
