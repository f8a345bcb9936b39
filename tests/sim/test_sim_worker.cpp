#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <thread>

#include "sim/sim_worker.h"
#include "sim/static_solver.h"
#include "sim/strain.h"

using namespace handson;

namespace {

struct Box {
  NestedMeshes meshes = buildNestedMeshes({0, 0, 0}, {60, 40, 40}, 400, 27);
  std::vector<Mat12> K;
  FineConstraints c;
  Box() {
    const auto& F = meshes.fine;
    K = tetStiffnesses(F, std::vector<double>(F.tets.size(), 5e3), std::vector<double>(F.tets.size(), 0.4));
    c.handleCount = 1;
    c.handleOf.assign(F.nodes.size(), -1);
    c.fixed.assign(F.nodes.size(), 0);
    for (std::size_t n = 0; n < F.nodes.size(); ++n) {
      const auto& p = F.nodes[n];
      if (p.minCoeff() < 1e-9 || p.x() > 60 - 1e-9 || p.y() > 40 - 1e-9 || p.z() > 40 - 1e-9) c.fixed[n] = 1;
      else if ((p - Eigen::Vector3d(30, 20, 20)).norm() < 8) c.handleOf[n] = 0;
    }
  }
};

}  // namespace

TEST(SimWorker, AnswersTheNewestInputWithTheSynchronousResultAndRefinesWhileIdle) {
  Box box;
  const std::vector<RigidTransform> T = {RigidTransform::about({30, 20, 20}, Eigen::Vector3d(0.3, 0, 0), Eigen::Vector3d(4, 0, 0))};
  // The synchronous answer (a separate model: the worker owns its own).
  CoarseModel ref(box.meshes, box.K, box.c);
  auto xr = ref.restState();
  ref.solve(T, xr, 3);
  const auto fineRef = ref.reconstruct(T, xr);

  CoarseModel model(box.meshes, box.K, box.c);
  SimWorker worker(model, box.K);
  EXPECT_FALSE(worker.takeLatest().has_value());
  const auto id = worker.setHandles(T);
  const auto s = worker.waitFor(id, 0);
  ASSERT_TRUE(s.has_value());
  EXPECT_EQ(s->input, id);
  EXPECT_TRUE(s->error.empty());
  double d = 0;
  for (std::size_t i = 0; i < fineRef.size(); ++i) d = std::max(d, (s->fine[i] - fineRef[i]).norm());
  EXPECT_LT(d, 1e-9) << "the worker computes what the synchronous solve does";
  // With refinement steps, left alone, it refines and publishes each step.
  CoarseModel model2(box.meshes, box.K, box.c);
  SimWorkerOptions o;
  o.refineSteps = 3;
  SimWorker refining(model2, box.K, o);
  const auto r = refining.waitFor(refining.setHandles(T), 3);
  ASSERT_TRUE(r.has_value());
  EXPECT_EQ(r->refineStep, 3);
  double moved = 0;
  for (std::size_t i = 0; i < fineRef.size(); ++i) moved = std::max(moved, (r->fine[i] - fineRef[i]).norm());
  EXPECT_GT(moved, 1e-6) << "refinement changed the free nodes";
}

TEST(SimWorker, ABurstOfInputsEndsOnTheLastAndBadInputIsRefusedWithoutStoppingIt) {
  Box box;
  CoarseModel model(box.meshes, box.K, box.c);
  SimWorker worker(model, box.K);
  std::uint64_t last = 0;
  for (int i = 0; i < 50; ++i) last = worker.setHandles({RigidTransform::about({30, 20, 20}, Eigen::Vector3d::Zero(), Eigen::Vector3d(0.1 * i, 0, 0))});
  auto s = worker.waitFor(last);
  ASSERT_TRUE(s.has_value());
  EXPECT_EQ(s->input, last);
  RigidTransform bad;
  bad.t.x() = std::nan("");
  const auto b = worker.setHandles({bad});
  s = worker.waitFor(b);
  ASSERT_TRUE(s.has_value());
  EXPECT_FALSE(s->error.empty());
  for (const auto& p : s->coarse) EXPECT_TRUE(p.allFinite());
  const auto good = worker.setHandles({RigidTransform{}});
  s = worker.waitFor(good);
  ASSERT_TRUE(s.has_value());
  EXPECT_TRUE(s->error.empty());
  // Destroying a busy worker joins cleanly.
  for (int i = 0; i < 5; ++i) worker.setHandles({RigidTransform::about({30, 20, 20}, Eigen::Vector3d(0, 0.2 * i, 0), Eigen::Vector3d::Zero())});
}

TEST(SimWorker, AHeldPoseSettlesAndALargeJumpIsSolvedInIncrements) {
  Box box;
  // 60 degrees and 16 mm in one input: two increments (30 deg / 10 mm each at most).
  const std::vector<RigidTransform> T = {RigidTransform::about({30, 20, 20}, Eigen::Vector3d(0, 0, M_PI / 3), Eigen::Vector3d(16, 0, 0))};
  CoarseModel ref(box.meshes, box.K, box.c);
  auto xr = ref.restState();
  ref.solve({RigidTransform::about({30, 20, 20}, Eigen::Vector3d(0, 0, M_PI / 6), Eigen::Vector3d(8, 0, 0))}, xr, 200);
  const auto conv = ref.solve(T, xr, 200);
  ASSERT_TRUE(conv.converged);

  CoarseModel model(box.meshes, box.K, box.c);
  SimWorkerOptions o;
  o.idleIterations = 300;
  o.reconstructFine = false;
  o.elementRotations = true;
  SimWorker worker(model, box.K, o);
  const auto id = worker.setHandles(T);
  // Poll until the published state has converged (the worker keeps iterating while idle).
  std::optional<SimSnapshot> s;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
  while (std::chrono::steady_clock::now() < deadline) {
    if (auto n = worker.takeLatest()) s = n;
    if (s && s->stats.converged) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  ASSERT_TRUE(s.has_value());
  EXPECT_EQ(s->input, id);
  EXPECT_TRUE(s->stats.converged);
  EXPECT_TRUE(s->fine.empty()) << "the GPU interpolates: no CPU reconstruction";
  ASSERT_EQ(s->rotations.size(), model.elementCount());
  double d = 0;
  for (std::size_t i = 0; i < xr.size(); ++i) d = std::max(d, (s->coarse[i] - xr[i]).norm());
  EXPECT_LT(d, 1e-3) << "mm: the same converged state as the synchronous continuation";
  CoarseModel check(box.meshes, box.K, box.c);
  const auto R = check.elementRotations(s->coarse);
  double dr = 0;
  for (std::size_t e = 0; e < R.size(); ++e) dr = std::max(dr, (R[e] - s->rotations[e]).norm());
  EXPECT_LT(dr, 1e-12);
}

TEST(SimWorker, TheLastRefinementStepSaysWhatTissueIsPastItsStrainLimit) {
  Box box;
  SimScene scene;
  scene.meshes = box.meshes;
  scene.fineK = box.K;
  scene.constraints = box.c;
  const std::size_t nt = box.meshes.fine.tets.size();
  scene.youngs.assign(nt, 5e3);
  scene.poisson.assign(nt, 0.4);
  scene.band.assign(nt, 0);
  const MaterialTable table = MaterialTable::parse("units,hu\nname,lower,upper,youngs_kpa,poisson,strain_limit\nsoft,-inf,inf,5,0.4,0.05\n");
  CoarseModel model(scene.meshes, scene.fineK, scene.constraints);
  SimWorkerOptions o;
  o.refineSteps = 2;
  o.refineMethod = RefineMethod::Projected;  // the scene's materials are uniform: any method
  o.tissueLimits = table;
  SimWorker worker(model, scene, o);
  const std::vector<RigidTransform> T = {RigidTransform::about({30, 20, 20}, Eigen::Vector3d(0.3, 0, 0), Eigen::Vector3d(4, 0, 0))};
  const auto id = worker.setHandles(T);
  // The last step is published at once, then again with its report.
  auto r = worker.waitFor(id, 2);
  ASSERT_TRUE(r.has_value());
  ASSERT_EQ(r->refineStep, 2);
  const std::vector<Eigen::Vector3d> state = r->fine;
  for (const auto t0 = std::chrono::steady_clock::now(); !r->limits && std::chrono::steady_clock::now() - t0 < std::chrono::seconds(30);) {
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
    if (auto next = worker.takeLatest()) r = std::move(next);
  }
  ASSERT_TRUE(r->limits.has_value()) << "the last step's report follows it";
  EXPECT_EQ(r->refineStep, 2);
  EXPECT_EQ(r->fine, state) << "the same state";
  // The same as the report from its own fine positions; a 4 mm, 17-degree turn of a ball of 8 mm
  // strains the tissue beside it past 5 %, all of it the one handle's doing.
  const TissueLimitReport direct = tissueLimits(scene.meshes.fine, tetStrain(scene.meshes.fine, r->fine), scene.band, table,
                                                nearestHandleOfNodes(scene.meshes.fine, scene.constraints), 1);
  EXPECT_TRUE(direct.any());
  EXPECT_EQ(r->limits->tets, direct.tets);
  EXPECT_DOUBLE_EQ(r->limits->volumeMm3, direct.volumeMm3);
  ASSERT_EQ(r->limits->volumeByHandle.size(), 1u);
  EXPECT_DOUBLE_EQ(r->limits->volumeByHandle[0], r->limits->volumeMm3);
  EXPECT_NE(describeTissueLimits(*r->limits, {7}).find("from handle 7 ("), std::string::npos) << describeTissueLimits(*r->limits, {7});
}
