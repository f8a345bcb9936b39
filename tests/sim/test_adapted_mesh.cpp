// The TetGen wrapper and the image-adapted fine mesh: conforming, nested in the coarse cells, points
// only at stiffness jumps, usable by the coarse model and the resampling.
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <map>
#include <random>

#include "sim/adapted_mesh.h"
#include "sim/coarsening.h"
#include "sim/base/error.h"
#include "sim/phantom.h"
#include "sim/sim_scene.h"
#include "sim/tet_raster.h"
#include "sim/tetgen_mesher.h"

using namespace handson;

namespace {

// The unit cube's 8 corners and its 12 surface triangles.
std::vector<std::array<int, 3>> cubeTriangles() {
  // Corner q at (q & 1, q >> 1 & 1, q >> 2 & 1); two triangles per face.
  return {{0, 1, 3}, {0, 3, 2}, {4, 5, 7}, {4, 7, 6}, {0, 1, 5}, {0, 5, 4}, {2, 3, 7}, {2, 7, 6}, {0, 2, 6}, {0, 6, 4}, {1, 3, 7}, {1, 7, 5}};
}
std::vector<Eigen::Vector3d> cubeCorners() {
  std::vector<Eigen::Vector3d> p;
  for (int q = 0; q < 8; ++q) p.emplace_back(q & 1, (q >> 1) & 1, (q >> 2) & 1);
  return p;
}

double tetVolume(const TetMesh& m, std::size_t t) { return std::abs(m.signedVolume(int(t))); }

// How many tets own each triangular face (sorted node triple): 2 inside a conforming mesh, 1 on its boundary.
std::map<std::array<int, 3>, int> faceCounts(const std::vector<std::array<int, 4>>& tets) {
  std::map<std::array<int, 3>, int> faces;
  for (const auto& t : tets)
    for (int k = 0; k < 4; ++k) {
      std::array<int, 3> f{};
      for (int j = 0, i = 0; j < 4; ++j)
        if (j != k) f[std::size_t(i++)] = t[std::size_t(j)];
      std::sort(f.begin(), f.end());
      ++faces[f];
    }
  return faces;
}

}  // namespace

TEST(TetgenMesher, MeshesACubeWithAnInteriorPointAndKeepsItsSurface) {
  auto pts = cubeCorners();
  pts.emplace_back(0.4, 0.55, 0.5);
  const TetgenResult r = tetrahedralizeSurface(pts, cubeTriangles());
  ASSERT_TRUE(r.ok) << r.message;
  TetMesh m{pts, r.tets};
  double vol = 0;
  bool usesInterior = false;
  for (std::size_t t = 0; t < r.tets.size(); ++t) {
    EXPECT_GT(m.signedVolume(int(t)), 0.0) << "positive orientation";
    vol += m.signedVolume(int(t));
    for (int v : r.tets[t]) usesInterior = usesInterior || v == 8;
  }
  EXPECT_NEAR(vol, 1.0, 1e-12);
  EXPECT_TRUE(usesInterior);
  // Every boundary face of the mesh is one of the 12 input triangles (nothing split).
  const auto faces = faceCounts(r.tets);
  std::size_t boundary = 0;
  for (const auto& [f, n] : faces) {
    EXPECT_LE(n, 2);
    if (n == 1) {
      ++boundary;
      bool input = false;
      for (auto tri : cubeTriangles()) {
        std::sort(tri.begin(), tri.end());
        input = input || tri == f;
      }
      EXPECT_TRUE(input);
    }
  }
  EXPECT_EQ(boundary, 12u);
}

TEST(TetgenMesher, BadInputIsAStatusNotACrash) {
  auto pts = cubeCorners();
  auto tris = cubeTriangles();
  tris[3][1] = 42;
  TetgenResult r = tetrahedralizeSurface(pts, tris);
  EXPECT_FALSE(r.ok);
  EXPECT_NE(r.message.find("missing point"), std::string::npos);
  pts[2].x() = std::nan("");
  r = tetrahedralizeSurface(pts, cubeTriangles());
  EXPECT_FALSE(r.ok);
  EXPECT_FALSE(r.message.empty());
  r = tetrahedralizeSurface({{0, 0, 0}, {1, 0, 0}}, {});
  EXPECT_FALSE(r.ok);
  // A triangle piercing the cube's faces: TetGen itself fails (its error path frees its memory
  // twice, so it runs in a child process): a status here, and this process goes on.
  pts = cubeCorners();
  tris = cubeTriangles();
  pts.emplace_back(0.5, 0.5, -0.5);
  pts.emplace_back(0.5, -0.3, 1.5);
  pts.emplace_back(0.5, 1.3, 1.5);
  tris.push_back({8, 9, 10});
  r = tetrahedralizeSurface(pts, tris);
  EXPECT_FALSE(r.ok);
  EXPECT_NE(r.message.find("TetGen"), std::string::npos) << r.message;
  // And the next call works.
  auto good = cubeCorners();
  good.emplace_back(0.5, 0.5, 0.5);
  EXPECT_TRUE(tetrahedralizeSurface(good, cubeTriangles()).ok);
}

namespace {
// A 60 x 50 x 40 mm box with a ball 1000x stiffer than the rest.
const Eigen::Vector3d kLo(0, 0, 0), kHi(60, 50, 40), kBall(31, 24, 19);
constexpr double kRadius = 11.0;
double ballYoungs(const Eigen::Vector3d& p) { return (p - kBall).norm() < kRadius ? 6000.0 : 6.0; }
}  // namespace

TEST(AdaptedMesh, ConformsNestsInCellsAndAddsPointsOnlyAtTheStiffnessJump) {
  AdaptedMeshStats st;
  const NestedMeshes nm = buildImageAdaptedMeshes({kLo, kHi, 400, 64, ballYoungs, 10.0}, {}, &st);
  const NestedMeshes reg = buildNestedMeshes(kLo, kHi, 400, 64);
  const TetMesh& F = nm.fine;
  EXPECT_FALSE(nm.regularFine);
  EXPECT_EQ(st.fallbackCells, 0u) << st.firstFailure;
  EXPECT_GT(st.structurePoints, 0u);
  EXPECT_EQ(F.nodes.size(), reg.fine.nodes.size() + st.structurePoints) << "the regular lattice plus the structure points";
  // The extra points lie within one half-lattice step of the ball's surface.
  const double step = nm.fineGrid.cell().norm() / 2.0;
  std::vector<char> lattice(F.nodes.size(), 0);
  for (std::size_t n = 0; n < F.nodes.size(); ++n) {
    const Eigen::Vector3d g = (F.nodes[n] - nm.fineGrid.origin()).cwiseQuotient(nm.fineGrid.cell());
    lattice[n] = ((g - g.array().round().matrix()).array().abs() < 1e-9).all();
    if (!lattice[n]) {
      EXPECT_LT(std::abs((F.nodes[n] - kBall).norm() - kRadius), step) << "point " << n;
    }
  }
  // Nested: each cell's tets lie in that cell and fill it; the parent is a coarse tet of that cell.
  ASSERT_EQ(nm.cellTetStart.size(), nm.coarseGrid.cellCount() + 1);
  const double cellVolume = nm.coarseGrid.cell().prod();
  for (std::size_t c = 0; c < nm.coarseGrid.cellCount(); ++c) {
    const auto corners = nm.coarseGrid.cellNodes(int(c));
    const Eigen::Vector3d clo = nm.coarse.nodes[std::size_t(corners[0])], chi = nm.coarse.nodes[std::size_t(corners[7])];
    double vol = 0;
    for (int k = nm.cellTetStart[c]; k < nm.cellTetStart[c + 1]; ++k) {
      const auto t = std::size_t(nm.cellTets[std::size_t(k)]);
      vol += tetVolume(F, t);
      EXPECT_EQ(nm.fineParent[t] / 6, int(c));
      for (int v : F.tets[t]) EXPECT_TRUE(((F.nodes[std::size_t(v)] - clo).array() > -1e-9).all() && ((chi - F.nodes[std::size_t(v)]).array() > -1e-9).all());
    }
    EXPECT_NEAR(vol, cellVolume, 1e-9 * cellVolume) << "cell " << c;
  }
  // Conforming: every face is shared by two tets except on the box's outer faces.
  const auto faces = faceCounts(F.tets);
  for (const auto& [f, n] : faces) {
    ASSERT_LE(n, 2);
    if (n == 1) {
      bool outer = false;
      for (int a = 0; a < 3 && !outer; ++a) {
        bool allLo = true, allHi = true;
        for (int v : f) {
          allLo = allLo && std::abs(F.nodes[std::size_t(v)][a] - kLo[a]) < 1e-9;
          allHi = allHi && std::abs(F.nodes[std::size_t(v)][a] - kHi[a]) < 1e-9;
        }
        outer = allLo || allHi;
      }
      ASSERT_TRUE(outer) << "a face inside the box belongs to one tet only: a crack between cells";
    }
  }
  // Coarse nodes are fine nodes at the same place.
  for (std::size_t v = 0; v < nm.coarse.nodes.size(); ++v) EXPECT_LT((F.nodes[std::size_t(nm.coarseNodeInFine[v])] - nm.coarse.nodes[v]).norm(), 1e-12);
  // locateFine finds a tet that holds the point.
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> ux(0, 60), uy(0, 50), uz(0, 40);
  for (int i = 0; i < 500; ++i) {
    const Eigen::Vector3d p(ux(rng), uy(rng), uz(rng));
    const int t = nm.locateFine(p);
    ASSERT_GE(t, 0);
    const auto& v = F.tets[std::size_t(t)];
    Eigen::Matrix3d D;
    D << F.nodes[std::size_t(v[1])] - F.nodes[std::size_t(v[0])], F.nodes[std::size_t(v[2])] - F.nodes[std::size_t(v[0])],
        F.nodes[std::size_t(v[3])] - F.nodes[std::size_t(v[0])];
    const Eigen::Vector3d l = D.inverse() * (p - F.nodes[std::size_t(v[0])]);
    EXPECT_GE(std::min({1.0 - l.sum(), l.x(), l.y(), l.z()}), -1e-9);
  }
  EXPECT_EQ(nm.locateFine({-1, 5, 5}), -1);
}

TEST(AdaptedMesh, HomogeneousMaterialGivesTheRegularMesh) {
  AdaptedMeshStats st;
  const NestedMeshes nm = buildImageAdaptedMeshes({kLo, kHi, 400, 64, [](const Eigen::Vector3d&) { return 6.0; }, 10.0}, {}, &st);
  const NestedMeshes reg = buildNestedMeshes(kLo, kHi, 400, 64);
  EXPECT_EQ(st.structurePoints, 0u);
  EXPECT_EQ(nm.fine.tets.size(), reg.fine.tets.size());
  EXPECT_EQ(nm.fine.nodes.size(), reg.fine.nodes.size());
  EXPECT_THROW(buildImageAdaptedMeshes({kLo, kHi, 400, 64, ballYoungs, 0.5}), Error);
}

TEST(AdaptedMesh, PhantomSceneRunsTheCoarseModelAndResamplesWithoutCracks) {
  PhantomOptions po;
  po.spacingMm = 4.0;
  const Phantom p = makePhantom(po);
  SimHandle h;
  h.voxels = voxelsLabelled(p.labels, label::kKidneyRight);
  SimSettings s;
  s.coarseTets = 300;
  s.fineTets = 300 * 64;
  s.fineMesh = SimSettings::FineMesh::ImageAdapted;
  const SimScene sc = buildSimScene(p.ct, {h}, s);
  EXPECT_GT(sc.adapted.structurePoints, 0u) << "bone and vessels in the region";
  EXPECT_EQ(sc.adapted.fallbackCells, 0u) << sc.adapted.firstFailure;
  EXPECT_THROW(CoarseModel(sc.meshes, sc.fineK, sc.constraints, {}, CoarseElement::Tet), Error) << "tets need the regular fine mesh";
  s.element = CoarseElement::Tet;
  EXPECT_THROW(buildSimScene(p.ct, {h}, s), Error);
  CoarseModel model(sc.meshes, sc.fineK, sc.constraints);
  // Zero motion: the coarse state stays at rest and the resampled image equals the input.
  auto xc = model.restState();
  ASSERT_TRUE(model.solve({RigidTransform{}}, xc, 10).converged);
  const auto x = model.reconstruct({RigidTransform{}}, xc);
  double worst = 0;
  for (std::size_t n = 0; n < x.size(); ++n) worst = std::max(worst, (x[n] - sc.meshes.fine.nodes[n]).norm());
  EXPECT_LT(worst, 1e-9) << "mm";
  Volume out;
  const RasterStats rs = rasterizeDeformed(p.ct, sc.meshes.fine, x, {sc.lo, sc.hi, -1000.0f}, out);
  std::size_t differ = 0, inRegionVoxels = 0;
  const VolumeGeometry& g = p.ct.geometry();
  for (int k = 0; k < g.dims.z(); ++k)
    for (int j = 0; j < g.dims.y(); ++j)
      for (int i = 0; i < g.dims.x(); ++i) {
        if (!inRegion(g.toWorld(Eigen::Vector3d(i, j, k)), sc.lo, sc.hi)) continue;
        ++inRegionVoxels;
        differ += std::abs(out.value(i, j, k) - p.ct.value(i, j, k)) > 0.5f ? 1 : 0;
      }
  EXPECT_GT(inRegionVoxels, 1000u);
  EXPECT_EQ(differ, 0u) << "every region voxel sampled at its own place";
  EXPECT_EQ(rs.covered, rs.regionVoxels) << "no cracks";
  EXPECT_EQ(rs.skipped, 0u);
  // Moved: the kidney's nodes follow it and the solve converges.
  const std::vector<RigidTransform> T = {RigidTransform::about(sc.handleCentroid[0], Eigen::Vector3d(0, 0, 0.3), Eigen::Vector3d(8, 0, 0))};
  ASSERT_TRUE(model.solve(T, xc, 100).converged);
  const auto moved = model.reconstruct(T, xc);
  for (std::size_t n = 0; n < moved.size(); ++n)
    if (sc.constraints.handleOf[n] == 0 && !sc.constraints.fixed[n]) {
      ASSERT_LT((moved[n] - T[0].apply(sc.meshes.fine.nodes[n])).norm(), 1e-9);
    }
}
