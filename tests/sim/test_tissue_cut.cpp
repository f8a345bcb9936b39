// Cutting the fine mesh along a quad (sim/tissue_cut.h), checked against exact answers on a bar
// whose material has no Poisson effect (nu = 0, so a pulled section's field is uniform and the
// tets reproduce it exactly): cut through, the bar transmits nothing; split along its length with
// only one part pulled, it transmits that part's E A U / L; cut part-way across, the nodes at the
// cut's edge stay shared.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <functional>
#include <limits>

#include "sim/base/error.h"
#include "sim/fem.h"
#include "sim/static_solver.h"
#include "sim/tissue_cut.h"

using namespace handson;

namespace {

// A 20 x 6 x 6 mm bar along x, 2 mm cells (540 tets), E 1 kPa, nu 0.
constexpr double kE = 1.0, kL = 20.0, kU = 0.05;
TetMesh bar() { return KuhnGrid({0, 0, 0}, {2, 2, 2}, {10, 3, 3}).mesh(); }

CutQuad quadX(double x, double y0, double y1, double z0, double z1) {
  return {{Eigen::Vector3d(x, y0, z0), Eigen::Vector3d(x, y1, z0), Eigen::Vector3d(x, y1, z1), Eigen::Vector3d(x, y0, z1)}};
}

Eigen::Vector3d centroidOf(const TetMesh& m, std::size_t t) {
  Eigen::Vector3d c = Eigen::Vector3d::Zero();
  for (int n : m.tets[t]) c += 0.25 * m.nodes[std::size_t(n)];
  return c;
}

// Per node: whether a tet using it has its centroid where `inside` says.
std::vector<char> nodesOfTets(const TetMesh& m, const std::function<bool(const Eigen::Vector3d&)>& inside) {
  std::vector<char> out(m.nodes.size(), 0);
  for (std::size_t t = 0; t < m.tets.size(); ++t)
    if (inside(centroidOf(m, t)))
      for (int n : m.tets[t]) out[std::size_t(n)] = 1;
  return out;
}

struct Pulled {
  std::vector<Eigen::Vector3d> x;
  double reaction = 0.0;  // the force the pulled nodes take, along x
};

// The bar's x = 0 nodes held at rest and the pulled nodes (x = L, `pulled`) moved kU along x.
Pulled pull(const TetMesh& m, const std::vector<char>& pulled) {
  const auto K = tetStiffnesses(m, std::vector<double>(m.tets.size(), kE), std::vector<double>(m.tets.size(), 0.0));
  std::vector<char> fixed(m.nodes.size(), 0);
  std::vector<Eigen::Vector3d> x0 = m.nodes;
  for (std::size_t i = 0; i < m.nodes.size(); ++i) {
    if (m.nodes[i].x() < 1e-9) fixed[i] = 1;
    if (m.nodes[i].x() > kL - 1e-9 && pulled[i]) {
      fixed[i] = 1;
      x0[i].x() += kU;
    }
  }
  StaticSolveOptions o;
  o.tolerance = 1e-10;
  const StaticSolveResult r = solveStatic(m, K, fixed, x0, o);
  EXPECT_TRUE(r.converged);
  Pulled p{r.x, 0.0};
  const auto f = internalForces(m, K, r.x);
  for (std::size_t i = 0; i < m.nodes.size(); ++i)
    if (m.nodes[i].x() > kL - 1e-9 && pulled[i]) p.reaction -= f[i].x();  // what the pull must supply
  return p;
}

}  // namespace

TEST(TissueCut, ABarCutThroughTransmitsNothing) {
  // Cut across at x = 10 (a plane of nodes: 16 of them copied): pulled at x = 20 and held at
  // x = 0, the far half moves rigidly and the near one stays at rest; the force is 0 against
  // E A U / L = 1 * 36 * 0.05 / 20 = 0.09 uncut. Bounds: 1e-6 of the motion, 1e-6 of the uncut force.
  const TetMesh m = bar();
  const MeshCut c = cutMesh(m, quadX(10.0, -1.0, 7.0, -1.0, 7.0));
  EXPECT_EQ(c.mesh.nodes.size(), m.nodes.size() + 16);
  EXPECT_EQ(c.cutFaces, 3u * 3 * 2);  // 9 cells' faces on the plane, two triangles each
  const std::vector<char> all(c.mesh.nodes.size(), 1);
  const double uncut = pull(m, std::vector<char>(m.nodes.size(), 1)).reaction;
  const Pulled p = pull(c.mesh, all);
  std::printf("uncut %.6f, cut through %.2e (E A U / L %.6f)\n", uncut, p.reaction, kE * 36 * kU / kL);
  EXPECT_NEAR(uncut, kE * 36 * kU / kL, 1e-9);
  EXPECT_LT(std::abs(p.reaction), 1e-6 * uncut);
  const std::vector<char> far = nodesOfTets(c.mesh, [](const Eigen::Vector3d& x) { return x.x() > 10.0; });
  for (std::size_t i = 0; i < c.mesh.nodes.size(); ++i) {
    const Eigen::Vector3d u = p.x[i] - c.mesh.nodes[i];
    EXPECT_LT((u - (far[i] ? Eigen::Vector3d(kU, 0, 0) : Eigen::Vector3d::Zero())).norm(), 1e-6 * kU) << "node " << i;
  }
  // An oblique cut (tilted 30 degrees about y, off the lattice's planes) separates as fully: along
  // the faces between the tets on either side of it, a staircase.
  const double s = std::tan(M_PI / 6);
  const CutQuad oblique{{Eigen::Vector3d(10 - s, -1, -1), Eigen::Vector3d(10 - s, 7, -1), Eigen::Vector3d(10 + 7 * s, 7, 7), Eigen::Vector3d(10 + 7 * s, -1, 7)}};
  const MeshCut o = cutMesh(m, oblique);
  const double obliqueForce = pull(o.mesh, std::vector<char>(o.mesh.nodes.size(), 1)).reaction;
  std::printf("oblique cut: %zu faces, %zu nodes copied, force %.2e\n", o.cutFaces, o.mesh.nodes.size() - m.nodes.size(), obliqueForce);
  EXPECT_LT(std::abs(obliqueForce), 1e-6 * uncut);
}

TEST(TissueCut, ABarSplitAlongItsLengthTransmitsThePulledPartsForce) {
  // Split at z = 2 over the whole length and only the upper part's end pulled: the upper 6 x 4 mm
  // section carries E A U / L = 1 * 24 * 0.05 / 20 = 0.06 (uniform, exact with nu = 0) and the
  // lower part stays at rest. Bound: 1e-6 relative (the solve's tolerance).
  const TetMesh m = bar();
  const MeshCut c = cutMesh(m, {{Eigen::Vector3d(-1, -1, 2), Eigen::Vector3d(21, -1, 2), Eigen::Vector3d(21, 7, 2), Eigen::Vector3d(-1, 7, 2)}});
  EXPECT_EQ(c.mesh.nodes.size(), m.nodes.size() + 11 * 4);  // the z = 2 plane's nodes
  const std::vector<char> upper = nodesOfTets(c.mesh, [](const Eigen::Vector3d& x) { return x.z() > 2.0; });
  const Pulled p = pull(c.mesh, upper);
  std::printf("split: %.6f (E A U / L %.6f)\n", p.reaction, kE * 24 * kU / kL);
  EXPECT_NEAR(p.reaction, kE * 24 * kU / kL, 1e-6 * kE * 24 * kU / kL);
  for (std::size_t i = 0; i < c.mesh.nodes.size(); ++i)
    if (!upper[i]) {
      EXPECT_LT((p.x[i] - c.mesh.nodes[i]).norm(), 1e-6 * kU) << "lower node " << i;
    }
}

TEST(TissueCut, ACutPartWayAcrossKeepsItsEdgeJoinedAndEachCopyOnOneSide) {
  // Across at x = 10 over y < 2 only (a third of the section): the y = 0 row of the plane's nodes
  // (4) is copied, the y = 2 row (the cut's edge) is not; every node that was copied has all its
  // tets on one side. The force lies between nothing and the uncut bar's, close to the latter (the
  // crack's compliance is local: measured 0.0853 of 0.09).
  const TetMesh m = bar();
  const MeshCut c = cutMesh(m, quadX(10.0, -1.0, 2.0, -1.0, 7.0));
  EXPECT_EQ(c.mesh.nodes.size(), m.nodes.size() + 4);
  std::vector<int> copies(m.nodes.size(), 0);
  for (int s : c.sourceNode) ++copies[std::size_t(s)];
  std::vector<int> side(c.mesh.nodes.size(), 0);  // +1 / -1: its tets' side; 2: both
  for (std::size_t t = 0; t < c.mesh.tets.size(); ++t) {
    const int s = centroidOf(c.mesh, t).x() > 10.0 ? 1 : -1;
    for (int n : c.mesh.tets[t]) side[std::size_t(n)] = side[std::size_t(n)] == 0 || side[std::size_t(n)] == s ? s : 2;
  }
  for (std::size_t i = 0; i < c.mesh.nodes.size(); ++i) {
    const int s = c.sourceNode[i];
    EXPECT_EQ(c.mesh.nodes[i], m.nodes[std::size_t(s)]) << "a copy sits where its node was";
    if (copies[std::size_t(s)] > 1) {
      EXPECT_NE(side[i], 2) << "node " << i;
    }
    const bool edge = std::abs(m.nodes[std::size_t(s)].x() - 10.0) < 1e-9 && std::abs(m.nodes[std::size_t(s)].y() - 2.0) < 1e-9;
    if (edge) {
      EXPECT_EQ(copies[std::size_t(s)], 1) << "the cut's edge";
    }
  }
  const double uncut = pull(m, std::vector<char>(m.nodes.size(), 1)).reaction;
  const double half = pull(c.mesh, std::vector<char>(c.mesh.nodes.size(), 1)).reaction;
  std::printf("cut a third of the way across: %.6f of %.6f\n", half, uncut);
  EXPECT_GT(half, 0.1 * uncut);
  EXPECT_LT(half, 0.99 * uncut);
}

TEST(TissueCut, ACutAcrossAnEarlierOneAndRefusals) {
  // A second cut across the first (the split, then across at x = 10): both apply, and the far
  // quarters, pulled, transmit nothing to the held end. The same cut again separates nothing: refused. So are a quad with
  // a non-finite corner, no area, corners off one plane, a bow tie, one that misses the mesh, and
  // one that would leave a tet on its own (two tets joined by one face, cut along it); a dart (a
  // non-convex quad with an area); and a quad narrower than the mesh's faces (nothing separates).
  // Either winding of a quad cuts alike.
  const TetMesh m = bar();
  const CutQuad split{{Eigen::Vector3d(-1, -1, 2), Eigen::Vector3d(21, -1, 2), Eigen::Vector3d(21, 7, 2), Eigen::Vector3d(-1, 7, 2)}};
  const MeshCut first = cutMesh(m, split);
  const MeshCut second = cutMesh(first.mesh, quadX(10.0, -1.0, 7.0, -1.0, 7.0));
  EXPECT_GT(second.mesh.nodes.size(), first.mesh.nodes.size());
  EXPECT_EQ(second.sourceNode.size(), second.mesh.nodes.size());
  for (int s : second.sourceNode) EXPECT_LT(std::size_t(s), first.mesh.nodes.size());
  const Pulled p = pull(second.mesh, std::vector<char>(second.mesh.nodes.size(), 1));
  EXPECT_LT(std::abs(p.reaction), 1e-6 * kE * 36 * kU / kL) << "the pulled quarters are cut off from the held end";
  EXPECT_THROW(cutMesh(first.mesh, split), Error);

  const double nan = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW(checkCutQuad(quadX(nan, 0, 1, 0, 1)), Error);
  EXPECT_THROW(checkCutQuad(quadX(10, 0, 0, 0, 1)), Error);
  CutQuad warped = quadX(10.0, 0.0, 6.0, 0.0, 6.0);
  warped.corners[2].x() += 1.0;
  EXPECT_THROW(checkCutQuad(warped), Error);
  CutQuad bowTie = quadX(10.0, 0.0, 6.0, 0.0, 6.0);
  std::swap(bowTie.corners[1], bowTie.corners[2]);
  EXPECT_THROW(checkCutQuad(bowTie), Error);
  EXPECT_NO_THROW(checkCutQuad(quadX(10.0, 0.0, 6.0, 0.0, 6.0)));
  CutQuad dart = quadX(10.0, 0.0, 6.0, 0.0, 6.0);  // a corner pushed in past the diagonal: area, not convex
  dart.corners[2] = Eigen::Vector3d(10.0, 2.0, 2.0);
  EXPECT_THROW(checkCutQuad(dart), Error);
  // Either winding cuts alike.
  CutQuad clockwise = quadX(10.0, -1.0, 7.0, -1.0, 7.0);
  std::swap(clockwise.corners[1], clockwise.corners[3]);
  const MeshCut a = cutMesh(m, clockwise), b = cutMesh(m, quadX(10.0, -1.0, 7.0, -1.0, 7.0));
  EXPECT_EQ(a.mesh.tets, b.mesh.tets);
  EXPECT_EQ(a.sourceNode, b.sourceNode);
  // A quad narrower than the mesh's faces cuts faces whose nodes all stay shared: nothing separates.
  EXPECT_THROW(cutMesh(m, quadX(10.0, 2.4, 2.6, 2.4, 2.6)), Error);
  EXPECT_THROW(cutMesh(m, quadX(100.0, -1.0, 7.0, -1.0, 7.0)), Error);
  TetMesh pair;
  pair.nodes = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {0, 0, -1}};
  pair.tets = {{0, 1, 2, 3}, {0, 2, 1, 4}};
  EXPECT_THROW(cutMesh(pair, {{Eigen::Vector3d(-1, -1, 0), Eigen::Vector3d(2, -1, 0), Eigen::Vector3d(2, 2, 0), Eigen::Vector3d(-1, 2, 0)}}), Error);
}

namespace {

// The brute-force reference for TetIncidence::across: every tet's faces sorted by their node
// triples; two equal neighbours share a face. Per slot (4 t + f): the tet across, or -1.
std::vector<int> acrossBySorting(const TetMesh& m) {
  std::vector<std::pair<std::array<int, 3>, int>> faces;
  for (std::size_t t = 0; t < m.tets.size(); ++t)
    for (int f = 0; f < 4; ++f) {
      std::array<int, 3> k{};
      for (int i = 0, j = 0; i < 4; ++i)
        if (i != f) k[std::size_t(j++)] = m.tets[t][std::size_t(i)];
      std::sort(k.begin(), k.end());
      faces.push_back({k, int(4 * t) + f});
    }
  std::sort(faces.begin(), faces.end());
  std::vector<int> across(faces.size(), -1);
  for (std::size_t i = 0; i + 1 < faces.size(); ++i)
    if (faces[i].first == faces[i + 1].first) {
      across[std::size_t(faces[i].second)] = faces[i + 1].second / 4;
      across[std::size_t(faces[i + 1].second)] = faces[i].second / 4;
    }
  return across;
}

// The bar with its nodes moved off the lattice (deterministically, up to 0.3 of a 2 mm cell along
// each axis; the end faces' nodes stay on their planes x = 0 and x = L, the sides' on theirs), so
// its tets differ in shape and size and no face lies in a lattice plane.
TetMesh unevenBar() {
  TetMesh m = bar();
  unsigned state = 12345;
  auto jitter = [&state] {
    state = state * 1103515245u + 12345u;
    return 0.6 * (double((state >> 8) & 0xffff) / 65535.0 - 0.5);
  };
  for (Eigen::Vector3d& x : m.nodes)
    for (int a = 0; a < 3; ++a) {
      const double extent = a == 0 ? kL : 6.0, j = jitter();
      if (x[a] > 1e-9 && x[a] < extent - 1e-9) x[a] += j;
    }
  return m;
}

}  // namespace

TEST(TissueCut, TheTetAcrossEachFaceIsTheOneASortOfAllFacesFinds) {
  // On the bar, on the bar cut through obliquely (its separated faces have none across) and on an
  // uneven bar: the incidence's answer for every face equals the sort's. A face of three tets throws.
  const TetMesh m = bar();
  const double s = std::tan(M_PI / 6);
  const MeshCut cut = cutMesh(m, {{Eigen::Vector3d(10 - s, -1, -1), Eigen::Vector3d(10 - s, 7, -1), Eigen::Vector3d(10 + 7 * s, 7, 7), Eigen::Vector3d(10 + 7 * s, -1, 7)}});
  const TetMesh uneven = unevenBar();
  std::vector<std::size_t> boundaries;
  for (const TetMesh* mesh : {&m, &cut.mesh, &uneven}) {
    const TetIncidence inc(*mesh);
    const std::vector<int> expected = acrossBySorting(*mesh);
    std::size_t boundary = 0;
    for (std::size_t slot = 0; slot < expected.size(); ++slot) {
      EXPECT_EQ(inc.across(*mesh, int(slot / 4), int(slot % 4)), expected[slot]) << "slot " << slot;
      boundary += expected[slot] < 0;
    }
    std::printf("%zu tets, %zu faces with no tet across\n", mesh->tets.size(), boundary);
    boundaries.push_back(boundary);
  }
  EXPECT_EQ(boundaries[1], boundaries[0] + 2 * cut.cutFaces) << "each separated face, on either side";
  TetMesh three;
  three.nodes = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {0, 0, -1}, {0.2, 0.2, 1}};
  three.tets = {{0, 1, 2, 3}, {0, 2, 1, 4}, {0, 1, 2, 5}};
  EXPECT_THROW(TetIncidence(three).across(three, 0, 3), Error);
}

TEST(TissueCut, ACutThroughAMeshOfUnevenTetsSeparatesItFully) {
  // The cut looks only at tets within the mesh's longest edge of the quad: on tets of uneven size
  // (the uneven bar) an oblique cut through must still find every face between the sides, or the
  // bar would transmit force through the one it missed. nu = 0 keeps the uncut answer exact on any
  // tets (a uniform strain): E A U / L = 0.09. Bounds as for the lattice's bar.
  const TetMesh m = unevenBar();
  const double uncut = pull(m, std::vector<char>(m.nodes.size(), 1)).reaction;
  EXPECT_NEAR(uncut, kE * 36 * kU / kL, 1e-9);
  const double s = std::tan(M_PI / 6);
  const MeshCut c = cutMesh(m, {{Eigen::Vector3d(10 - s, -1, -1), Eigen::Vector3d(10 - s, 7, -1), Eigen::Vector3d(10 + 7 * s, 7, 7), Eigen::Vector3d(10 + 7 * s, -1, 7)}});
  const double force = pull(c.mesh, std::vector<char>(c.mesh.nodes.size(), 1)).reaction;
  std::printf("uneven bar: uncut %.6f, cut through obliquely %.2e (%zu faces, %zu nodes copied)\n", uncut, force, c.cutFaces, c.mesh.nodes.size() - m.nodes.size());
  EXPECT_LT(std::abs(force), 1e-6 * uncut);
}

TEST(TissueCut, ARuledSurfaceOfQuadsCutAtOnceLeavesNoSeam) {
  // The cut a finger's stroke makes (docs/cutting.md): the view rays from an eye 200 mm above a 40 x
  // 20 x 20 mm block of 2 mm Kuhn cells, along x = 11.3 from y = -4 to 24 every 4 mm, each pair of
  // rays a quad from the top face (z = 20) to 15 mm past the first ray's surface distance (down to
  // z = 4.4-5.0). Their joints start on the lattice's planes y = 0, 4, ..., 20 at the top and slant
  // along them (y = 12 to 12.16 at the bottom). Applied one after another the quads leave a seam
  // there: faces on a joint, the earlier quad's, whose nodes stayed joined through the later quad's
  // faces (measured 104 tet-node incidences joining the two sides above z = 6). Cut at once
  // (cutMeshAlong) none join them, as one big quad in the same plane leaves none.
  const TetMesh block = KuhnGrid({0, 0, 0}, {2, 2, 2}, {20, 10, 10}).mesh();
  const Eigen::Vector3d eye(11.3, 10, 220);
  auto surfaceAt = [&](double y) { return Eigen::Vector3d(11.3, y, 20); };
  const double bottom = (surfaceAt(-4) - eye).norm() + 15.0;
  std::vector<CutQuad> surface;
  for (double y = -4; y < 24 - 1e-9; y += 4) {
    const Eigen::Vector3d a = surfaceAt(y), b = surfaceAt(y + 4);
    surface.push_back({{a, b, eye + bottom * (b - eye).normalized(), eye + bottom * (a - eye).normalized()}});
  }
  const CutPlane plane = cutPlane(surface.front());
  auto joined = [&](const TetMesh& m) {  // tet-node incidences joining the two sides above z = 6
    std::vector<int> side(m.nodes.size(), 0);
    int count = 0;
    for (const auto& t : m.tets) {
      const Eigen::Vector3d c = 0.25 * (m.nodes[std::size_t(t[0])] + m.nodes[std::size_t(t[1])] + m.nodes[std::size_t(t[2])] + m.nodes[std::size_t(t[3])]);
      if (c.z() < 6.0) continue;
      const int s = plane.height(c) >= 0.0 ? 1 : -1;
      for (int n : t) {
        count += side[std::size_t(n)] == -s && m.nodes[std::size_t(n)].z() > 6.0;
        side[std::size_t(n)] = s;
      }
    }
    return count;
  };
  TetMesh inTurn = block;
  for (const CutQuad& q : surface) {
    try {
      inTurn = cutMesh(inTurn, q).mesh;
    } catch (const Error&) {  // the quads off the block separate nothing
    }
  }
  const MeshCut atOnce = cutMeshAlong(block, surface);
  const int seam = joined(inTurn), none = joined(atOnce.mesh);
  std::printf("quads in turn: %d joining incidences; at once: %d (%zu faces, %zu nodes copied)\n", seam, none, atOnce.cutFaces,
              atOnce.mesh.nodes.size() - block.nodes.size());
  EXPECT_GT(seam, 0) << "the seam this cut exists to close";
  EXPECT_EQ(none, 0);
  EXPECT_THROW(cutMeshAlong(block, {}), Error);
}
