// Tissue past its strain limit: the limits column of the material table, the nearest handle along
// the mesh against a brute-force search, and the volume past the limit against exact answers.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

#include "sim/base/error.h"
#include "sim/materials.h"
#include "sim/strain.h"
#include "sim/tet_mesh.h"
#include "sim/tissue_limits.h"

using namespace handson;

namespace {

// A 30 x 10 x 10 mm bar: 5 mm cells, each coarse tet split into 8 fine ones (2.5 mm fine cells).
NestedMeshes bar() { return buildNestedMeshes({0, 0, 0}, {30, 10, 10}, 144, 8); }

// Handle 0: the nodes on the face x = 0; handle 1 (when two): those on x = 30.
FineConstraints endHandles(const TetMesh& m, int count) {
  FineConstraints c;
  c.handleCount = count;
  c.handleOf.assign(m.nodes.size(), -1);
  c.fixed.assign(m.nodes.size(), 0);
  for (std::size_t i = 0; i < m.nodes.size(); ++i) {
    if (m.nodes[i].x() < 1e-9) c.handleOf[i] = 0;
    if (count > 1 && m.nodes[i].x() > 30 - 1e-9) c.handleOf[i] = 1;
  }
  return c;
}

// Two bands by x: "soft" (limit 10 %) for x < 15, "stiff" (limit 2 %) beyond; per tet by its centroid.
const char* const kTable =
    "units,hu\nname,lower,upper,youngs_kpa,poisson,strain_limit\nsoft,-inf,15,6,0.45,0.1\nstiff,15,inf,600,0.45,0.02\n";

std::vector<int> bandsByCentroid(const TetMesh& m) {
  std::vector<int> band(m.tets.size());
  for (std::size_t t = 0; t < m.tets.size(); ++t) {
    double x = 0;
    for (int v : m.tets[t]) x += m.nodes[std::size_t(v)].x() / 4.0;
    band[t] = x < 15 ? 0 : 1;
  }
  return band;
}

}  // namespace

TEST(TissueLimits, TheStrainLimitColumnIsParsedOptionalAndChecked) {
  const MaterialTable t = MaterialTable::parse(kTable);
  EXPECT_DOUBLE_EQ(t.band(0).strainLimit, 0.1);
  EXPECT_DOUBLE_EQ(t.band(1).strainLimit, 0.02);
  // Without the column (tables written before it): no limit.
  const MaterialTable old = MaterialTable::parse("units,hu\nname,lower,upper,youngs_kpa,poisson\nsoft,-inf,inf,6,0.45\n");
  EXPECT_TRUE(std::isinf(old.band(0).strainLimit));
  EXPECT_TRUE(std::isinf(MaterialTable::parse("units,hu\nname,lower,upper,youngs_kpa,poisson,strain_limit\na,-inf,inf,6,0.45,inf\n").band(0).strainLimit));
  // The built-in CT table gives every tissue a finite limit (air and the lung boundary have none:
  // no source), bone's far below soft tissue's.
  const MaterialTable ct = MaterialTable::ctDefault();
  for (const auto& b : ct.bands()) {
    const bool none = b.name == "air" || b.name == "lung-or-gas-boundary";
    EXPECT_EQ(std::isinf(b.strainLimit), none) << b.name;
    EXPECT_TRUE(none || (b.strainLimit > 0.0 && b.strainLimit < 1.0)) << b.name;
  }
  EXPECT_LT(ct.band(ct.classify(1500)).strainLimit, 0.05);
  EXPECT_GT(ct.band(ct.classify(55)).strainLimit, 0.1);
  for (const char* bad : {"0", "-0.1", "nan", "x", ""}) {
    const std::string text = std::string("units,hu\nname,lower,upper,youngs_kpa,poisson,strain_limit\na,-inf,inf,6,0.45,") + bad + "\n";
    EXPECT_THROW(MaterialTable::parse(text), Error) << bad;
  }
  // A row whose column count differs from the header's.
  EXPECT_THROW(MaterialTable::parse("units,hu\nname,lower,upper,youngs_kpa,poisson,strain_limit\na,-inf,inf,6,0.45\n"), Error);
  EXPECT_THROW(MaterialTable::parse("units,hu\nname,lower,upper,youngs_kpa,poisson\na,-inf,inf,6,0.45,0.3\n"), Error);
}

TEST(TissueLimits, TheNearestHandleAlongTheMeshMatchesABruteForceRelaxation) {
  // The bar with a wall cut out of it (2.5 < x < 12.5, y < 7.5: tets removed, a passage left at
  // y > 7.5), so that distance along the mesh is not distance in space.
  const NestedMeshes nm = bar();
  TetMesh m = nm.fine;
  const auto inWall = [&](const std::array<int, 4>& t) {
    Eigen::Vector3d c = Eigen::Vector3d::Zero();
    for (int v : t) c += m.nodes[std::size_t(v)] / 4.0;
    return c.x() > 2.5 && c.x() < 12.5 && c.y() < 7.5;
  };
  m.tets.erase(std::remove_if(m.tets.begin(), m.tets.end(), inWall), m.tets.end());
  const FineConstraints c = endHandles(m, 2);
  const NearestHandle near = nearestHandleOfNodes(m, c);
  // Independent answer: per handle, Bellman-Ford over every tet edge until nothing changes.
  const auto relax = [&](int handle) {
    std::vector<double> d(m.nodes.size(), std::numeric_limits<double>::infinity());
    for (std::size_t i = 0; i < m.nodes.size(); ++i)
      if (c.handleOf[i] == handle) d[i] = 0;
    for (bool changed = true; changed;) {
      changed = false;
      for (const auto& t : m.tets)
        for (int a : t)
          for (int b : t) {
            const double w = d[std::size_t(a)] + (m.nodes[std::size_t(b)] - m.nodes[std::size_t(a)]).norm();
            if (w < d[std::size_t(b)] - 1e-12) d[std::size_t(b)] = w, changed = true;
          }
    }
    return d;
  };
  const std::vector<double> d0 = relax(0), d1 = relax(1);
  int behindTheWall = -1;
  for (std::size_t i = 0; i < m.nodes.size(); ++i) {
    const double d = std::min(d0[i], d1[i]);
    if (std::isinf(d)) {
      EXPECT_EQ(near.handle[i], -1) << i;  // inside the wall: no tet holds it
      EXPECT_TRUE(std::isinf(near.distance[i])) << i;
      continue;
    }
    EXPECT_NEAR(near.distance[i], d, 1e-9) << i;
    if (std::abs(d0[i] - d1[i]) > 1e-9) {  // equidistant nodes may go either way
      EXPECT_EQ(near.handle[i], d0[i] < d1[i] ? 0 : 1) << i;
    }
    if ((m.nodes[i] - Eigen::Vector3d(12.5, 0, 5)).norm() < 1e-9) behindTheWall = int(i);
  }
  // The wall's far face at y = 0: 12.5 mm from handle 0 in space, but 20 mm around the wall along
  // the mesh, so handle 1 (17.5 mm straight along x) is nearer.
  ASSERT_GE(behindTheWall, 0);
  EXPECT_EQ(near.handle[std::size_t(behindTheWall)], 1);
  EXPECT_NEAR(near.distance[std::size_t(behindTheWall)], 17.5, 1e-9);
  // Only moving handles are sources: with handle 1 held, everything reached goes to handle 0.
  const NearestHandle only0 = nearestHandleOfNodes(m, c, {1, 0});
  EXPECT_EQ(only0.handle[std::size_t(behindTheWall)], 0);
  EXPECT_GT(only0.distance[std::size_t(behindTheWall)], 17.5);
  EXPECT_THROW(nearestHandleOfNodes(m, c, {1}), Error);
  // No handle: nothing is reached.
  FineConstraints none = c;
  none.handleOf.assign(m.nodes.size(), -1);
  const NearestHandle unreached = nearestHandleOfNodes(m, none);
  EXPECT_EQ(unreached.handle[0], -1);
  EXPECT_TRUE(std::isinf(unreached.distance[0]));
}

TEST(TissueLimits, AUniformStretchPutsExactlyTheTissueWithALowerLimitPastIt) {
  const NestedMeshes nm = bar();
  const TetMesh& m = nm.fine;
  const MaterialTable table = MaterialTable::parse(kTable);
  const std::vector<int> band = bandsByCentroid(m);
  const FineConstraints c = endHandles(m, 1);
  const NearestHandle near = nearestHandleOfNodes(m, c);
  // A 5 % stretch along x, then a rigid turn: every tet's largest principal stretch is 1.05.
  const Eigen::Matrix3d R = Eigen::AngleAxisd(0.4, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  std::vector<Eigen::Vector3d> x(m.nodes.size());
  for (std::size_t i = 0; i < x.size(); ++i) x[i] = R * Eigen::Vector3d(1.05 * m.nodes[i].x(), m.nodes[i].y(), m.nodes[i].z()) + Eigen::Vector3d(3, -1, 2);
  const TissueLimitReport r = tissueLimits(m, tetStrain(m, x), band, table, near, 1);
  // Exactly the stiff half (limit 2 % < 5 %) is past its limit: 15 x 10 x 10 mm³, at 2.5x; the soft
  // half (10 %) is not.
  ASSERT_EQ(r.bands.size(), 1u);
  EXPECT_EQ(r.bands[0].name, "stiff");
  EXPECT_NEAR(r.bands[0].volumeMm3, 1500.0, 1e-6);
  EXPECT_NEAR(r.bands[0].worstRatio, 2.5, 1e-6);
  EXPECT_EQ(r.bands[0].tets, m.tets.size() / 2);
  EXPECT_NEAR(r.volumeMm3, 1500.0, 1e-6);
  ASSERT_EQ(r.volumeByHandle.size(), 1u);
  EXPECT_NEAR(r.volumeByHandle[0], 1500.0, 1e-6);  // one handle: all of it is its doing
  EXPECT_NE(describeTissueLimits(r).find("stiff 1.50 cm³ at up to 2.50x its 2 % limit"), std::string::npos) << describeTissueLimits(r);
  // A rigid motion alone: nothing past any limit.
  for (std::size_t i = 0; i < x.size(); ++i) x[i] = R * m.nodes[i] + Eigen::Vector3d(3, -1, 2);
  const TissueLimitReport rigid = tissueLimits(m, tetStrain(m, x), band, table, near, 1);
  EXPECT_FALSE(rigid.any());
  EXPECT_EQ(describeTissueLimits(rigid), "none");
}

TEST(TissueLimits, TissueIsPutDownToTheNearerOfTwoHandles) {
  const NestedMeshes nm = bar();
  const TetMesh& m = nm.fine;
  // One band with a 1 % limit everywhere; a stretch of 3 % over x < 10 and of 4 % over x > 25, none
  // between (that part moved rigidly): the first third is nearer handle 0 (x = 0), the last sixth
  // handle 1 (x = 30).
  const MaterialTable table = MaterialTable::parse("units,hu\nname,lower,upper,youngs_kpa,poisson,strain_limit\nsoft,-inf,inf,6,0.45,0.01\n");
  const std::vector<int> band(m.tets.size(), 0);
  const FineConstraints c = endHandles(m, 2);
  std::vector<Eigen::Vector3d> x(m.nodes.size());
  for (std::size_t i = 0; i < x.size(); ++i) {
    const Eigen::Vector3d& p = m.nodes[i];
    const double along = p.x() < 10 ? 1.03 * p.x() : p.x() < 25 ? p.x() + 0.3 : 25.3 + 1.04 * (p.x() - 25);
    x[i] = Eigen::Vector3d(along, p.y(), p.z());
  }
  std::vector<float> strain = tetStrain(m, x);
  const TissueLimitReport r = tissueLimits(m, strain, band, table, nearestHandleOfNodes(m, c), 2);
  EXPECT_NEAR(r.volumeMm3, 1500.0, 1e-6);
  EXPECT_NEAR(r.volumeByHandle[0], 1000.0, 1e-6);
  EXPECT_NEAR(r.volumeByHandle[1], 500.0, 1e-6);
  EXPECT_NE(describeTissueLimits(r, {4, 9}).find("from handle 4 (1.00 cm³), handle 9 (0.50 cm³)"), std::string::npos) << describeTissueLimits(r, {4, 9});
  // Handle 1 held (a fixed mask): all of it is handle 0's doing.
  const TissueLimitReport held = tissueLimits(m, strain, band, table, nearestHandleOfNodes(m, c, {1, 0}), 2);
  EXPECT_NEAR(held.volumeByHandle[0], 1500.0, 1e-6);
  EXPECT_EQ(held.volumeByHandle[1], 0.0);
  // A NaN strain (a degenerate tet) is not counted.
  for (std::size_t t = 0; t < strain.size(); ++t)
    if (strain[t] > 0.02f) {
      strain[t] = std::numeric_limits<float>::quiet_NaN();
      break;
    }
  EXPECT_EQ(tissueLimits(m, strain, band, table, nearestHandleOfNodes(m, c), 2).tets, r.tets - 1);
  // Sizes that do not match the mesh are refused.
  EXPECT_THROW(tissueLimits(m, std::vector<float>(3, 0.f), band, table, nearestHandleOfNodes(m, c), 2), Error);
  EXPECT_THROW(tetStrainLimits({5}, table), Error);
  EXPECT_THROW(tetStrainLimits({-3}, table), Error);
  // The exterior layer stands for tissue beyond the region, a sliding handle's own tets move
  // rigidly with it: no limit, never past it.
  EXPECT_EQ(tetStrainLimits({kExteriorBand}, table)[0], std::numeric_limits<float>::infinity());
  EXPECT_EQ(tetStrainLimits({kRigidBand}, table)[0], kRigidStrainLimit);
  std::vector<int> rigid(band.size(), kRigidBand);
  EXPECT_EQ(tissueLimits(m, std::vector<float>(band.size(), 10.0f), rigid, table, nearestHandleOfNodes(m, c), 2).tets, 0u);
  std::vector<float> shown{0.5f, 0.7f};
  hideRigidStrain(shown, {0.2f, kRigidStrainLimit});
  EXPECT_EQ(shown, (std::vector<float>{0.5f, 0.0f}));
  EXPECT_THROW(hideRigidStrain(shown, {0.2f}), Error);
  std::vector<int> exterior(band.size(), kExteriorBand);
  EXPECT_EQ(tissueLimits(m, std::vector<float>(band.size(), 10.0f), exterior, table, nearestHandleOfNodes(m, c), 2).tets, 0u);
}

// The highlight's volume, by hand on a 5 x 1 x 1 grid: a voxel of no tet, one of a tet with no
// limit, one past its limit, one within it; NaN strain gives 0; mismatched sizes are refused.
TEST(TissueLimits, TheStrainOverLimitVolumeIsEachVoxelsTetsRatio) {
  VolumeGeometry g;
  g.dims = Eigen::Vector3i(5, 1, 1);
  const std::vector<std::int32_t> tetOf = {-1, 0, 1, 2, 3};
  const float inf = std::numeric_limits<float>::infinity(), nan = std::numeric_limits<float>::quiet_NaN();
  const std::vector<float> strain = {0.5f, 0.33f, 0.1f, nan}, limits = {inf, 0.22f, 0.2f, 0.2f};
  const Volume v = strainOverLimitVolume(g, tetOf, strain, limits);
  ASSERT_EQ(v.voxelCount(), 5u);
  EXPECT_EQ(v.value(0), 0.0f);              // no tet
  EXPECT_EQ(v.value(1), 0.0f);              // no limit
  EXPECT_FLOAT_EQ(v.value(2), 1.5f);        // 33 % against 22 %: past it
  EXPECT_FLOAT_EQ(v.value(3), 0.5f);        // 10 % against 20 %: within
  EXPECT_EQ(v.value(4), 0.0f);              // a degenerate tet's NaN
  EXPECT_THROW(strainOverLimitVolume(g, tetOf, strain, {inf}), Error);
  EXPECT_THROW(strainOverLimitVolume(g, {-1, 0, 1, 2, 4}, strain, limits), Error);
  EXPECT_THROW(strainOverLimitVolume(g, {0, 1}, strain, limits), Error);
}
