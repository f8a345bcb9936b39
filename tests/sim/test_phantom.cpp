#include <gtest/gtest.h>

#include <cmath>
#include <cstring>

#include "sim/base/error.h"
#include "sim/phantom.h"

using namespace handson;

TEST(Phantom, AnatomyIsWhereTheGeometrySays) {
  PhantomOptions o;
  o.spacingMm = 4.0;
  o.noiseHu = 0.0;
  const Phantom p = makePhantom(o);
  const auto& g = p.ct.geometry();
  EXPECT_EQ(p.ct.type(), ScalarType::Int16);
  EXPECT_EQ(p.labels.type(), ScalarType::UInt8);
  EXPECT_EQ(p.ct.dims(), p.labels.dims());
  EXPECT_LT(g.center().norm(), 1e-9);  // centred on the origin
  auto at = [&](const Volume& v, Eigen::Vector3d w) {
    const Eigen::Vector3i i = g.toIndex(w).array().round().cast<int>();
    return v.value(i.x(), i.y(), i.z());
  };
  const PhantomGeometry& geo = p.geometry;
  EXPECT_EQ(at(p.labels, {180, 130, 0}), label::kBackground);
  EXPECT_EQ(at(p.ct, {180, 130, 0}), -1000.0f);
  EXPECT_EQ(at(p.labels, geo.kidneyLeftCenter), label::kKidneyLeft);
  EXPECT_LT(geo.kidneyLeftCenter.x(), 0.0);  // RAS: the patient's left is -x
  EXPECT_EQ(at(p.labels, geo.kidneyRightCenter), label::kKidneyRight);
  EXPECT_EQ(at(p.ct, geo.kidneyRightCenter), 45.0f);  // medulla
  EXPECT_EQ(at(p.labels, {geo.aortaCenter.x(), geo.aortaCenter.y(), 0}), label::kArtery);
  EXPECT_EQ(at(p.ct, {geo.aortaCenter.x(), geo.aortaCenter.y(), 0}), 280.0f);
  EXPECT_EQ(at(p.labels, {geo.cavaCenter.x(), geo.cavaCenter.y(), 0}), label::kVenous);
  EXPECT_EQ(at(p.labels, geo.liverCenter), label::kLiver);
  EXPECT_EQ(at(p.labels, {geo.vertebraCenter.x(), geo.vertebraCenter.y(), 20}), label::kBone);
  EXPECT_EQ(at(p.ct, {0, 0, 0}), 10.0f);  // cavity
}

TEST(Phantom, NoiseIsDeterministicAndHasTheRequestedSpread) {
  PhantomOptions o;
  o.spacingMm = 6.0;
  const Phantom a = makePhantom(o), b = makePhantom(o);
  ASSERT_EQ(a.ct.byteSize(), b.ct.byteSize());
  EXPECT_EQ(0, std::memcmp(a.ct.bytes(), b.ct.bytes(), a.ct.byteSize()));
  // Air voxels away from the body: -1000 + noise (clamped at -1024): sample standard deviation.
  double sum = 0, sum2 = 0;
  int n = 0;
  for (std::size_t i = 0; i < a.ct.voxelCount(); ++i)
    if (a.labels.value(i) == 0) {
      const double v = a.ct.value(i) + 1000.0;
      if (v < -23.0) continue;  // clamped tail
      sum += v;
      sum2 += v * v;
      ++n;
    }
  ASSERT_GT(n, 1000);
  const double sd = std::sqrt(sum2 / n - (sum / n) * (sum / n));
  EXPECT_NEAR(sd, 12.0, 1.5);  // truncation at -24 HU (2 sigma) lowers it slightly
}

TEST(Phantom, RayIntersectionsAgreeWithBruteForceMarching) {
  const PhantomGeometry geo;
  const Eigen::Vector3d o(30, 600, 10);
  for (const Eigen::Vector3d& target : {Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(100, -20, 40), Eigen::Vector3d(-150, 10, -80)}) {
    const Eigen::Vector3d d = (target - o).normalized();
    const auto t = geo.intersectBody(o, d);
    ASSERT_TRUE(t.has_value());
    // March in 0.01 mm steps until the label leaves the background.
    double s = 0;
    while (geo.labelAt(o + s * d) == label::kBackground && s < 2000) s += 0.01;
    EXPECT_NEAR(*t, s, 0.011);
  }
  EXPECT_FALSE(geo.intersectBody(o, Eigen::Vector3d(0, 1, 0)).has_value());  // pointing away
}

TEST(Phantom, BadOptionsAreRefused) {
  PhantomOptions o;
  o.spacingMm = 0.0;
  EXPECT_THROW(makePhantom(o), Error);
  o.spacingMm = std::nan("");
  EXPECT_THROW(makePhantom(o), Error);
}
