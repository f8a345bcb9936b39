// Sliding interfaces (sim/sliding_interface.h): the springs' calculus, the interface's nodes and
// normals, and a rigid ball sliding in soft tissue against the closed form, fine and coarse.
#include "sim/sliding_interface.h"

#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <cmath>
#include <cstdio>
#include <algorithm>

#include "sim/base/error.h"
#include "sim/handle_reaction.h"
#include "sim/sim_scene.h"
#include "sim/strain.h"
#include "sim/two_level.h"

namespace handson {
namespace {

TEST(SlidingInterface, TheSpringForcesAreTheEnergysGradientAndThePlanesHoldExactly) {
  // Two springs on one node and one on another, checked by central differences (the energy is
  // quadratic, so the differences are exact to rounding: 1e-6 relative).
  const std::vector<NormalSpring> springs{{0, 3.0, Eigen::Vector3d(1, 2, 2) / 3.0, {0.1, 0.2, 0.3}},
                                          {0, 5.0, Eigen::Vector3d(0, 0.6, 0.8), {-0.2, 0.0, 0.1}},
                                          {1, 2.0, Eigen::Vector3d(1, 0, 0), {1.0, 1.0, 1.0}}};
  std::vector<Eigen::Vector3d> x{{0.3, -0.1, 0.7}, {1.4, 0.9, 1.2}};
  std::vector<Eigen::Vector3d> f(2, Eigen::Vector3d::Zero());
  addSpringForces(springs, x, f);
  const double h = 1e-5;
  for (std::size_t n = 0; n < 2; ++n)
    for (int c = 0; c < 3; ++c) {
      auto xp = x, xm = x;
      xp[n][c] += h;
      xm[n][c] -= h;
      const double fd = -(springEnergy(springs, xp) - springEnergy(springs, xm)) / (2 * h);
      EXPECT_NEAR(f[n][c], fd, 1e-6 * (1 + std::abs(fd)));
    }
  // Held exactly: a node put on its plane has no gap (node 1; node 0's two planes in turn, the
  // second's projection leaving the first's gap), and a step with the normal parts removed keeps it.
  const std::vector<NormalSpring> one{springs[2]};
  projectOntoSpringPlanes(one, x);
  EXPECT_NEAR(springs[2].normal.dot(x[1] - springs[2].anchor), 0.0, 1e-15);
  std::vector<Eigen::Vector3d> step{{0.2, -0.4, 0.1}, {0.5, 0.3, -0.2}};
  removeNormalParts(one, step);
  EXPECT_NEAR(springs[2].normal.dot(step[1]), 0.0, 1e-15);
  EXPECT_EQ(step[0], Eigen::Vector3d(0.2, -0.4, 0.1));
}

TEST(SlidingInterface, TheSurfaceNodesAreThoseBesideAnotherNodeAndTheHandlesOwnTetsTheRest) {
  // Two tets sharing the face (1,2,3): nodes 0-3 selected by handle 0, node 4 free. Tet 0 is the
  // handle's own; tet 1 is tissue, so its selected nodes 1-3 are the surface.
  TetMesh m;
  m.nodes = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {1, 1, 1}};
  m.tets = {{0, 1, 2, 3}, {4, 1, 3, 2}};
  const InterfaceNodes in = findInterfaceNodes(m, {0, 0, 0, 0, -1}, {0, 0, 0, 0, 0});
  EXPECT_EQ(in.slideNodes, (std::vector<int>{1, 2, 3}));
  EXPECT_EQ(in.slideHandle, (std::vector<int>{0, 0, 0}));
  EXPECT_EQ(in.handleTet, (std::vector<char>{1, 0}));
  // A held node is never a slide node (the region's boundary wins).
  EXPECT_EQ(findInterfaceNodes(m, {0, 0, 0, 0, -1}, {0, 1, 0, 0, 0}).slideNodes, (std::vector<int>{2, 3}));
  // Next to another handle's node the surface is a surface too.
  EXPECT_EQ(findInterfaceNodes(m, {0, 0, 0, 0, 1}, {0, 0, 0, 0, 0}).slideNodes, (std::vector<int>{1, 2, 3, 4}));
}

// A ball of radius `radius` voxels centred in a cube of `n` voxels of 1 mm.
struct Ball {
  VolumeGeometry g;
  std::vector<std::uint32_t> voxels;
  Eigen::Vector3d centre;
  Ball(int n, double radius) : centre(Eigen::Vector3d::Constant((n - 1) / 2.0)) {
    g.dims = {n, n, n};
    for (int k = 0; k < n; ++k)
      for (int j = 0; j < n; ++j)
        for (int i = 0; i < n; ++i)
          if ((Eigen::Vector3d(i, j, k) - centre).norm() <= radius) voxels.push_back(std::uint32_t(i + n * (j + n * k)));
  }
};

TEST(SlidingInterface, TheMasksNormalBelowTheSurfaceIsTheSurfacesNormal) {
  // A coarse mesh's slide nodes lie up to a tet below the organ's voxel surface. On an elongated
  // ellipsoid (semi-axes 10, 10, 24 voxels of 1 mm), points 1-6 mm below the surface on its side,
  // where the normal is lateral but the direction from the centroid is not: within 12 degrees of
  // the ellipsoid's normal at the point's nearest surface point (a neighbourhood of 3 mm alone, all
  // or nearly all mask below 3 mm, was up to 172 degrees off).
  VolumeGeometry g;
  g.dims = {27, 27, 55};
  const Eigen::Vector3d c(13, 13, 27), r(10, 10, 24);
  std::vector<std::uint32_t> voxels;
  for (int k = 0; k < g.dims.z(); ++k)
    for (int j = 0; j < g.dims.y(); ++j)
      for (int i = 0; i < g.dims.x(); ++i)
        if ((Eigen::Vector3d(i, j, k) - c).cwiseQuotient(r).squaredNorm() <= 1.0) voxels.push_back(std::uint32_t(i + g.dims.x() * (j + g.dims.y() * k)));
  const HandleMask mask = handleMask(g, voxels);
  double worst = 0;
  for (const double z : {-14.0, -7.0, 0.0, 7.0, 14.0}) {
    const double rho = std::sqrt(1.0 - z * z / (r.z() * r.z())) * r.x();  // the surface's radius at height z
    const Eigen::Vector3d surface(rho, 0, z), n = Eigen::Vector3d(rho / (r.x() * r.x()), 0, z / (r.z() * r.z())).normalized();
    for (const double depth : {1.0, 3.0, 6.0}) {
      const Eigen::Vector3d p = c + surface - depth * n;
      EXPECT_NEAR(mask.depthAt(g, p), depth, 1.0) << "z " << z << " depth " << depth;
      worst = std::max(worst, std::acos(std::clamp(maskNormal(g, mask, p, 3.0).dot(n), -1.0, 1.0)) * 180 / M_PI);
    }
  }
  std::printf("worst normal error below the ellipsoid's surface: %.1f degrees\n", worst);
  EXPECT_LT(worst, 12.0);
}

TEST(SlidingInterface, TheMasksNormalOnABallIsRadial) {
  // Radius 8 voxels, the neighbourhood 3 voxels: on the voxelized surface the normal is within 12
  // degrees of the radius (measured 9.4: the staircase's steps are 1 voxel, a third of the
  // neighbourhood).
  const Ball b(25, 8.0);
  const HandleMask mask = handleMask(b.g, b.voxels);
  double worst = 0;
  for (int k = 0; k < 40; ++k) {
    const double th = std::acos(1 - 2 * (k + 0.5) / 40.0), ph = 2.39996 * k;  // a Fibonacci sphere
    const Eigen::Vector3d dir(std::sin(th) * std::cos(ph), std::sin(th) * std::sin(ph), std::cos(th));
    const Eigen::Vector3d n = maskNormal(b.g, mask, b.centre + 8.0 * dir, 3.0);
    EXPECT_NEAR(n.norm(), 1.0, 1e-12);
    worst = std::max(worst, std::acos(std::clamp(n.dot(dir), -1.0, 1.0)) * 180 / M_PI);
  }
  std::printf("worst normal error on the voxel ball: %.1f degrees\n", worst);
  EXPECT_LT(worst, 12.0);
  // Deep inside, where the neighbourhood is all mask, the fallback points away from the centroid.
  EXPECT_GT(maskNormal(b.g, mask, b.centre + Eigen::Vector3d(2, 0, 0), 3.0).x(), 0.99);
  EXPECT_THROW(handleMask(b.g, {}), Error);
  EXPECT_THROW(handleMask(b.g, {std::uint32_t(b.g.voxelCount())}), Error);
}

// A ball of radius 8 mm (1 mm voxels) in uniform soft tissue (30 HU: E 6 kPa, nu 0.45) padded by
// 32 mm (4 radii, where the glued ball's force is 1.04x the unbounded medium's), with the interface;
// `finePerCoarse` fine tets per coarse one (m^3: 64 for graded cells, which need m even).
SimScene ballInSoftTissue(SimSettings::Interface interface, int coarse, int finePerCoarse = 27) {
  Ball b(121, 8.0);
  Volume ct(b.g, ScalarType::Int16);
  for (std::size_t i = 0; i < ct.voxelCount(); ++i) ct.setValue(i, 30.0f);
  SimSettings s;
  s.coarseTets = coarse;
  s.fineTets = coarse * finePerCoarse;
  s.paddingMm = 32.0;
  s.interface = interface;
  return buildSimScene(ct, {SimHandle{b.voxels, {}}}, s);
}

// The displacement around a rigid sphere (centre c, radius a) translated by U in an unbounded
// medium (Poisson nu): the Kelvin solution plus a harmonic dipole, with r = x - c,
//   u = alpha [(3 - 4 nu) U / |r| + (U.r) r / |r|^3] + beta [U / |r|^3 - 3 (U.r) r / |r|^5],
// glued (u = U at |r| = a): alpha = 3a / (2 (5 - 6 nu)), beta = a^3 - alpha a^2 (3 - 4 nu);
// sliding (u.r = U.r and no shear traction at |r| = a): alpha = 3a / (14 - 16 nu),
// beta = alpha a^2 (2 nu - 1) / 3. The force is 16 pi G (1 - nu) alpha U.
Eigen::Vector3d sphereDisplacement(const Eigen::Vector3d& x, const Eigen::Vector3d& c, double a, double nu, const Eigen::Vector3d& U, bool sliding) {
  const double alpha = sliding ? 3 * a / (14 - 16 * nu) : 3 * a / (2 * (5 - 6 * nu));
  const double beta = sliding ? alpha * a * a * (2 * nu - 1) / 3 : a * a * a - alpha * a * a * (3 - 4 * nu);
  const Eigen::Vector3d r = x - c;
  const double d = r.norm(), ur = U.dot(r);
  return alpha * ((3 - 4 * nu) * U / d + ur * r / (d * d * d)) + beta * (U / (d * d * d) - 3 * ur * r / std::pow(d, 5));
}

// The strain measure of sim/strain.h (largest singular value of F - 1) of the closed form at x
// (F = I + grad u by central differences, h = 1e-4 mm: truncation ~1e-8 of the gradient).
double sphereStrain(const Eigen::Vector3d& x, const Eigen::Vector3d& c, double a, double nu, const Eigen::Vector3d& U, bool sliding) {
  Eigen::Matrix3d F = Eigen::Matrix3d::Identity();
  const double h = 1e-4;
  for (int k = 0; k < 3; ++k) {
    const Eigen::Vector3d e = h * Eigen::Vector3d::Unit(k);
    F.col(k) += (sphereDisplacement(x + e, c, a, nu, U, sliding) - sphereDisplacement(x - e, c, a, nu, U, sliding)) / (2 * h);
  }
  return Eigen::JacobiSVD<Eigen::Matrix3d>(F).singularValues()[0] - 1.0;
}

// The rest volume (mm^3) of the tissue tets (a band of the table: not the exterior layer nor the
// ball's own) beyond 1.2 radii whose strain passes `threshold`: the model's (`strain`) and the
// closed form's at their centroids.
std::pair<double, double> volumesPast(const SimScene& sc, const std::vector<float>& strain, const Eigen::Vector3d& c, double a, double nu,
                                      const Eigen::Vector3d& U, bool sliding, double threshold) {
  const TetMesh& F = sc.meshes.fine;
  double model = 0, closed = 0;
  for (std::size_t t = 0; t < F.tets.size(); ++t) {
    const auto X = tetCorners(F.tets[t], F.nodes);
    const Eigen::Vector3d centroid = (X[0] + X[1] + X[2] + X[3]) / 4.0;
    if (sc.band[t] < 0 || (centroid - c).norm() < 1.2 * a) continue;
    const double V = std::abs((X[1] - X[0]).cross(X[2] - X[0]).dot(X[3] - X[0])) / 6.0;
    if (strain[t] > threshold) model += V;
    if (sphereStrain(centroid, c, a, nu, U, sliding) > threshold) closed += V;
  }
  return {model, closed};
}

TEST(SlidingInterface, ABallSlidingInSoftTissueTakesTheClosedFormsForceAndStaysOnItsSurface) {
#if defined(HANDSON_TEST_SANITIZED)
  GTEST_SKIP() << "two fine static solves of 86k tets: the release suite runs them";
#endif
  // A rigid sphere of radius a translated U in an unbounded medium (shear modulus G, Poisson nu):
  // glued, F = 24 pi G a U (1 - nu) / (5 - 6 nu); frictionless and bilateral, F = 24 pi G a U (1 - nu)
  // / (7 - 8 nu) (the Kelvin solution plus a harmonic dipole with u_r = U cos(theta) and no shear
  // traction at r = a; 4 pi G a U incompressible, the perfect-slip Stokes drag): 0.298 and 0.202 N
  // here, a ratio of 0.676. The voxelized ball and the fine tets straddling it make its effective
  // radius a - h/2 .. a; the exterior layer at 4 radii adds 4 % (the glued test in SimScene.*):
  // within 15 %, and the ratio, where both effects largely cancel, within 10 % (measured: sliding
  // 1.007x, glued 1.039x, ratio 0.656; the largest normal gap 0.45 % of the motion).
  const double G = 6000.0 / 2.9, a = 8.0, nu = 0.45, U = 1.0;
  const double glued = 24 * M_PI * G * a * U * (1 - nu) / (5 - 6 * nu) * 1e-6, sliding = 24 * M_PI * G * a * U * (1 - nu) / (7 - 8 * nu) * 1e-6;
  const SimScene sc = ballInSoftTissue(SimSettings::Interface::Sliding, 3200);
  ASSERT_FALSE(sc.constraints.slide.empty());
  const std::vector<RigidTransform> T{RigidTransform::about(sc.handleCentroid[0], Eigen::Vector3d::Zero(), Eigen::Vector3d(U, 0, 0))};
  const StaticSolveResult r = solveFineStatic(sc, T);
  ASSERT_TRUE(r.converged);
  const double fs = fineHandleReactions(sc.meshes.fine, sc.fineK, sc.constraints, T, r.x)[0].forceN.norm();
  const SimScene scg = ballInSoftTissue(SimSettings::Interface::Glued, 3200);
  const StaticSolveResult rg = solveFineStatic(scg, T);
  const double fg = fineHandleReactions(scg.meshes.fine, scg.fineK, scg.constraints, T, rg.x)[0].forceN.norm();
  // On the surface: the normal gap is a small fraction of the motion; tangentially the tissue
  // slides (at the equator, where the motion is tangential, it lags the ball).
  double gap = 0, equatorLag = 0;
  int equator = 0;
  for (const NormalSpring& s : slideSprings(sc.meshes.fine, sc.constraints.slide, T)) {
    gap = std::max(gap, std::abs(s.normal.dot(r.x[std::size_t(s.node)] - s.anchor)));
    if (std::abs(s.normal.x()) < 0.2) {
      equatorLag += U - (r.x[std::size_t(s.node)] - sc.meshes.fine.nodes[std::size_t(s.node)]).x();
      ++equator;
    }
  }
  equatorLag /= std::max(equator, 1);
  std::printf("sliding %.4f N (closed form %.4f, %.3fx), glued %.4f N (%.4f, %.3fx); ratio %.3f (closed form %.3f); largest normal gap %.4f mm, "
              "equator's mean lag %.3f mm\n",
              fs, sliding, fs / sliding, fg, glued, fg / glued, fs / fg, sliding / glued, gap, equatorLag);
  EXPECT_NEAR(fs, sliding, 0.15 * sliding);
  EXPECT_NEAR(fs / fg, sliding / glued, 0.1 * sliding / glued);
  // The strain field: the tissue beyond 1.2 radii (the voxelized surface's tets left out) strained
  // past 2 % (the peak there is ~1.5 U/a = 19 % glued), by volume, against the closed form's on the
  // same tets: within 15 % (measured 0.876x sliding, 1.123x glued: the tets straddling 1.2 radii and
  // the voxelized surface's reach beyond it).
  const Eigen::Vector3d c = sc.handleCentroid[0], Ux(U, 0, 0);
  for (const bool slide : {true, false}) {
    const auto [model, closed] = volumesPast(slide ? sc : scg, tetStrain((slide ? sc : scg).meshes.fine, slide ? r.x : rg.x), c, a, nu, Ux, slide, 0.02);
    std::printf("%s: %.0f mm3 strained past 2 %% (closed form %.0f, %.3fx)\n", slide ? "sliding" : "glued", model, closed, model / closed);
    EXPECT_NEAR(model, closed, 0.15 * closed);
  }
  EXPECT_LT(gap, 0.05 * U);
  EXPECT_GT(equatorLag, 0.2 * U);
}

TEST(SlidingInterface, TissueTheHandleEnclosesMovesWithIt) {
  // A shell (radii 4-9 mm, 1 mm voxels) selected around a core of unselected tissue: sliding all
  // round, the core would float on its normal springs (a round cavity turns freely). It is the
  // handle's: a turn and a move solve, and the core's centre moves exactly with the shell.
  VolumeGeometry g;
  g.dims = {41, 41, 41};
  Volume ct(g, ScalarType::Int16);
  SimHandle shell;
  const Eigen::Vector3d c(20, 20, 20);
  for (int k = 0; k < 41; ++k)
    for (int j = 0; j < 41; ++j)
      for (int i = 0; i < 41; ++i) {
        ct.setValue(ct.linearIndex(i, j, k), 30.0f);
        const double r = (Eigen::Vector3d(i, j, k) - c).norm();
        if (r >= 4.0 && r <= 9.0) shell.voxels.push_back(std::uint32_t(ct.linearIndex(i, j, k)));
      }
  SimSettings s;
  s.coarseTets = 400;
  s.fineTets = 400 * 27;
  s.paddingMm = 8.0;
  s.interface = SimSettings::Interface::Sliding;
  const SimScene sc = buildSimScene(ct, {shell}, s);
  const std::vector<RigidTransform> T{RigidTransform::about(c, Eigen::Vector3d(0, 0, 0.3), Eigen::Vector3d(1, 0, 0))};
  const StaticSolveResult r = solveFineStatic(sc, T);
  ASSERT_TRUE(r.converged);
  std::size_t core = 0;
  for (std::size_t n = 0; n < sc.meshes.fine.nodes.size(); ++n)
    if ((sc.meshes.fine.nodes[n] - c).norm() < 2.0) {
      EXPECT_EQ(sc.constraints.handleOf[n], 0);
      EXPECT_LT((r.x[n] - T[0].apply(sc.meshes.fine.nodes[n])).norm(), 1e-9);
      ++core;
    }
  EXPECT_GT(core, 0u);
}

TEST(SlidingInterface, TheCoarseModelSlidesAndRefinementConvergesToTheFineAnswer) {
#if defined(HANDSON_TEST_SANITIZED)
  GTEST_SKIP() << "a fine static solve of 43k tets and twenty refinement steps: the release suite runs them";
#endif
  // The coarse model condenses the springs (ghost Dirichlet nodes of the handle) and holds the slide
  // nodes on its faces to the surface exactly, sliding with the faces' corners: its force is an
  // approximation of the fine one, within 35 % (measured 1.31x); twenty two-level steps from its
  // answer bring the force within 2 % of the fine reference's (measured 1.001x) and the motion
  // within 1 %.
  const SimScene sc = ballInSoftTissue(SimSettings::Interface::Sliding, 1600);
  const std::vector<RigidTransform> T{RigidTransform::about(sc.handleCentroid[0], Eigen::Vector3d(0, 0, 0.2), Eigen::Vector3d(1, 0.5, 0))};
  const StaticSolveResult fine = solveFineStatic(sc, T);
  ASSERT_TRUE(fine.converged);
  const double ff = fineHandleReactions(sc.meshes.fine, sc.fineK, sc.constraints, T, fine.x)[0].forceN.norm();
  CoarseModel model(sc.meshes, sc.fineK, sc.constraints);
  auto xc = model.restState();
  ASSERT_TRUE(model.solve(T, xc, 500).converged);
  const double fc = model.handleReactions(T, xc)[0].forceN.norm();
  auto x = model.reconstruct(T, xc);
  const FineRefiner refiner(model, sc.fineK, sc.youngs, sc.poisson);
  for (int k = 0; k < 20; ++k) refiner.step(T, xc, x, 10);
  const double fr = fineHandleReactions(sc.meshes.fine, sc.fineK, sc.constraints, T, x)[0].forceN.norm();
  std::printf("fine %.4f N, coarse %.4f N (%.2fx), refined %.4f N (%.3fx)\n", ff, fc, fc / ff, fr, fr / ff);
  EXPECT_NEAR(fc, ff, 0.35 * ff);
  EXPECT_NEAR(fr, ff, 0.02 * ff);
  EXPECT_LT(compareDeformation(sc, T, x, fine.x).rmsOfMotion, 0.01);
}

TEST(SlidingInterface, TheCoarseReactionOfASlidingBallIsTheWorkItsSolutionStores) {
#if defined(HANDSON_TEST_SANITIZED)
  GTEST_SKIP() << "a scene of 200k fine tets condensed three ways: the release suite runs it";
#endif
  // Translated U in the linear regime, the force along U is 2E/U (Clapeyron), E the energy the
  // coarse state stores (springs included, in the solve's own frames): the free nodes balanced, the
  // held ones still, the handle's nodes do all the work. The elements holding the interface are
  // taken in the solve's frame (their normals are fixed in it), the rest in their moment-free frames:
  // within 1 % of 2E/U for uniform and graded cells (measured within 0.1 %: the 1 mm motion turns
  // the frames by ~1e-3). With every element in its moment-free frame (the rule before), graded cells
  // gave 0.29x and 0.17x here: that frame turns the interface's normals against the tissue's slip.
  // Against the closed form (0.202 N; the fine reference 0.206 N) the coarse model is stiffer, as on
  // every scene (measured 1.32x, 1.36x, 1.22x): within 1.5x.
  const SimScene sc = ballInSoftTissue(SimSettings::Interface::Sliding, 3200, 64);
  const std::vector<RigidTransform> T{RigidTransform::about(sc.handleCentroid[0], Eigen::Vector3d::Zero(), Eigen::Vector3d(1, 0, 0))};
  const double G = 6000.0 / 2.9, nu = 0.45;
  const double closed = 24 * M_PI * G * 8.0 * (1 - nu) / (7 - 8 * nu) * 1e-6;  // N (the test above)
  for (const double split : {-1.0, 0.0, 1.0}) {
    CoarseModel model(sc.meshes, sc.fineK, sc.constraints, {}, CoarseElement::Cell, CoarseGrading{split});
    auto xc = model.restState();
    ASSERT_TRUE(model.solve(T, xc, 5000, 1e-9).converged);
    const double along = -model.handleReactions(T, xc)[0].forceN.x(), work = 2.0 * model.storedEnergy(T, xc);
    std::printf("split %.0f: reaction along the motion %.4f N, 2E/U %.4f N (%.3fx), %.2fx the closed form\n", split, along, work, along / work, along / closed);
    EXPECT_NEAR(along, work, 0.01 * work) << "split " << split;
    EXPECT_GT(along, closed);
    EXPECT_LT(along, 1.5 * closed);
  }
}

}  // namespace

}  // namespace handson
