// The simulation in a running session (app/session/deformation_controller): built in the background, solved
// on its worker, shown without the render loop waiting; rebuilt, cancelled and shut down cleanly.
#include <gtest/gtest.h>

#include <chrono>
#include <set>
#include <string>
#include <thread>

#include "app/session/deformation_controller.h"
#include "interaction/camera.h"
#include "render/deform_pass.h"
#include "render/render_params.h"
#include "render/transfer_function.h"
#include "tests/app/session/phantom_on_gpu.h"

using namespace handson;

namespace {

using Clock = std::chrono::steady_clock;

struct Scene : test::PhantomOnGpu {
  std::vector<std::uint32_t> kidney, liver;
  gpu::RenderParams params{};
  Scene() {
    renderer->setTransferFunction(transferFunctionPreset("ct-abdomen").lookupTable(q));
    const auto* lab = phantom.labels.data<std::uint8_t>();
    for (std::size_t i = 0; i < phantom.labels.voxelCount(); ++i) {
      if (lab[i] == label::kKidneyRight) kidney.push_back(std::uint32_t(i));
      if (lab[i] == label::kLiver) liver.push_back(std::uint32_t(i));
    }
    RenderSettings rs;
    rs.width = rs.height = 32;
    const OrbitCamera cam = OrbitCamera::framing(q.geometry, 0.0, 0.0);
    params = makeRenderParams(q.geometry, cam.view(), cam.projection(1.0), glm::vec3(cam.eye()), rs);
  }
  // One frame: the controller's part, submitted and waited for. Returns whether it showed the simulation.
  bool frame(DeformationController& dc, const HandleSet& h) {
    FrameRequest req;
    req.params = params;
    const bool shown = dc.prepareFrame(req, h);
    renderer->submit(req);
    renderer->waitLast();
    return shown;
  }
};

// The kidney added to `handles`, moved 8 mm and turned 0.3 rad about z; returns its id.
int addKidneyMovedAndTurned(const Scene& s, HandleSet& handles) {
  const int id = handles.add(s.kidney);
  RigidTransform pose;
  pose.t = Eigen::Vector3d(8, 0, 0);
  pose.R = Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  handles.setPose(id, pose, false);
  return id;
}

// The kidney as the one handle, moved and turned as above.
HandleSet kidneyMovedAndTurned(const Scene& s) {
  HandleSet handles;
  addKidneyMovedAndTurned(s, handles);
  return handles;
}

DeformationOptions small() {
  DeformationOptions o;
  o.sim.coarseTets = 300;
  o.sim.fineTets = 300 * 27;
  return o;
}

}  // namespace

TEST(DeformationController, ShowsTheSimulationWithoutWaitingAndFollowsTheHandles) {
  Scene s;
  HandleSet handles;
  const int id = handles.add(s.kidney);
  ASSERT_GT(id, 0);
  RigidTransform pose;
  pose.t = Eigen::Vector3d(8, 0, 0);
  handles.setPose(id, pose, false);
  DeformationController dc(s.phantom.ct, s.q, *s.renderer, small());
  // Frames go on while the scene is built and solved; the first ones cannot show it yet.
  const auto t0 = Clock::now();
  const bool first = s.frame(dc, handles);
  EXPECT_LT(std::chrono::duration<double>(Clock::now() - t0).count(), 5.0) << "the first frame does not wait for the build";
  EXPECT_FALSE(first);
  bool shown = false;
  int frames = 1;
  while (!(shown && dc.shownConverged()) && Clock::now() - t0 < std::chrono::seconds(60)) {
    shown = s.frame(dc, handles);
    ++frames;
  }
  ASSERT_TRUE(shown) << dc.status();
  EXPECT_TRUE(s.renderer->deforming());
  EXPECT_TRUE(s.renderer->deformer()->hasStrainLimits()) << "the built-in table's limits reach the highlight";
  EXPECT_NE(dc.status().find("converged"), std::string::npos) << dc.status();
  EXPECT_EQ(dc.modelState(), "converged");
  Volume out;
  ASSERT_TRUE(dc.exportDeformed(out));
  std::size_t changed = 0;
  for (std::size_t i = 0; i < out.voxelCount(); ++i) changed += out.value(i) != s.phantom.ct.value(i);
  EXPECT_GT(changed, 100u) << "after " << frames << " frames";

  // A new pose is sent and shown; a fixed handle added restarts the build; removing the active
  // handle ends the simulation (nothing moves) and the renderer shows the input again.
  pose.t = Eigen::Vector3d(12, 0, 0);
  handles.setPose(id, pose, false);
  const std::uint64_t before = dc.shownInput();
  while (dc.shownInput() == before && Clock::now() - t0 < std::chrono::seconds(90)) s.frame(dc, handles);
  EXPECT_GT(dc.shownInput(), before);
  const int fixedId = handles.add(s.liver);
  ASSERT_GT(fixedId, 0);
  handles.setStatus(fixedId, HandleStatus::Fixed);
  const std::uint64_t builds = dc.buildsStarted();
  EXPECT_FALSE(s.frame(dc, handles)) << "rebuilding: the rigid preview meanwhile";
  // Rebuilt (this small scene's build may already have ended on a fast machine: not a failure).
  EXPECT_EQ(dc.buildsStarted(), builds + 1);
  EXPECT_NE(dc.state(), DeformationController::State::Failed) << dc.status();
  handles.remove(id);
  s.frame(dc, handles);
  EXPECT_FALSE(s.renderer->deforming());
  EXPECT_EQ(dc.state(), DeformationController::State::Off);
  EXPECT_EQ(s.ctx->validationMessageCount(), 0u);
}

TEST(DeformationController, AHeldPoseIsRefinedWhileFramesGoOnAndEachStateIsNamed) {
  Scene s;
  const HandleSet handles = kidneyMovedAndTurned(s);
  DeformationOptions o = small();
  o.refineSteps = 2;
  DeformationController dc(s.phantom.ct, s.q, *s.renderer, o);
  const auto t0 = Clock::now();
  std::set<std::string> seen;
  double coarseSeconds = -1;
  while (dc.modelState() != "converged" && Clock::now() - t0 < std::chrono::seconds(90)) {
    s.frame(dc, handles);  // never waits for the solve
    seen.insert(dc.modelState());
    if (dc.modelState() == "coarse" || dc.modelState() == "refining 0/2") coarseSeconds = dc.shownSeconds();
  }
  ASSERT_EQ(dc.modelState(), "converged") << dc.status();
  EXPECT_NE(dc.status().find(", converged"), std::string::npos) << dc.status();
  for (const auto& st : seen)
    EXPECT_TRUE(st == "building" || st == "rest" || st == "coarse" || st == "refining 0/2" || st == "refining 1/2" || st == "converged") << st;
  // The refined state landed after the coarse one it started from (worker time since the pose).
  if (coarseSeconds >= 0) {
    EXPECT_GT(dc.shownSeconds(), coarseSeconds);
  }
  EXPECT_EQ(s.ctx->validationMessageCount(), 0u);
}

TEST(DeformationController, TissuePastItsLimitIsPutDownToTheMovingHandleByItsId) {
  // The liver held (handle 1, fixed) and the kidney moved 8 mm and turned 0.3 rad (handle 2): once
  // the held pose is refined, its report comes, and all the tissue past its limit - beside the
  // liver too - is the kidney's doing, named by the app's id.
  Scene s;
  HandleSet handles;
  const int liver = handles.add(s.liver);
  ASSERT_TRUE(handles.setStatus(liver, HandleStatus::Fixed));
  const int kidney = addKidneyMovedAndTurned(s, handles);
  DeformationOptions o = small();
  o.refineSteps = 1;
  o.sim.interface = SimSettings::Interface::Glued;  // glued, this move strains tissue past its limit on both sides
  DeformationController dc(s.phantom.ct, s.q, *s.renderer, o);
  const auto t0 = Clock::now();
  while (dc.shownTissueLimits().empty() && Clock::now() - t0 < std::chrono::seconds(120)) s.frame(dc, handles);
  const std::string limits = dc.shownTissueLimits();
  EXPECT_EQ(dc.modelState(), "converged") << dc.status();
  EXPECT_NE(limits.find("), from handle " + std::to_string(kidney) + " ("), std::string::npos) << limits;
  EXPECT_EQ(limits.find("handle " + std::to_string(liver) + " ("), std::string::npos) << limits;
  EXPECT_EQ(s.ctx->validationMessageCount(), 0u);
}

TEST(DeformationController, ARegionShapedByTheHandleIsSimulatedDrawnAndRebuiltWhenOutgrown) {
  Scene s;
  HandleSet handles;
  const int id = handles.add(s.kidney);
  RigidTransform pose;
  pose.t = Eigen::Vector3d(6, 0, 0);
  handles.setPose(id, pose, false);
  DeformationOptions o = small();
  o.sim.region = SimSettings::Region::Handles;
  o.sim.paddingMm = 24.0;
  DeformationController dc(s.phantom.ct, s.q, *s.renderer, o);
  const auto t0 = Clock::now();
  while (!(s.frame(dc, handles) && dc.shownConverged()) && Clock::now() - t0 < std::chrono::seconds(60)) {
  }
  ASSERT_TRUE(dc.shownConverged()) << dc.status();
  Volume out;
  ASSERT_TRUE(dc.exportDeformed(out));
  std::size_t changed = 0;
  for (std::size_t i = 0; i < out.voxelCount(); ++i) changed += out.value(i) != s.phantom.ct.value(i);
  EXPECT_GT(changed, 100u);
  // Moved 14 mm further, the kidney comes within half the padding of the region's edge (the box's
  // face in this small scene; the held cells' check: RegionShape.AMovedOutline...): rebuilt there.
  pose.t = Eigen::Vector3d(20, 0, 0);
  handles.setPose(id, pose, false);
  const std::uint64_t builds = dc.buildsStarted();
  s.frame(dc, handles);
  // Rebuilt there (this small scene's build may already have ended on a fast machine).
  EXPECT_EQ(dc.buildsStarted(), builds + 1);
  EXPECT_NE(dc.state(), DeformationController::State::Failed) << dc.status();
  while (!(s.frame(dc, handles) && dc.shownConverged()) && Clock::now() - t0 < std::chrono::seconds(120)) {
  }
  EXPECT_TRUE(dc.shownConverged()) << dc.status();
  EXPECT_EQ(s.ctx->validationMessageCount(), 0u);
}

TEST(DeformationController, GradedCellsAreSimulatedRefinedAndDrawn) {
  // Graded cells (--sim-graded-split) through the app's path: the worker's solve and refinement, the
  // GPU interpolation of a state that holds hanging nodes, the export.
  Scene s;
  const HandleSet handles = kidneyMovedAndTurned(s);
  DeformationOptions o = small();
  o.sim.fineTets = 300 * 64;  // 4 fine cells per coarse cell: half-size cells need an even count
  o.sim.grading.splitWithinCells = 0.0;
  o.refineSteps = 2;
  DeformationController dc(s.phantom.ct, s.q, *s.renderer, o);
  const auto t0 = Clock::now();
  while (dc.modelState() != "converged" && Clock::now() - t0 < std::chrono::seconds(120)) s.frame(dc, handles);
  ASSERT_EQ(dc.modelState(), "converged") << dc.status();
  Volume out;
  ASSERT_TRUE(dc.exportDeformed(out));
  std::size_t changed = 0;
  for (std::size_t i = 0; i < out.voxelCount(); ++i) changed += out.value(i) != s.phantom.ct.value(i);
  EXPECT_GT(changed, 100u);
  // The graded model's answer, not the uniform one's (the same settings without the split differ).
  o.sim.grading = {};
  DeformationController uniform(s.phantom.ct, s.q, *s.renderer, o);
  while (uniform.modelState() != "converged" && Clock::now() - t0 < std::chrono::seconds(180)) s.frame(uniform, handles);
  ASSERT_EQ(uniform.modelState(), "converged") << uniform.status();
  Volume other;
  ASSERT_TRUE(uniform.exportDeformed(other));
  std::size_t differ = 0;
  for (std::size_t i = 0; i < out.voxelCount(); ++i) differ += out.value(i) != other.value(i);
  EXPECT_GT(differ, 10u);
  EXPECT_EQ(s.ctx->validationMessageCount(), 0u);
}

TEST(DeformationController, ChangesDuringABuildAndShutdownNeverBlockForLong) {
  Scene s;
  HandleSet handles;
  const int id = handles.add(s.kidney);
  RigidTransform pose;
  pose.t = Eigen::Vector3d(5, 0, 0);
  handles.setPose(id, pose, false);
  DeformationOptions o;  // the default resolution: a build of a second or more on this machine
  auto t0 = Clock::now();
  {
    DeformationController dc(s.phantom.ct, s.q, *s.renderer, o);
    s.frame(dc, handles);  // starts a build
    const int other = handles.add(s.liver);  // the set changes: the build is cancelled, another starts
    t0 = Clock::now();
    s.frame(dc, handles);
    EXPECT_LT(std::chrono::duration<double>(Clock::now() - t0).count(), 2.0) << "a cancelled build is not waited for on the render thread";
    handles.remove(other);
    s.frame(dc, handles);
    t0 = Clock::now();
  }  // destroyed mid-build: joins the builders (each stops at its next progress report)
  EXPECT_LT(std::chrono::duration<double>(Clock::now() - t0).count(), 30.0);
  EXPECT_FALSE(s.renderer->deforming());
}

TEST(DeformationController, ACutRebuildsTheModelOnTheCutSceneAndARefusedCutIsDropped) {
  // The kidney moved 8 mm away from a plane 8 mm beyond it, across the whole region (the "cut"
  // action): the model is rebuilt on the cut scene, its coarse model updated where the cut passes,
  // and the tissue between follows the kidney while the far side stays: the opening shows air (the
  // image's lowest value) where uncut there was tissue. A second cut that misses the tissue is
  // refused by the build and dropped, the first kept; clearing the cuts gives the uncut tissue back.
  Scene s;
  HandleSet handles;
  const int id = handles.add(s.kidney);
  double kidneyMaxX = -1e300;
  for (std::uint32_t v : s.kidney) kidneyMaxX = std::max(kidneyMaxX, s.q.geometry.toWorld(s.q.geometry.voxelOf(v).cast<double>()).x());
  RigidTransform pose;
  pose.t = Eigen::Vector3d(-8, 0, 0);
  handles.setPose(id, pose, false);
  DeformationController dc(s.phantom.ct, s.q, *s.renderer, small());
  const float air = s.phantom.ct.valueRange().first;
  auto airVoxels = [&] {
    FrameRequest req;
    req.params = s.params;
    EXPECT_TRUE(dc.prepareFrameSettled(req, handles)) << dc.status();
    s.renderer->submit(req);
    s.renderer->waitLast();
    Volume out;
    EXPECT_TRUE(dc.exportDeformed(out));
    std::size_t n = 0;
    for (std::size_t i = 0; i < out.voxelCount(); ++i) n += out.value(i) <= air ? 1 : 0;
    return n;
  };
  const std::size_t uncut = airVoxels();
  const double x = kidneyMaxX + 8.0;
  ASSERT_TRUE(dc.addCut({{{Eigen::Vector3d(x, -1000, -1000), Eigen::Vector3d(x, 1000, -1000), Eigen::Vector3d(x, 1000, 1000), Eigen::Vector3d(x, -1000, 1000)}}}));
  const std::size_t cut = airVoxels();
  EXPECT_NE(dc.status().find("; 1 cut, "), std::string::npos) << dc.status();
  std::printf("air voxels: uncut %zu, cut %zu; %s\n", uncut, cut, dc.status().c_str());
  EXPECT_GT(cut, uncut + 10) << "the opening";
  ASSERT_TRUE(dc.addCut({{{Eigen::Vector3d(5000, 0, 0), Eigen::Vector3d(5000, 10, 0), Eigen::Vector3d(5000, 10, 10), Eigen::Vector3d(5000, 0, 10)}}}));
  EXPECT_EQ(airVoxels(), cut) << "the refused cut changes nothing";
  EXPECT_EQ(dc.cuts().size(), 1u);
  EXPECT_NE(dc.status().find("; 1 refused: "), std::string::npos) << dc.status();
  EXPECT_FALSE(dc.addCut({}));
  dc.clearCuts();
  EXPECT_EQ(airVoxels(), uncut);
  EXPECT_EQ(dc.status().find("cut"), std::string::npos) << dc.status();
  EXPECT_EQ(s.ctx->validationMessageCount(), 0u);
}
