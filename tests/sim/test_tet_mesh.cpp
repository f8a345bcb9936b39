#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <map>
#include <random>
#include <set>

#include "sim/base/error.h"
#include "sim/tet_mesh.h"

using namespace handson;

TEST(KuhnGrid, TetsFillTheBoxAndFacesMatch) {
  const KuhnGrid g({-1, 2, 3}, {2, 1.5, 1}, {3, 2, 4});
  const TetMesh m = g.mesh();
  EXPECT_EQ(m.tets.size(), 3u * 2 * 4 * 6);
  double vol = 0;
  for (std::size_t t = 0; t < m.tets.size(); ++t) {
    EXPECT_GT(std::abs(m.signedVolume(int(t))), 0.0);
    vol += std::abs(m.signedVolume(int(t)));
  }
  EXPECT_NEAR(vol, 6.0 * 3.0 * 4.0, 1e-9);
  // Conformity: every interior face is shared by exactly two tets, every boundary face by one,
  // and the boundary faces cover the box's surface (2 triangles per cell face).
  std::map<std::array<int, 3>, int> faces;
  for (const auto& t : m.tets)
    for (int skip = 0; skip < 4; ++skip) {
      std::array<int, 3> f{};
      int k = 0;
      for (int i = 0; i < 4; ++i)
        if (i != skip) f[std::size_t(k++)] = t[std::size_t(i)];
      std::sort(f.begin(), f.end());
      ++faces[f];
    }
  int boundary = 0;
  for (const auto& [f, n] : faces) {
    EXPECT_LE(n, 2);
    if (n == 1) ++boundary;
  }
  EXPECT_EQ(boundary, 2 * 2 * (3 * 2 + 2 * 4 + 3 * 4));
}

TEST(KuhnGrid, LocateGivesTheContainingTetAndItsBarycentrics) {
  const KuhnGrid g({0, 0, 0}, {1, 2, 3}, {4, 3, 2});
  const TetMesh m = g.mesh();
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  for (int i = 0; i < 2000; ++i) {
    const Eigen::Vector3d p(4 * u(rng), 6 * u(rng), 6 * u(rng));
    Eigen::Vector4d lam;
    const int t = g.locate(p, &lam);
    ASSERT_GE(t, 0);
    EXPECT_GE(lam.minCoeff(), -1e-12);
    EXPECT_NEAR(lam.sum(), 1.0, 1e-12);
    Eigen::Vector3d q = Eigen::Vector3d::Zero();
    for (int c = 0; c < 4; ++c) q += lam[c] * m.nodes[std::size_t(m.tets[std::size_t(t)][std::size_t(c)])];
    EXPECT_LT((q - p).norm(), 1e-12);
  }
  EXPECT_EQ(g.locate({-0.1, 1, 1}), -1);
  EXPECT_EQ(g.locate({1, 1, 6.5}), -1);
  EXPECT_EQ(g.locate({std::nan(""), 1, 1}), -1);
  EXPECT_GE(g.locate({4, 6, 6}), 0);  // the far corner belongs to the box
}

TEST(NestedMeshes, EveryFineTetLiesInsideOneCoarseTetAndCoarseNodesAreFineNodes) {
  const NestedMeshes nm = buildNestedMeshes({0, 0, 0}, {30, 20, 25}, 300, 27);
  EXPECT_EQ(nm.refinement, 3);
  EXPECT_NEAR(double(nm.coarse.tets.size()), 300, 0.35 * 300);
  EXPECT_EQ(nm.fine.tets.size(), nm.coarse.tets.size() * 27);
  // All four corners of each fine tet have barycentrics >= 0 in its parent, and each coarse tet's
  // children fill it exactly.
  std::vector<double> filled(nm.coarse.tets.size(), 0.0);
  for (std::size_t t = 0; t < nm.fine.tets.size(); ++t) {
    const int p = nm.fineParent[t];
    ASSERT_GE(p, 0);
    const auto& ct = nm.coarse.tets[std::size_t(p)];
    Eigen::Matrix3d D;
    D << nm.coarse.nodes[std::size_t(ct[1])] - nm.coarse.nodes[std::size_t(ct[0])], nm.coarse.nodes[std::size_t(ct[2])] - nm.coarse.nodes[std::size_t(ct[0])],
        nm.coarse.nodes[std::size_t(ct[3])] - nm.coarse.nodes[std::size_t(ct[0])];
    for (int v : nm.fine.tets[t]) {
      const Eigen::Vector3d l = D.inverse() * (nm.fine.nodes[std::size_t(v)] - nm.coarse.nodes[std::size_t(ct[0])]);
      EXPECT_GE(l.minCoeff(), -1e-9);
      EXPECT_LE(l.sum(), 1.0 + 1e-9);
    }
    filled[std::size_t(p)] += std::abs(nm.fine.signedVolume(int(t)));
  }
  for (std::size_t c = 0; c < filled.size(); ++c) EXPECT_NEAR(filled[c], std::abs(nm.coarse.signedVolume(int(c))), 1e-9);
  for (std::size_t n = 0; n < nm.coarse.nodes.size(); ++n)
    EXPECT_LT((nm.fine.nodes[std::size_t(nm.coarseNodeInFine[n])] - nm.coarse.nodes[n]).norm(), 1e-12);
}

TEST(NestedMeshes, BadRegionsAndCountsAreRefused) {
  EXPECT_THROW(buildNestedMeshes({0, 0, 0}, {0, 1, 1}, 100, 8), Error);
  EXPECT_THROW(buildNestedMeshes({0, 0, 0}, {1, 1, 1}, 2, 8), Error);
  EXPECT_THROW(buildNestedMeshes({0, 0, 0}, {1, 1, 1}, 100, 0), Error);
  EXPECT_THROW(buildNestedMeshes({0, 0, std::nan("")}, {1, 1, 1}, 100, 8), Error);
  EXPECT_THROW(KuhnGrid({0, 0, 0}, {1, 1, 1}, {1000, 1000, 1000}), Error);
}
