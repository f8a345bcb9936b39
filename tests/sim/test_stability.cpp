// Where methods fail (docs/simulation-outputs.md, "Stability"): large rotations, extreme stiffness
// contrast, handles against the fixed boundary and against a fixed handle. The models must stay
// finite, converge or report it, and count inverted elements rather than hide them.
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <cmath>
#include <functional>

#include "sim/box_scene.h"
#include "sim/coarsening.h"
#include "sim/static_solver.h"
#include "sim/two_level.h"

using namespace handson;

namespace {

using Scene = BoxScene;
using Outcome = StabilityOutcome;
using Motion = std::function<std::vector<RigidTransform>(double fraction)>;
Outcome run(Scene& s, const Motion& at, int increments) { return solveBoxMotion(s, at, increments); }

}  // namespace

TEST(Stability, TenThousandFoldStiffnessContrastBesideTheHandle) {
  Scene s(1e4);
  s.ball({30, 16, 20}, 7, 0);
  const auto o = run(s, [](double f) { return std::vector<RigidTransform>{RigidTransform::about({30, 16, 20}, Eigen::Vector3d(0.3 * f, 0, 0), Eigen::Vector3d(0, 6 * f, 0))}; }, 1);
  EXPECT_TRUE(o.coarseFinite);
  EXPECT_TRUE(o.fineFinite);
  EXPECT_TRUE(o.fineConverged);
  EXPECT_TRUE(o.coarseConverged) << "every increment";
}

TEST(Stability, HandleTouchingTheFixedBoundaryAndAFixedHandlePullingApart) {
  Scene s;
  s.ball({6, 20, 20}, 10, 0);   // reaches the fixed face x = 0: the boundary wins there
  s.ball({42, 20, 20}, 6, 1);   // a fixed handle
  const auto o = run(s, [](double f) { return std::vector<RigidTransform>{RigidTransform::about({6, 20, 20}, Eigen::Vector3d::Zero(), Eigen::Vector3d(-4 * f, 0, 0)), RigidTransform{}}; }, 1);
  EXPECT_TRUE(o.coarseFinite);
  EXPECT_TRUE(o.fineFinite);
  EXPECT_TRUE(o.fineConverged);
  EXPECT_TRUE(o.coarseConverged) << "every increment";
  // Pulled 8 mm further apart along x, in two increments.
  Scene t;
  t.ball({22, 20, 20}, 6, 0);
  t.ball({40, 20, 20}, 6, 1);
  const auto p = run(t, [](double f) { return std::vector<RigidTransform>{RigidTransform::about({22, 20, 20}, Eigen::Vector3d::Zero(), Eigen::Vector3d(-8 * f, 0, 0)), RigidTransform{}}; }, 2);
  EXPECT_TRUE(p.coarseFinite && p.fineFinite && p.fineConverged && p.coarseConverged);
  // 8 mm toward the fixed face halves the 16 mm of tissue there: a few fine tets may invert at this
  // resolution (measured 2 of 12,960); they are counted, and the solve still converges.
  EXPECT_LT(p.fineInverted, 50);
  std::printf("pulled apart: inverted fine tets coarse %d, fine %d\n", p.coarseInverted, p.fineInverted);
}

TEST(Stability, HandleRotatedBy180DegreesWithContinuationAndBackRecoversTheInvertedElements) {
  // Out to 180 degrees and back to 0 in 30-degree increments, each solve warm-started from the last.
  // Every increment converges in both models; a ball twisted half a turn inside a fixed box shears its
  // shell beyond what linear tets of this size can follow without inverting (measured ~300 of 12,960
  // fine tets in both models at 180 degrees): counted, and on the way back they must all come back,
  // both models returning to rest.
#if defined(HANDSON_TEST_SANITIZED)
  GTEST_SKIP() << "twelve warm-started fine and coarse solves (the sanitizer suite's longest test, 5 min): the release suite runs them";
#endif
  Scene s;
  s.ball({30, 20, 20}, 9, 0);
  const Motion outAndBack = [](double f) {
    const double angle = M_PI * (1.0 - std::abs(2.0 * f - 1.0));
    return std::vector<RigidTransform>{RigidTransform::about({30, 20, 20}, Eigen::Vector3d(0, 0, angle), Eigen::Vector3d::Zero())};
  };
  const auto o = run(s, outAndBack, 12);
  ASSERT_TRUE(o.coarseFinite && o.fineFinite);
  EXPECT_TRUE(o.fineConverged);
  EXPECT_TRUE(o.coarseConverged) << "every increment";
  ASSERT_EQ(o.fineInvertedAt.size(), 12u);
  ASSERT_EQ(o.coarseInvertedAt.size(), 12u);
  EXPECT_GT(o.fineInvertedAt[5], 0) << "the half turn inverts some tets (else the way back proves nothing)";
  EXPECT_GT(o.coarseInvertedAt[5], 0);
  EXPECT_EQ(o.fineInverted, 0);
  EXPECT_EQ(o.coarseInverted, 0);
  double worstFine = 0, worstCoarse = 0;
  for (std::size_t n = 0; n < o.fine.size(); ++n) {
    worstFine = std::max(worstFine, (o.fine[n] - s.meshes.fine.nodes[n]).norm());
    worstCoarse = std::max(worstCoarse, (o.coarse[n] - s.meshes.fine.nodes[n]).norm());
  }
  // Solver tolerances: the fine solve stops at 1e-6 of the motion, the coarse one after 30
  // iterations an increment at 1e-6 of the largest handle displacement (zero here: a micron floor).
  EXPECT_LT(worstFine, 1e-3) << "mm from rest";
  EXPECT_LT(worstCoarse, 1e-2) << "mm from rest";
  std::printf("out to 180 and back: inverted at 180 deg %d (fine), %d (coarse); back at rest within %.2e mm (fine) and %.2e mm (coarse)\n",
              o.fineInvertedAt[5], o.coarseInvertedAt[5], worstFine, worstCoarse);
}
