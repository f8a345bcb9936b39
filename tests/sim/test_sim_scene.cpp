// What a handle holds and what the skeleton anchors (sim/sim_scene.h, SimSettings::HandleNodes and
// ::Bone), on a synthetic CT at 1 mm: 30 HU soft tissue, a ball of 50 HU (the handle's organ) and
// a compact-bone slab (900 HU) 4 mm from the ball's surface.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "sim/coarsening.h"
#include "sim/handle_reaction.h"
#include "sim/sim_scene.h"
#include "sim/static_solver.h"

namespace handson {
namespace {

constexpr double kBallRadius = 10.0;
const Eigen::Vector3d kBallCentre(40, 30, 30);

struct BallAndBone {
  Volume ct;
  SimHandle ball;
  BallAndBone() {
    VolumeGeometry g;
    g.dims = {80, 60, 60};
    g.spacing = {1, 1, 1};
    ct = Volume(g, ScalarType::Int16);
    for (int k = 0; k < 60; ++k)
      for (int j = 0; j < 60; ++j)
        for (int i = 0; i < 80; ++i) {
          const Eigen::Vector3d p = g.toWorld(Eigen::Vector3d(i, j, k));
          float v = 30.0f;
          if ((p - kBallCentre).norm() <= kBallRadius) {
            v = 50.0f;
            ball.voxels.push_back(std::uint32_t(ct.linearIndex(i, j, k)));
          }
          if (j >= 44 && j <= 49) v = 900.0f;  // y in [44, 49]: 4 mm beyond the ball's top (y = 40)
          ct.setValue(i, j, k, v);
        }
  }
  Eigen::Vector3i nearestVoxel(const Eigen::Vector3d& p) const {
    const Eigen::Vector3d idx = (ct.geometry().worldToIndex() * p.homogeneous()).head<3>();
    return {int(std::lround(idx.x())), int(std::lround(idx.y())), int(std::lround(idx.z()))};
  }
};

SimSettings settings(int coarse, SimSettings::HandleNodes rule, SimSettings::Bone bone) {
  SimSettings s;
  s.coarseTets = coarse;
  s.fineTets = coarse * 27;
  s.paddingMm = 20.0;
  s.handleNodes = rule;
  s.bone = bone;
  s.interface = SimSettings::Interface::Glued;  // the rules of what a handle holds, glued (sliding: test_sliding_interface.cpp)
  return s;
}

TEST(SimScene, AHandleHoldsTheNodesInsideItsSelectionAndTheSkeletonIsAnchored) {
  const BallAndBone scene;
  const SimScene inside = buildSimScene(scene.ct, {scene.ball}, settings(3000, SimSettings::HandleNodes::Inside, SimSettings::Bone::Anchored));
  const TetMesh& F = inside.meshes.fine;
  std::size_t handleNodes = 0, anchored = 0;
  for (std::size_t n = 0; n < F.nodes.size(); ++n) {
    const Eigen::Vector3i v = scene.nearestVoxel(F.nodes[n]);
    const bool inBall = (scene.ct.geometry().toWorld(v.cast<double>()) - kBallCentre).norm() <= kBallRadius;
    const bool bone = v.y() >= 44 && v.y() <= 49;
    if (inside.constraints.handleOf[n] == 0) {
      ++handleNodes;
      EXPECT_TRUE(inBall) << "handle node " << n << " outside the selection";
    } else if (!inside.constraints.fixed[n]) {
      EXPECT_FALSE(inBall) << "node " << n << " in the selection but not held";
    }
    if (bone) {
      EXPECT_TRUE(inside.constraints.fixed[n]) << "skeleton node " << n << " not anchored";
      anchored += inside.constraints.fixed[n];
    }
  }
  EXPECT_GT(handleNodes, 100u);
  EXPECT_GT(anchored, 100u);
  // The earlier rules: every node of the tets holding a ball voxel (beyond the ball), nothing anchored
  // inside the region.
  const SimScene tets = buildSimScene(scene.ct, {scene.ball}, settings(3000, SimSettings::HandleNodes::Tets, SimSettings::Bone::ByValue));
  std::size_t outside = 0, fixedBone = 0;
  for (std::size_t n = 0; n < F.nodes.size(); ++n) {
    const Eigen::Vector3i v = scene.nearestVoxel(F.nodes[n]);
    outside += tets.constraints.handleOf[n] == 0 && (scene.ct.geometry().toWorld(v.cast<double>()) - kBallCentre).norm() > kBallRadius;
    fixedBone += tets.constraints.fixed[n] && v.y() >= 44 && v.y() <= 49 && F.nodes[n].x() > tets.lo.x() + 1 && F.nodes[n].x() < tets.hi.x() - 1 &&
                 F.nodes[n].z() > tets.lo.z() + 1 && F.nodes[n].z() < tets.hi.z() - 1;
  }
  EXPECT_GT(outside, 50u);
  EXPECT_EQ(fixedBone, 0u);
}

TEST(SimScene, EveryNodeOfATetThatIsBoneThroughoutIsAnchored) {
  // A tet whose five samples all lie on the skeleton is bone (its softest sample's band a skeleton
  // band: hundreds of MPa and up). Its nodes on the bone's surface, whose nearest voxel may be soft,
  // are anchored with it, or a coarse cell, whose fine nodes follow its corners, would stretch the
  // bone with the cell (sim_scene.cpp, anchorSkeleton). A compact-bone slab 5 mm thick, tilted to
  // the grid (normal (1, 2, 0.5)), so that nodes on its faces fall either side of voxel centres.
  VolumeGeometry g;
  g.dims = {60, 60, 60};
  g.spacing = {1, 1, 1};
  Volume ct(g, ScalarType::Int16);
  SimHandle ball;
  const Eigen::Vector3d n = Eigen::Vector3d(1, 2, 0.5).normalized(), centre(30, 24, 30);
  for (int k = 0; k < 60; ++k)
    for (int j = 0; j < 60; ++j)
      for (int i = 0; i < 60; ++i) {
        const Eigen::Vector3d p(i, j, k);
        const double d = n.dot(p - Eigen::Vector3d(30, 30, 30));
        ct.setValue(i, j, k, d > 4.0 && d < 9.0 ? 900.0f : 30.0f);
        if ((p - centre).norm() <= 6.0) ball.voxels.push_back(std::uint32_t(ct.linearIndex(i, j, k)));
      }
  for (const int coarse : {400, 3000}) {
    SimSettings s = settings(coarse, SimSettings::HandleNodes::Inside, SimSettings::Bone::Anchored);
    s.outer = SimSettings::Outer::Wall;  // every tet keeps its band (the exterior layer renames the outer cells')
    const SimScene sc = buildSimScene(ct, {ball}, s);
    const TetMesh& F = sc.meshes.fine;
    std::size_t boneTets = 0, loose = 0;
    for (std::size_t t = 0; t < F.tets.size(); ++t) {
      if (sc.band[t] < 0 || s.materials.resolve(ct).band(sc.band[t]).skeleton == SkeletonRole::No) continue;
      ++boneTets;
      for (const int v : F.tets[t]) loose += sc.constraints.handleOf[std::size_t(v)] < 0 && !sc.constraints.fixed[std::size_t(v)];
    }
    EXPECT_GT(boneTets, 100u);
    EXPECT_EQ(loose, 0u) << coarse << " coarse tets: bone tets' nodes left free";
    // With the exterior layer (the default), which renames the outer cells' bands, the same nodes
    // are anchored: bone is told before the renaming (the slab crosses the outer cells).
    s.outer = SimSettings::Outer::Exterior;
    const SimScene ext = buildSimScene(ct, {ball}, s);
    ASSERT_EQ(ext.constraints.fixed.size(), sc.constraints.fixed.size());
    std::size_t differ = 0, renamed = 0;
    for (std::size_t v = 0; v < F.nodes.size(); ++v) differ += ext.constraints.fixed[v] != sc.constraints.fixed[v];
    for (std::size_t t = 0; t < F.tets.size(); ++t) renamed += ext.band[t] < 0 && sc.band[t] >= 0 && s.materials.resolve(ct).band(sc.band[t]).skeleton != SkeletonRole::No;
    EXPECT_GT(renamed, 0u) << "no bone tet in the exterior layer: the check would not tell";
    EXPECT_EQ(differ, 0u);
  }
}

TEST(SimScene, AHandleThinnerThanTheFineMeshFallsBackToItsTets) {
  // One voxel between fine nodes: no node is nearest to it, so the handle takes its tet's nodes.
  const BallAndBone scene;
  SimHandle dot;
  dot.voxels = {std::uint32_t(scene.ct.linearIndex(41, 31, 31))};
  const SimScene sc = buildSimScene(scene.ct, {dot}, settings(600, SimSettings::HandleNodes::Inside, SimSettings::Bone::Anchored));
  EXPECT_EQ(sc.handleNodeCount[0], 4u);
}

// The fine reference's force (N) on the scene's one handle translated by t.
double fineForceOfTranslation(const SimScene& sc, const Eigen::Vector3d& t) {
  const std::vector<RigidTransform> T{RigidTransform::about(sc.handleCentroid[0], Eigen::Vector3d::Zero(), t)};
  const StaticSolveResult r = solveFineStatic(sc, T);
  EXPECT_TRUE(r.converged);
  return fineHandleReactions(sc.meshes.fine, sc.fineK, sc.constraints, T, r.x)[0].forceN.norm();
}

// The force of a 2 mm move of the ball along x (the fine reference) at two fine meshes.
double forceOfMove(const BallAndBone& scene, int coarse, SimSettings::HandleNodes rule, SimSettings::Bone bone) {
  return fineForceOfTranslation(buildSimScene(scene.ct, {scene.ball}, settings(coarse, rule, bone)), Eigen::Vector3d(2, 0, 0));
}

TEST(SimScene, TheForceOfAMoveConvergesWithTheMeshWhenTheHandleHoldsItsSelection) {
#if defined(HANDSON_TEST_SANITIZED)
  GTEST_SKIP() << "four fine static solves of 10-90k tets: the release suite runs them (the scene is built under them above, the fine solve and reactions in HandleReaction.*)";
#endif
  // 10,800 and 64,800 fine tets (27 per coarse tet, 400 and 2,400 coarse tets over the region).
  // Held inside the selection, with the bone anchored and mixed tets' moduli averaged harmonically,
  // the force changes by less than 15 % (measured 1.84 / 1.70 N, 1.08x); the earlier rules - the
  // handle's tets, up to a tet beyond the ball, and the bone free with its stiffness bled into mixed
  // tets - change it by far more (measured 211,292 / 1,143 N): the coarser mesh's handle tets reach
  // the bone 4 mm away.
  const BallAndBone scene;
  const double coarseNew = forceOfMove(scene, 400, SimSettings::HandleNodes::Inside, SimSettings::Bone::Anchored);
  const double fineNew = forceOfMove(scene, 2400, SimSettings::HandleNodes::Inside, SimSettings::Bone::Anchored);
  const double coarseOld = forceOfMove(scene, 400, SimSettings::HandleNodes::Tets, SimSettings::Bone::ByValue);
  const double fineOld = forceOfMove(scene, 2400, SimSettings::HandleNodes::Tets, SimSettings::Bone::ByValue);
  const double ratioNew = std::max(coarseNew, fineNew) / std::min(coarseNew, fineNew), ratioOld = std::max(coarseOld, fineOld) / std::min(coarseOld, fineOld);
  std::printf("inside + anchored: %.4f / %.4f N (%.2fx); tets + by value: %.4f / %.4f N (%.2fx)\n", coarseNew, fineNew, ratioNew, coarseOld, fineOld, ratioOld);
  EXPECT_LT(ratioNew, 1.15);
  EXPECT_GT(ratioOld, ratioNew);
}

}  // namespace
}  // namespace handson

namespace handson {
namespace {

// A ball of radius 8 mm (1 mm voxels) in uniform soft tissue (30 HU: E 6 kPa, nu 0.45), moved 1 mm
// along x; the fine reference's force (N) with the region padded by `padding`.
double forceOfBallInSoftTissue(double padding, SimSettings::Outer outer, int coarse) {
  VolumeGeometry g;
  g.dims = {121, 121, 121};
  g.spacing = {1, 1, 1};
  Volume ct(g, ScalarType::Int16);
  SimHandle ball;
  const Eigen::Vector3d centre(60, 60, 60);
  for (int k = 0; k < 121; ++k)
    for (int j = 0; j < 121; ++j)
      for (int i = 0; i < 121; ++i) {
        ct.setValue(i, j, k, 30.0f);
        if ((Eigen::Vector3d(i, j, k) - centre).norm() <= 8.0) ball.voxels.push_back(std::uint32_t(ct.linearIndex(i, j, k)));
      }
  SimSettings s;
  s.coarseTets = coarse;
  s.fineTets = coarse * 27;
  s.paddingMm = padding;
  s.outer = outer;
  s.interface = SimSettings::Interface::Glued;  // the glued closed form
  return fineForceOfTranslation(buildSimScene(ct, {ball}, s), Eigen::Vector3d(1, 0, 0));
}

TEST(SimScene, TheExteriorLayerMakesTheForceOfAGluedBallThatOfAnUnboundedMedium) {
#if defined(HANDSON_TEST_SANITIZED)
  GTEST_SKIP() << "three fine static solves of 40-90k tets: the release suite runs them (the scene is built under them above, the fine solve and reactions in HandleReaction.*)";
#endif
  // Closed form (a rigid sphere translated in an unbounded medium, glued): F = 24 pi G a U (1 - nu) /
  // (5 - 6 nu) = 0.298 N for G = 6 kPa / 2.9, a = 8 mm, U = 1 mm, nu = 0.45. The ball's surface is
  // voxelized and its boundary tets are half soft (the handle holds the nodes inside it: an effective
  // radius between a - h/2 and a for fine tets of edge h ~ 2.7 mm), so within 20 % (measured below).
  // Measured 1.16x at a padding of 2 radii, 1.04x at 4: the layer stands for the exterior of a
  // sphere, and at 2 radii the box's corners are far from one; kept within 20 % and 10 %, and 15 %
  // of each other (the glued kidney's force changes by 0.04 % from 40 to 80 mm at equal tet size:
  // docs/results.md, "Glued across meshes"). With
  // walls held at the region's faces the force is twice the closed form (measured 1.97x).
  const double G = 6000.0 / 2.9, closed = 24.0 * M_PI * G * 8e-3 * 1e-3 * 0.55 / 2.3;
  const double near = forceOfBallInSoftTissue(16.0, SimSettings::Outer::Exterior, 1600);
  const double far = forceOfBallInSoftTissue(32.0, SimSettings::Outer::Exterior, 3200);
  const double wallNear = forceOfBallInSoftTissue(16.0, SimSettings::Outer::Wall, 1600);
  std::printf("closed form %.4f N; exterior layer: padding 16 mm %.4f N (%.2fx), 32 mm %.4f N (%.2fx); walls at 16 mm %.4f N (%.2fx)\n", closed, near,
              near / closed, far, far / closed, wallNear, wallNear / closed);
  EXPECT_NEAR(near, closed, 0.2 * closed);
  EXPECT_NEAR(far, closed, 0.1 * closed);
  EXPECT_NEAR(far, near, 0.15 * near);
  EXPECT_GT(wallNear, 1.3 * closed);
}

}  // namespace
}  // namespace handson
