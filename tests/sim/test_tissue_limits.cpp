// Tissue past its strain limit: the limits column of the material table, the nearest handle along
// the mesh against a brute-force search, and the volume past the limit against exact answers.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "sim/error.h"
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
  const NestedMeshes nm = bar();
  const TetMesh& m = nm.fine;
  const FineConstraints c = endHandles(m, 2);
  const NearestHandle near = nearestHandleOfNodes(m, c);
  // Independent answer: Bellman-Ford over every tet edge until nothing changes.
  std::vector<double> d(m.nodes.size(), std::numeric_limits<double>::infinity());
  std::vector<int> h(m.nodes.size(), -1);
  for (std::size_t i = 0; i < m.nodes.size(); ++i)
    if (c.handleOf[i] >= 0) d[i] = 0, h[i] = c.handleOf[i];
  for (bool changed = true; changed;) {
    changed = false;
    for (const auto& t : m.tets)
      for (int a : t)
        for (int b : t) {
          const double w = d[std::size_t(a)] + (m.nodes[std::size_t(b)] - m.nodes[std::size_t(a)]).norm();
          if (w < d[std::size_t(b)] - 1e-12) d[std::size_t(b)] = w, h[std::size_t(b)] = h[std::size_t(a)], changed = true;
        }
  }
  for (std::size_t i = 0; i < m.nodes.size(); ++i) {
    EXPECT_NEAR(near.distance[i], d[i], 1e-9) << i;
    // Equidistant nodes (the plane x = 15) may go either way; elsewhere the handles agree.
    if (std::abs(m.nodes[i].x() - 15.0) > 1e-9) {
      EXPECT_EQ(near.handle[i], h[i]) << i;
    }
    EXPECT_EQ(near.handle[i], m.nodes[i].x() < 15.0 - 1e-9 ? 0 : m.nodes[i].x() > 15.0 + 1e-9 ? 1 : near.handle[i]);
  }
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
  // One band with a 1 % limit everywhere; a stretch of 3 % over x < 10 only, 0 elsewhere (the
  // bar's far part moved rigidly with it): the stretched third is nearer handle 0 (x = 0).
  const MaterialTable table = MaterialTable::parse("units,hu\nname,lower,upper,youngs_kpa,poisson,strain_limit\nsoft,-inf,inf,6,0.45,0.01\n");
  const std::vector<int> band(m.tets.size(), 0);
  const NearestHandle near = nearestHandleOfNodes(m, endHandles(m, 2));
  std::vector<Eigen::Vector3d> x(m.nodes.size());
  for (std::size_t i = 0; i < x.size(); ++i) {
    const Eigen::Vector3d& p = m.nodes[i];
    x[i] = Eigen::Vector3d(p.x() < 10 ? 1.03 * p.x() : p.x() + 0.3, p.y(), p.z());
  }
  const TissueLimitReport r = tissueLimits(m, tetStrain(m, x), band, table, near, 2);
  EXPECT_NEAR(r.volumeMm3, 1000.0, 1e-6);
  EXPECT_NEAR(r.volumeByHandle[0], 1000.0, 1e-6);
  EXPECT_EQ(r.volumeByHandle[1], 0.0);
  // Sizes that do not match the mesh are refused.
  EXPECT_THROW(tissueLimits(m, std::vector<float>(3, 0.f), band, table, near, 2), Error);
  EXPECT_THROW(tetStrainLimits({5}, table), Error);
}
