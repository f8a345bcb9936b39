// Strain per fine tet and on the image's grid against exact answers: homogeneous deformations
// (every tet's principal stretch is known), a rigid motion (zero), the bar stretched by its end
// handle (the 1 % everywhere), and the rasterized strain volume (the strain where the tissue is,
// zero outside the region).
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>

#include "sim/strain.h"
#include "sim/tet_raster.h"
#include "tests/sim/bar_scene.h"

using namespace handson;

namespace {

std::vector<Eigen::Vector3d> mapped(const TetMesh& m, const Eigen::Matrix3d& A, const Eigen::Vector3d& b) {
  std::vector<Eigen::Vector3d> x;
  for (const auto& X : m.nodes) x.push_back(A * X + b);
  return x;
}

}  // namespace

TEST(Strain, HomogeneousDeformationsGiveTheirLargestPrincipalStretchMinusOne) {
  const NestedMeshes nm = buildNestedMeshes({0, 0, 0}, {20, 10, 10}, 120, 8);
  const TetMesh& m = nm.fine;
  const Eigen::Matrix3d R = Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, -1).normalized()).toRotationMatrix();
  struct Case {
    Eigen::Matrix3d A;
    double expect;
  };
  const std::vector<Case> cases = {
      {R, 0.0},                                                         // rigid: no strain
      {R * Eigen::Vector3d(1.3, 0.9, 1.0).asDiagonal(), 0.3},           // 30 % stretch, turned
      {Eigen::Vector3d(0.8, 0.9, 0.95).asDiagonal(), -0.05},            // compressed every way
      {(Eigen::Matrix3d() << 1, 0.2, 0, 0, 1, 0, 0, 0, 1).finished(), 0.1 + std::sqrt(1.01) - 1.0},  // simple shear 0.2
  };
  for (std::size_t c = 0; c < cases.size(); ++c) {
    const auto s = tetStrain(m, mapped(m, cases[c].A, {3, -4, 5}));
    // The exact value: the largest singular value of A, minus one.
    const double exact = Eigen::JacobiSVD<Eigen::Matrix3d>(cases[c].A).singularValues()[0] - 1.0;
    EXPECT_NEAR(exact, cases[c].expect, 1e-12);  // (simple shear g: sigma_max = g/2 + sqrt(1 + g^2/4))
    for (float v : s) ASSERT_NEAR(v, exact, 1e-6) << "case " << c;  // float storage: 1e-6
  }
}

TEST(Strain, TheBarStretchedOnePercentByItsEndHandleIsAtOnePercentEverywhere) {
  // nu = 0: the displacement is x * 1 % along the bar, lateral faces unmoved: stretch 1.01 in every tet.
  const handson::test::Bar bar(10e3, 0.0, true);
  const std::vector<RigidTransform> T{{Eigen::Matrix3d::Identity(), Eigen::Vector3d(0.5, 0, 0)}};
  for (float v : tetStrain(bar.meshes.fine, bar.fineSolve(T))) ASSERT_NEAR(v, 0.01, 1e-6);
}

TEST(Strain, OnTheImageGridTheStrainIsWhereTheTissueIsAndZeroOutside) {
  // A 40 mm image of 1 mm voxels; the mesh fills the region [10, 30]^3 and is stretched 20 % along
  // x about the region's centre: covered voxels read 0.2, the rest of the image 0.
  VolumeGeometry g;
  g.dims = {40, 40, 40};
  Volume image(g, ScalarType::Int16);
  const NestedMeshes nm = buildNestedMeshes({10, 10, 10}, {30, 30, 30}, 300, 8);
  const Eigen::Matrix3d A = Eigen::Vector3d(1.2, 1.0, 1.0).asDiagonal();
  const auto x = mapped(nm.fine, A, Eigen::Vector3d(-4, 0, 0));  // centre 20 stays
  std::vector<std::int32_t> tetOf;
  Volume out;
  const RasterStats st = rasterizeDeformed(image, nm.fine, x, {{10, 10, 10}, {30, 30, 30}, 0.0f}, out, {nullptr, nullptr, UINT64_MAX, &tetOf, {}});
  const Volume s = strainVolume(g, tetOf, tetStrain(nm.fine, x));
  EXPECT_EQ(s.type(), ScalarType::Float32);
  std::size_t covered = 0, outside = 0;
  for (int k = 0; k < 40; ++k)
    for (int j = 0; j < 40; ++j)
      for (int i = 0; i < 40; ++i) {
        const float v = s.value(i, j, k);
        const bool in = i >= 10 && i <= 30 && j >= 10 && j <= 30 && k >= 10 && k <= 30;
        if (!in) {
          EXPECT_EQ(v, 0.0f) << i << "," << j << "," << k;
          ++outside;
        } else if (tetOf[s.linearIndex(i, j, k)] >= 0) {
          EXPECT_NEAR(v, 0.2f, 1e-6);
          ++covered;
        }
      }
  EXPECT_EQ(covered, st.covered);
  EXPECT_GT(covered, 8000u);
  EXPECT_GT(outside, 0u);
}
