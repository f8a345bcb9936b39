// Where methods fail (../shared/spec/methods.md section 8): large rotations, extreme stiffness
// contrast, handles against the fixed boundary and against a fixed handle. The models must stay
// finite, converge or report it, and count inverted elements rather than hide them.
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <cmath>
#include <functional>

#include "sim/coarsening.h"
#include "sim/static_solver.h"
#include "sim/two_level.h"

using namespace handson;

namespace {

struct Scene {
  NestedMeshes meshes = buildNestedMeshes({0, 0, 0}, {60, 40, 40}, 480, 27);
  std::vector<double> E, nu;
  std::vector<Mat12> K;
  FineConstraints c;
  explicit Scene(double contrast = 1.0) {
    const auto& F = meshes.fine;
    E.assign(F.tets.size(), 3e3);
    nu.assign(F.tets.size(), 0.45);
    for (std::size_t t = 0; t < F.tets.size(); ++t) {
      Eigen::Vector3d ctr = Eigen::Vector3d::Zero();
      for (int v : F.tets[t]) ctr += F.nodes[std::size_t(v)] / 4.0;
      if (ctr.y() > 24 && ctr.y() < 30) E[t] *= contrast;  // a stiff slab beside the handle
    }
    K = tetStiffnesses(F, E, nu);
    c.handleOf.assign(F.nodes.size(), -1);
    c.fixed.assign(F.nodes.size(), 0);
    for (std::size_t n = 0; n < F.nodes.size(); ++n) {
      const auto& p = F.nodes[n];
      if (p.minCoeff() < 1e-9 || p.x() > 60 - 1e-9 || p.y() > 40 - 1e-9 || p.z() > 40 - 1e-9) c.fixed[n] = 1;
    }
  }
  void ball(const Eigen::Vector3d& ctr, double r, int handle) {
    for (std::size_t n = 0; n < meshes.fine.nodes.size(); ++n)
      if ((meshes.fine.nodes[n] - ctr).norm() < r) c.handleOf[n] = handle;
    c.handleCount = std::max(c.handleCount, handle + 1);
  }
};

bool finite(const std::vector<Eigen::Vector3d>& x) {
  for (const auto& p : x)
    if (!p.allFinite()) return false;
  return true;
}

// Coarse (with continuation) and fine solves of one scene and motion; both must be finite.
struct Outcome {
  bool coarseFinite = false, fineFinite = false, fineConverged = false;
  int coarseInverted = 0, fineInverted = 0;
};
using Motion = std::function<std::vector<RigidTransform>(double fraction)>;
Outcome run(Scene& s, const Motion& at, int increments) {
  Outcome o;
  CoarseModel model(s.meshes, s.K, s.c);
  auto xc = model.restState();
  const auto T = at(1.0);
  for (int k = 1; k <= increments; ++k) model.solve(at(double(k) / increments), xc, 30);
  const auto xcoarse = model.reconstruct(T, xc);
  o.coarseFinite = finite(xc) && finite(xcoarse);
  o.coarseInverted = countInvertedTets(s.meshes.fine, xcoarse);
  std::vector<char> dir;
  auto x = s.meshes.fine.nodes;
  for (int k = 1; k <= increments; ++k) {
    auto x0 = prescribedPositions(s.meshes.fine, s.c, at(double(k) / increments), &dir);
    for (std::size_t i = 0; i < x0.size(); ++i)
      if (!dir[i]) x0[i] = x[i];
    const auto r = solveStatic(s.meshes.fine, s.K, dir, x0);
    x = r.x;
    o.fineConverged = r.converged;
  }
  o.fineFinite = finite(x);
  o.fineInverted = countInvertedTets(s.meshes.fine, x);
  return o;
}

}  // namespace

TEST(Stability, HandleRotatedBy180DegreesWithContinuation) {
  Scene s;
  s.ball({30, 20, 20}, 9, 0);
  const auto o = run(s, [](double f) { return std::vector<RigidTransform>{RigidTransform::about({30, 20, 20}, Eigen::Vector3d(0, 0, f * M_PI), Eigen::Vector3d::Zero())}; }, 6);
  EXPECT_TRUE(o.coarseFinite);
  EXPECT_TRUE(o.fineFinite);
  EXPECT_TRUE(o.fineConverged);
  // A ball twisted half a turn inside a fixed box shears its shell beyond what linear tets of this
  // size can follow without inverting (measured ~300 of 12,960 fine tets in both models): reported.
  std::printf("180 deg: inverted fine tets coarse %d, fine %d\n", o.coarseInverted, o.fineInverted);
}

TEST(Stability, TenThousandFoldStiffnessContrastBesideTheHandle) {
  Scene s(1e4);
  s.ball({30, 16, 20}, 7, 0);
  const auto o = run(s, [](double f) { return std::vector<RigidTransform>{RigidTransform::about({30, 16, 20}, Eigen::Vector3d(0.3 * f, 0, 0), Eigen::Vector3d(0, 6 * f, 0))}; }, 1);
  EXPECT_TRUE(o.coarseFinite);
  EXPECT_TRUE(o.fineFinite);
  EXPECT_TRUE(o.fineConverged);
}

TEST(Stability, HandleTouchingTheFixedBoundaryAndAFixedHandlePullingApart) {
  Scene s;
  s.ball({6, 20, 20}, 10, 0);   // reaches the fixed face x = 0: the boundary wins there
  s.ball({42, 20, 20}, 6, 1);   // a fixed handle
  const auto o = run(s, [](double f) { return std::vector<RigidTransform>{RigidTransform::about({6, 20, 20}, Eigen::Vector3d::Zero(), Eigen::Vector3d(-4 * f, 0, 0)), RigidTransform{}}; }, 1);
  EXPECT_TRUE(o.coarseFinite);
  EXPECT_TRUE(o.fineFinite);
  EXPECT_TRUE(o.fineConverged);
  // Pulled 8 mm further apart along x, in two increments.
  Scene t;
  t.ball({22, 20, 20}, 6, 0);
  t.ball({40, 20, 20}, 6, 1);
  const auto p = run(t, [](double f) { return std::vector<RigidTransform>{RigidTransform::about({22, 20, 20}, Eigen::Vector3d::Zero(), Eigen::Vector3d(-8 * f, 0, 0)), RigidTransform{}}; }, 2);
  EXPECT_TRUE(p.coarseFinite && p.fineFinite && p.fineConverged);
  // 8 mm toward the fixed face halves the 16 mm of tissue there: a few fine tets may invert at this
  // resolution (measured 2 of 12,960); they are counted, and the solve still converges.
  EXPECT_LT(p.fineInverted, 50);
  std::printf("pulled apart: inverted fine tets coarse %d, fine %d\n", p.coarseInverted, p.fineInverted);
}
