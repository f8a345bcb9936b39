// The region shaped by the handles (sim/region_shape.h): its cells against brute force, the scene's
// held nodes, and the coarse solve that visits only the elements with a free corner against the
// assembled one that visits them all.
#include <gtest/gtest.h>

#include <algorithm>
#include <random>

#include "sim/coarsening.h"
#include "sim/base/error.h"
#include "sim/phantom.h"
#include "sim/region_shape.h"
#include "sim/sim_scene.h"

using namespace handson;

namespace {

std::vector<Eigen::Vector3d> cubeCentres(int n, double spacing, const Eigen::Vector3d& origin) {
  std::vector<Eigen::Vector3d> p;
  for (int z = 0; z < n; ++z)
    for (int y = 0; y < n; ++y)
      for (int x = 0; x < n; ++x) p.push_back(origin + spacing * Eigen::Vector3d(x + 0.5, y + 0.5, z + 0.5));
  return p;
}

double boxDistance(const KuhnGrid& g, int c, const Eigen::Vector3d& p) {
  const Eigen::Vector3d lo = g.nodePosition(g.cellNodes(c)[0]), hi = lo + g.cell();
  return (p - p.cwiseMax(lo).cwiseMin(hi)).norm();
}

bool insideCell(const KuhnGrid& g, int c, const Eigen::Vector3d& p) { return boxDistance(g, c, p) == 0.0; }

// The 4 mm phantom with its right kidney as the handle, and settings of `coarseTets` (8 fine tets
// each) padded by `paddingMm`.
struct KidneyPhantom {
  Phantom phantom;
  SimHandle handle;
  KidneyPhantom() {
    PhantomOptions po;
    po.spacingMm = 4.0;
    phantom = makePhantom(po);
    handle.voxels = voxelsLabelled(phantom.labels, label::kKidneyRight);
  }
  SimSettings settings(int coarseTets, double paddingMm) const {
    SimSettings s;
    s.coarseTets = coarseTets;
    s.fineTets = coarseTets * 8;
    s.paddingMm = paddingMm;
    return s;
  }
};

}  // namespace

TEST(RegionShape, ThinnedPointsKeepOnePerBucketAndMarkTheOutside) {
  // A 10 mm cube of 1 mm voxel centres: 1,000 buckets of 1 mm, of which the 8^3 inner ones have all
  // six neighbours; 125 buckets of 2 mm, 27 of them inner.
  const auto centres = cubeCentres(10, 1.0, Eigen::Vector3d(0.0, 0.0, 0.0));
  const HandlePoints fine = thinHandlePoints(centres, 1.0), coarse = thinHandlePoints(centres, 2.0);
  EXPECT_EQ(fine.point.size(), 1000u);
  EXPECT_EQ(std::count(fine.surface.begin(), fine.surface.end(), 1), 1000 - 512);
  EXPECT_EQ(coarse.point.size(), 125u);
  EXPECT_EQ(std::count(coarse.surface.begin(), coarse.surface.end(), 1), 125 - 27);
  EXPECT_THROW(thinHandlePoints(centres, 0.0), Error);
  EXPECT_THROW(thinHandlePoints({Eigen::Vector3d(0, std::nan(""), 0)}, 1.0), Error);
}

TEST(RegionShape, CellsNearThePointsEqualBruteForce) {
  const KuhnGrid g(Eigen::Vector3d(-20, -10, 5), Eigen::Vector3d(7, 9, 8), Eigen::Vector3i(9, 7, 8));
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> ux(-30, 60), uy(-20, 60), uz(0, 75);
  HandlePoints pts;
  for (int i = 0; i < 60; ++i) {
    pts.point.emplace_back(ux(rng), uy(rng), uz(rng));
    pts.surface.push_back(i % 3 != 0);  // a third of them inside the handle: they mark their own cell only
  }
  for (double pad : {0.0, 3.5, 12.0, 30.0}) {
    const std::vector<char> in = cellsNearPoints(g, pts, pad);
    ASSERT_EQ(in.size(), g.cellCount());
    for (std::size_t c = 0; c < g.cellCount(); ++c) {
      bool expect = false;
      for (std::size_t i = 0; i < pts.point.size(); ++i)
        expect = expect || insideCell(g, int(c), pts.point[i]) || (pts.surface[i] && boxDistance(g, int(c), pts.point[i]) <= pad);
      EXPECT_EQ(in[c] != 0, expect) << "cell " << c << ", padding " << pad;
    }
  }
  EXPECT_THROW(cellsNearPoints(g, pts, -1.0), Error);
  // The boundary check: a ball that reaches a held cell.
  std::vector<char> all(g.cellCount(), 1);
  const Eigen::Vector3d mid = g.origin() + 0.5 * g.cell().cwiseProduct(g.cells().cast<double>());
  EXPECT_FALSE(nearRegionBoundary(g, all, mid, 10.0));
  all[0] = 0;  // the lowest corner cell held
  EXPECT_FALSE(nearRegionBoundary(g, all, mid, 10.0));
  EXPECT_TRUE(nearRegionBoundary(g, all, g.origin() + Eigen::Vector3d(8, 10, 9), 2.0));
  EXPECT_FALSE(nearRegionBoundary(g, {}, g.origin(), 5.0)) << "no shaped region: the box alone";
}

TEST(RegionShape, SceneHoldsTheCellsAwayFromTheKidneyAndSpendsItsBudgetOnTheRest) {
  const KidneyPhantom k;
  const Phantom& p = k.phantom;
  const SimHandle& h = k.handle;
  SimSettings s = k.settings(3000, 40.0);
  const SimScene box = buildSimScene(p.ct, {h}, s);
  s.region = SimSettings::Region::Handles;
  const SimScene shaped = buildSimScene(p.ct, {h}, s);
  ASSERT_TRUE(box.regionCell.empty());
  ASSERT_EQ(shaped.regionCell.size(), shaped.meshes.coarseGrid.cellCount());
  EXPECT_EQ(shaped.lo, box.lo);
  EXPECT_EQ(shaped.hi, box.hi);
  const auto in = std::count(shaped.regionCell.begin(), shaped.regionCell.end(), 1);
  const double share = double(in) / double(shaped.regionCell.size());
  std::printf("shaped: %ld of %zu cells (%.2f), %zu coarse tets against the box's %zu\n", long(in), shaped.regionCell.size(), share,
              shaped.meshes.coarse.tets.size(), box.meshes.coarse.tets.size());
  EXPECT_LT(share, 0.95) << "the box's far corners are held";
  // The budget: about coarseTets tets in the simulated cells (the grid's rounding: 15 %, twice).
  EXPECT_NEAR(6.0 * double(in), 3000.0, 0.35 * 3000.0);
  // Every fine node of a held cell is held; no handle node is (off the box's own faces), whatever
  // the padding: the cells around the handle's are simulated too.
  auto check = [&](const SimScene& sc) {
    const TetMesh& F = sc.meshes.fine;
    for (std::size_t t = 0; t < F.tets.size(); ++t) {
      if (sc.regionCell[std::size_t(sc.meshes.fineParent[t] / 6)]) continue;
      for (int n : F.tets[t]) ASSERT_TRUE(sc.constraints.fixed[std::size_t(n)]);
    }
    EXPECT_GT(sc.handleNodeCount[0], 0u);
    const double onFace = 1e-9 * sc.meshes.coarseGrid.cell().maxCoeff();
    std::size_t held = 0;
    for (std::size_t n = 0; n < F.nodes.size(); ++n) {
      const bool boxFace = ((F.nodes[n] - sc.lo).array() <= onFace).any() || ((sc.hi - F.nodes[n]).array() <= onFace).any();
      held += sc.constraints.handleOf[n] >= 0 && sc.constraints.fixed[n] && !boxFace;
    }
    EXPECT_EQ(held, 0u) << "handle nodes held at rest inside the box";
  };
  check(shaped);
  SimSettings tight = s;
  tight.paddingMm = 0.0;
  check(buildSimScene(p.ct, {h}, tight));
  // A padding that reaches every cell gives the box's scene.
  SimSettings wide = s;
  wide.paddingMm = 1000.0;
  SimSettings wideBox = wide;
  wideBox.region = SimSettings::Region::Box;
  const SimScene a = buildSimScene(p.ct, {h}, wide), b = buildSimScene(p.ct, {h}, wideBox);
  EXPECT_EQ(a.meshes.coarse.tets.size(), b.meshes.coarse.tets.size());
  EXPECT_EQ(a.constraints.fixed, b.constraints.fixed);
}

TEST(RegionShape, AMovedOutlineThatNearsAHeldCellAsksForANewRegion) {
  const KidneyPhantom k;
  SimSettings s = k.settings(3000, 40.0);
  s.region = SimSettings::Region::Handles;
  const SimScene sc = buildSimScene(k.phantom.ct, {k.handle}, s);
  const KuhnGrid& g = sc.meshes.coarseGrid;
  // The kidney's outside at 4 mm, as the app keeps it.
  std::vector<Eigen::Vector3d> centres;
  const VolumeGeometry& geo = k.phantom.ct.geometry();
  for (std::uint32_t v : k.handle.voxels) centres.push_back(geo.toWorld(geo.voxelOf(v).cast<double>()));
  const HandlePoints thin = thinHandlePoints(centres, 4.0);
  std::vector<Eigen::Vector3d> outline;
  for (std::size_t i = 0; i < thin.point.size(); ++i)
    if (thin.surface[i]) outline.push_back(thin.point[i]);
  const double margin = 0.5 * s.paddingMm;
  const Eigen::Matrix3d I = Eigen::Matrix3d::Identity();
  EXPECT_FALSE(outlineNearRegionBoundary(g, sc.regionCell, outline, I, Eigen::Vector3d::Zero(), margin)) << "at rest: the padding is all there";
  // Moved so that its outside point nearest a held cell reaches that cell's centre: a rebuild.
  double best = 1e300;
  Eigen::Vector3d shift = Eigen::Vector3d::Zero();
  for (std::size_t c = 0; c < g.cellCount(); ++c) {
    if (sc.regionCell[c]) continue;
    const Eigen::Vector3d centre = g.nodePosition(g.cellNodes(int(c))[0]) + 0.5 * g.cell();
    for (const auto& p : outline)
      if ((centre - p).norm() < best) best = (centre - p).norm(), shift = centre - p;
  }
  ASSERT_LT(best, 1e300) << "the scene has held cells";
  EXPECT_TRUE(outlineNearRegionBoundary(g, sc.regionCell, outline, I, shift, margin));
  EXPECT_FALSE(outlineNearRegionBoundary(g, {}, outline, I, shift, margin)) << "a box region: the caller checks its faces";
}

TEST(RegionShape, TheSolveThatSkipsHeldElementsConvergesToTheAssembledAnswer) {
  const KidneyPhantom k;
  SimSettings s = k.settings(1500, 25.0);
  s.region = SimSettings::Region::Handles;
  const SimScene sc = buildSimScene(k.phantom.ct, {k.handle}, s);
  const std::vector<RigidTransform> T{RigidTransform::about(sc.handleCentroid[0], Eigen::Vector3d(0, 0, 30.0 * M_PI / 180), Eigen::Vector3d(8, 0, 3))};
  CoarseModel pcg(sc.meshes, sc.fineK, sc.constraints), assembled(sc.meshes, sc.fineK, sc.constraints);
  assembled.setSolver(CoarseSolver::Assembled);
  auto xp = pcg.restState(), xa = assembled.restState();
  ASSERT_TRUE(pcg.solve(T, xp, 2000, 1e-8).converged);
  ASSERT_TRUE(assembled.solve(T, xa, 2000, 1e-8).converged);
  double d = 0, motion = 0;
  const auto rest = pcg.restState();
  for (std::size_t v = 0; v < xp.size(); ++v) {
    d = std::max(d, (xp[v] - xa[v]).norm());
    if (pcg.coarseRole()[v] >= 0) motion = std::max(motion, (xp[v] - rest[v]).norm());
  }
  // Both stop when their update is below 1e-8 of the motion; the PCG's linear convergence (30 degrees
  // from rest in one input) leaves about 100x that between them, as in the whole box (1.2e-6 there,
  // 1.4e-6 here): skipping the held elements changes nothing the solve sees.
  EXPECT_LT(d, 1e-5 * motion);
  // Held cells stay at rest in the reconstruction; the tissue beside the kidney moves.
  const auto x = pcg.reconstruct(T, xp);
  double heldMoved = 0, freeMoved = 0;
  for (std::size_t n = 0; n < x.size(); ++n) {
    const double m = (x[n] - sc.meshes.fine.nodes[n]).norm();
    if (sc.constraints.fixed[n]) heldMoved = std::max(heldMoved, m);
    else if (sc.constraints.handleOf[n] < 0) freeMoved = std::max(freeMoved, m);
  }
  EXPECT_LT(heldMoved, 1e-9) << "held nodes are rebuilt from held corners: at rest up to roundoff";
  EXPECT_GT(freeMoved, 1.0);
}
