// The deformation passes (interpolation, moved-box resampling, mask) against their CPU references:
// interpolateFineReference (sim/fine_interpolation.h) and rasterizeDeformed (sim/tet_raster.h).
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <memory>
#include <string>
#include <utility>

#include "deform_fixture.h"
#include "gpu_test_env.h"
#include "render/deform_pass.h"
#include "render/raymarch_reference.h"
#include "render/render_params.h"
#include "render/transfer_function.h"
#include "render/volume_renderer.h"
#include "interaction/camera.h"
#include "render/vk_resources.h"
#include "sim/coarsening.h"
#include "sim/base/error.h"
#include "sim/phantom.h"
#include "sim/scene_cut.h"
#include "sim/quantized_volume.h"
#include "sim/sim_scene.h"
#include "sim/tet_raster.h"
#include "sim/two_level.h"

using namespace handson;
using test::kKidneyId;
using test::setupFor;
using test::Images;
using test::upload;

namespace {

using Fixture = test::DeformFixture;
const Fixture& fixture() { return test::deformFixture(); }

// The coarse state of the kidney moved and rotated, from a few coarse iterations.
struct Motion {
  std::vector<RigidTransform> T;
  std::vector<Eigen::Vector3d> xc;
};
Motion kidneyMotion(const Fixture& f, double mm, double deg) {
  Motion m;
  m.T = {RigidTransform::about(f.scene.handleCentroid[0], Eigen::Vector3d(0, 0, deg * M_PI / 180), Eigen::Vector3d(mm, 0, 0))};
  m.xc = f.model->restState();
  f.model->solve(m.T, m.xc, 20);
  return m;
}

struct Agreement {
  double fractionWithin1Hu = 0, worstHu = 0;
  double maskAgreement = 0;
};

// GPU images against the CPU reference run on the GPU's own fine node positions.
Agreement compareWithReference(const Fixture& f, const vk::GpuDeformer& gpu, const TetMesh& mesh, const Eigen::Vector3d& lo, const Eigen::Vector3d& hi,
                               RasterStats* cpuStats = nullptr) {
  const std::vector<Eigen::Vector3d> world = test::worldPositions(f, gpu);
  Volume out;
  std::vector<std::uint8_t> outMask;
  const RasterStats st = rasterizeDeformed(f.phantom.ct, mesh, world, {lo, hi, f.backgroundHu}, out, {&f.mask, &outMask, UINT64_MAX, nullptr, {}});
  if (cpuStats) *cpuStats = st;
  const auto vol = gpu.readVolume();
  const auto msk = gpu.readMask();
  Agreement a;
  std::size_t within = 0, same = 0;
  for (std::size_t i = 0; i < vol.size(); ++i) {
    // The CPU output keeps the input's int16 type (rounded); compare in HU.
    const double gpuHu = f.q.toValue(vol[i] / 65535.0f);
    const double err = std::abs(gpuHu - out.value(i));
    a.worstHu = std::max(a.worstHu, err);
    within += err <= 1.0 ? 1 : 0;
    same += msk[i] == outMask[i] ? 1 : 0;
  }
  a.fractionWithin1Hu = double(within) / double(vol.size());
  a.maskAgreement = double(same) / double(vol.size());
  return a;
}

class DeformGpu : public test::GpuTest {};

}  // namespace

TEST_F(DeformGpu, InterpolationPassMatchesItsCpuReference) {
  const Fixture& f = fixture();
  const Images im = upload(f.q, f.mask);
  // Both coarse element kinds: cells (8 corners, the default) and the spec's tets (4 corners); and
  // the cells of a scene cut across the kidney through its cells (one element per piece of a cell
  // the cut crosses, corners copied, some with no fine node: docs/cutting.md).
  SimScene cut = f.scene;
  const double x = f.scene.handleCentroid[0].x() + 5.3;
  cutScene(cut, {{{Eigen::Vector3d(x, cut.lo.y() - 5, cut.lo.z() - 5), Eigen::Vector3d(x, cut.hi.y() + 5, cut.lo.z() - 5),
                   Eigen::Vector3d(x, cut.hi.y() + 5, cut.hi.z() + 5), Eigen::Vector3d(x, cut.lo.y() - 5, cut.hi.z() + 5)}}});
  for (const auto& [sc, kind] : {std::pair<const SimScene*, CoarseElement>{&f.scene, CoarseElement::Cell}, {&f.scene, CoarseElement::Tet}, {&cut, CoarseElement::Cell}}) {
    SCOPED_TRACE(std::string(coarseElementName(kind)) + (sc == &cut ? ", cut" : ""));
    CoarseModel model(sc->meshes, sc->fineK, sc->constraints, {}, kind);
    if (sc == &cut) {
      ASSERT_GT(model.elementCount(), sc->meshes.coarseGrid.cellCount());
    }
    const FineInterpolationData data = model.interpolationData();
    ASSERT_EQ(data.cornersPerElement, kind == CoarseElement::Cell ? 8u : 4u);
    vk::GpuDeformer gpu(test::gpuContext(), im.volume, im.mask, setupFor(f, data, sc->meshes.fine.tets, sc->lo, sc->hi));
    const std::vector<RigidTransform> T = {
        RigidTransform::about(sc->handleCentroid[0], Eigen::Vector3d(0, 0, 30 * M_PI / 180), Eigen::Vector3d(10, 0, 0))};
    auto xc = model.restState();
    model.solve(T, xc, 20);
    const CoarseFrameState st = packFrameState(xc, model.elementRotations(xc), T);
    gpu.runFrame(st, vk::Redo::Region);
    const auto got = gpu.readPositions();
    const auto ref = interpolateFineReference(data, st, f.q.geometry.worldToIndex().cast<float>());
    ASSERT_EQ(got.size(), ref.size());
    double worst = 0;
    for (std::size_t i = 0; i < got.size(); ++i) worst = std::max(worst, double((got[i] - ref[i]).norm()));
    // Same float expressions (fused multiply-adds and operation order may differ by ~1e-6 voxel);
    // nodes that moved less than the commit threshold (1e-3 voxel) from rest keep their rest position.
    EXPECT_LT(worst, 1.1e-3) << "voxels";
  }
}

TEST_F(DeformGpu, ZeroMotionReproducesTheInputWithinOneHu) {
  const Fixture& f = fixture();
  const Images im = upload(f.q, f.mask);
  vk::GpuDeformer gpu(test::gpuContext(), im.volume, im.mask, setupFor(f, f.data, f.scene.meshes.fine.tets, f.scene.lo, f.scene.hi));
  const auto xc = f.model->restState();
  const auto stats = gpu.runFrame(packFrameState(xc, f.model->elementRotations(xc), {RigidTransform{}}), vk::Redo::Region);
  const auto vol = gpu.readVolume();
  const auto msk = gpu.readMask();
  double worst = 0;
  for (std::size_t i = 0; i < vol.size(); ++i) worst = std::max(worst, double(std::abs(f.q.toValue(vol[i] / 65535.0f) - f.phantom.ct.value(i))));
  EXPECT_LE(worst, 1.0) << "HU";
  EXPECT_EQ(msk, f.mask);
  // No cracks: every region voxel covered, as on the CPU.
  Volume out;
  const RasterStats cpu = rasterizeDeformed(f.phantom.ct, f.scene.meshes.fine, f.scene.meshes.fine.nodes, {f.scene.lo, f.scene.hi, f.backgroundHu}, out);
  EXPECT_EQ(cpu.covered, cpu.regionVoxels);
  EXPECT_EQ(stats.coveredVoxels, cpu.regionVoxels);
}

TEST_F(DeformGpu, KidneyDragAgreesWithTheCpuReferenceAndRedoesOnlyTheMovedBox) {
  const Fixture& f = fixture();
  const Images im = upload(f.q, f.mask);
  const auto& mesh = f.scene.meshes.fine;
  vk::GpuDeformer gpu(test::gpuContext(), im.volume, im.mask, setupFor(f, f.data, mesh.tets, f.scene.lo, f.scene.hi));
  const Motion a = kidneyMotion(f, 10, 30);
  const auto full = gpu.runFrame(packFrameState(a.xc, f.model->elementRotations(a.xc), a.T), vk::Redo::Region);
  RasterStats cpu;
  const Agreement agA = compareWithReference(f, gpu, mesh, f.scene.lo, f.scene.hi, &cpu);
  EXPECT_GE(agA.fractionWithin1Hu, 0.999) << "worst " << agA.worstHu << " HU";
  EXPECT_GE(agA.maskAgreement, 0.999);
  EXPECT_NEAR(double(full.coveredVoxels), double(cpu.covered), 1e-3 * double(cpu.regionVoxels));
  // The handle's id moved with it: the mask holds the kidney where the CPU reference puts it.
  std::size_t kidneyVoxels = 0;
  for (auto v : gpu.readMask()) kidneyVoxels += v == kKidneyId ? 1 : 0;
  std::size_t restKidney = 0;
  for (auto v : f.mask) restKidney += v == kKidneyId ? 1 : 0;
  // Within 5 %: the handle holds the fine nodes inside the kidney, so the tets that straddle its
  // boundary deform and its outermost voxels go with them (measured 3.4 % fewer on this 4 mm phantom;
  // with --interface sliding 9.5 %, those tets' outer nodes sliding past the kidney:
  // docs/tissue-physics.md).
  EXPECT_NEAR(double(kidneyVoxels), double(restKidney), 0.05 * double(restKidney));

  // A further, smaller drag: only the moved tets' box is redone, and the result equals a redo of
  // the whole region, and of the whole volume, from the same positions (bit for bit: same rule, same
  // arithmetic), and a fresh deformer's first frame within 1 HU (its positions are exact, ours
  // may lag by the commit threshold).
  const Motion b = kidneyMotion(f, 12, 32);
  const CoarseFrameState stB = packFrameState(b.xc, f.model->elementRotations(b.xc), b.T);
  const auto inc = gpu.runFrame(stB);
  EXPECT_GT(inc.movedTets, 0u);
  EXPECT_GT(inc.boxVoxels(), 0u);
  EXPECT_LT(inc.boxVoxels(), full.boxVoxels());
  const auto volInc = gpu.readVolume();
  const auto maskInc = gpu.readMask();
  const auto again = gpu.runFrame(stB, vk::Redo::Region);
  EXPECT_EQ(again.movedTets, 0u);
  EXPECT_EQ(gpu.readVolume(), volInc);
  EXPECT_EQ(gpu.readMask(), maskInc);
  const auto whole = gpu.runFrame(stB, vk::Redo::WholeVolume);
  EXPECT_EQ(whole.boxVoxels(), f.q.geometry.voxelCount());
  EXPECT_EQ(gpu.readVolume(), volInc);
  EXPECT_EQ(gpu.readMask(), maskInc);
  vk::GpuDeformer fresh(test::gpuContext(), im.volume, im.mask, setupFor(f, f.data, mesh.tets, f.scene.lo, f.scene.hi));
  fresh.runFrame(stB, vk::Redo::Region);
  const auto volFresh = fresh.readVolume();
  std::size_t close = 0;
  for (std::size_t i = 0; i < volInc.size(); ++i) close += std::abs(f.q.toValue(volInc[i] / 65535.0f) - f.q.toValue(volFresh[i] / 65535.0f)) <= 1.0f ? 1 : 0;
  EXPECT_GE(double(close) / double(volInc.size()), 0.999);
  const Agreement agB = compareWithReference(f, gpu, mesh, f.scene.lo, f.scene.hi);
  EXPECT_GE(agB.fractionWithin1Hu, 0.999);
  std::printf("kidney drag: whole region %llu voxels, %u covered (CPU %zu); within 1 HU %.5f (worst %.2f HU), mask %.5f;\n"
              "  then 2 mm / 2 deg more: %u tets moved, box %llu voxels, %u covered\n",
              (unsigned long long)full.boxVoxels(), full.coveredVoxels, cpu.covered, agA.fractionWithin1Hu, agA.worstHu, agA.maskAgreement, inc.movedTets,
              (unsigned long long)inc.boxVoxels(), inc.coveredVoxels);

  // Nothing moved: nothing is redone, nothing changes.
  const auto before = gpu.readVolume();
  const auto idle = gpu.runFrame(stB);
  EXPECT_EQ(idle.movedTets, 0u);
  EXPECT_EQ(idle.boxVoxels(), 0u);
  EXPECT_EQ(gpu.readVolume(), before);
}

// A kidney drag in small steps on `scene` (its coarse model, the deformer's setup `lagging`). Brick frames redo only the bricks whose tissue may have moved more
// than the stated lag since they were last resampled; every node still takes its exact position.
// Checked against a deformer that redoes the whole region at the exact state every frame: the
// positions are equal, the image differs by no more than a shift of the lag makes (3 lag x the
// largest neighbouring voxel step + the 16-bit rounding), some frames redo fewer bricks than there
// are, and one settled frame makes the images equal bit for bit. A frame without motion redoes nothing.
static void checkBricksDuringMotion(const SimScene& scene, CoarseModel& model, const vk::DeformSetup& lagging, double stepMm) {
  const Fixture& f = fixture();
  const Images im = upload(f.q, f.mask);
  vk::DeformSetup exact = lagging;
  exact.commitVoxels = 0.0;
  vk::GpuDeformer bricks(test::gpuContext(), im.volume, im.mask, lagging), whole(test::gpuContext(), im.volume, im.mask, exact);
  const Eigen::Vector3i rlo = bricks.regionVoxelLo(), rhi = bricks.regionVoxelHi();
  const Eigen::Vector3i brickDims = (rhi - rlo + Eigen::Vector3i::Constant(HANDSON_DEFORM_BRICK)) / HANDSON_DEFORM_BRICK;
  const std::uint32_t allBricks = std::uint32_t(brickDims.prod());
  const Eigen::Vector3i d = f.q.geometry.dims;
  auto hu = [&](const std::vector<std::uint16_t>& v, int x, int y, int z) {
    return double(f.q.toValue(v[std::size_t(x) + std::size_t(d.x()) * (std::size_t(y) + std::size_t(d.y()) * std::size_t(z))] / 65535.0f));
  };
  std::uint32_t fewest = allBricks;
  double worstRatio = 0;
  CoarseFrameState st;
  for (int k = 1; k <= 6; ++k) {
    const std::vector<RigidTransform> T = {
        RigidTransform::about(scene.handleCentroid[0], Eigen::Vector3d(0, 0, stepMm * k * M_PI / 180), Eigen::Vector3d(stepMm * k, 0, 0))};
    std::vector<Eigen::Vector3d> xc = model.restState();
    model.solve(T, xc, 20);
    st = packFrameState(xc, model.elementRotations(xc), T);
    const auto a = bricks.runFrame(st, vk::Redo::BricksDuringMotion);
    whole.runFrame(st, vk::Redo::Region);
    EXPECT_TRUE(a.bricks);
    EXPECT_LE(a.dirtyBricks, allBricks);
    if (k > 1) fewest = std::min(fewest, a.dirtyBricks);
    EXPECT_EQ(bricks.readPositions(), whole.readPositions()) << "every node at its exact position";
    const auto lag = bricks.readVolume(), ex = whole.readVolume();
    for (int z = rlo.z(); z <= rhi.z(); ++z)
      for (int y = rlo.y(); y <= rhi.y(); ++y)
        for (int x = rlo.x(); x <= rhi.x(); ++x) {
          const double e = std::abs(hu(lag, x, y, z) - hu(ex, x, y, z));
          if (e == 0) continue;
          double step = 0;
          for (int dz = -1; dz <= 1; ++dz)
            for (int dy = -1; dy <= 1; ++dy)
              for (int dx = -1; dx <= 1; ++dx) {
                const int p = std::clamp(x + dx, 0, d.x() - 2), q = std::clamp(y + dy, 0, d.y() - 2), r = std::clamp(z + dz, 0, d.z() - 2);
                const double c = hu(ex, p, q, r);
                step = std::max({step, std::abs(hu(ex, p + 1, q, r) - c), std::abs(hu(ex, p, q + 1, r) - c), std::abs(hu(ex, p, q, r + 1) - c)});
              }
          worstRatio = std::max(worstRatio, e / (3.0 * lagging.motionLagVoxels * step + 0.5));
        }
  }
  EXPECT_LT(fewest, allBricks) << "a frame during motion redid every brick";
  EXPECT_LE(worstRatio, 1.0) << "a voxel lags more than the stated tolerance";
  const auto settled = bricks.runFrame(st, vk::Redo::Bricks);
  EXPECT_GT(settled.dirtyBricks, 0u);
  EXPECT_EQ(bricks.readVolume(), whole.readVolume()) << "the settled frame equals a whole redo";
  EXPECT_EQ(bricks.readMask(), whole.readMask());
  const auto still = bricks.runFrame(st, vk::Redo::Bricks);
  EXPECT_EQ(still.dirtyBricks, 0u);
  EXPECT_EQ(still.movedTets, 0u);
  EXPECT_EQ(bricks.readVolume(), whole.readVolume());
  std::printf("bricks: %u in the region, fewest redone in a frame during motion %u, settled %u; worst error / tolerance %.3f\n", allBricks, fewest,
              settled.dirtyBricks, worstRatio);
}

TEST_F(DeformGpu, DuringMotionOnlyBricksThatMayLagMoreThanTheToleranceAreRedoneAndTheSettledFrameIsExact) {
  const Fixture& f = fixture();
  checkBricksDuringMotion(f.scene, *f.model, setupFor(f, f.data, f.scene.meshes.fine.tets, f.scene.lo, f.scene.hi), 0.4);  // the default lag
}

// The same with a sliding kidney drawn rigidly: its rim lies in bricks whose nodes barely move (the
// tissue slides past it), so its own motion marks the bricks its box meets.
TEST_F(DeformGpu, DuringMotionARigidlyDrawnSlidingHandleLagsNoMoreThanTheTolerance) {
  const Fixture& f = fixture();
  const test::SlidingScene& s = test::slidingScene();
  vk::DeformSetup setup = setupFor(f, s.data, s.scene.meshes.fine.tets, s.scene.lo, s.scene.hi);
  setup.rigidIds = {kKidneyId};
  setup.rigidRestBoxes = {s.kidneyBox};
  checkBricksDuringMotion(s.scene, *s.model, setup, 1.5);  // steps of 0.375 voxel
}

TEST_F(DeformGpu, AffineMotionOfTheWholeRegionMatchesAnalyticWarping) {
  // Every fine node moved by one affine map (a handle carrying the whole mesh): the output at x is
  // the source at A^-1 (x - c - t) + c wherever that lies inside the region.
  const Fixture& f = fixture();
  const Images im = upload(f.q, f.mask);
  const Eigen::Vector3d lo(-60, -90, -70), hi(60, 30, 50);
  const KuhnGrid grid(lo, Eigen::Vector3d::Constant(10.0), {12, 12, 12});
  const TetMesh mesh = grid.mesh();
  FineInterpolationData d;
  d.handleCount = 1;
  for (const auto& X : mesh.nodes) {
    d.node.push_back({FineInterpolationData::Handle, 0, 0, 0});
    d.rest.emplace_back(float(X.x()), float(X.y()), float(X.z()), 1.0f);
  }
  d.coarseRest = {Eigen::Vector4f(0, 0, 0, 1)};
  d.elementCorners = {{0, 0, 0, 0}, {0, 0, 0, 0}};
  vk::GpuDeformer gpu(test::gpuContext(), im.volume, im.mask, setupFor(f, d, mesh.tets, lo, hi));
  const Eigen::Vector3d c = 0.5 * (lo + hi);
  const Eigen::Matrix3d A = Eigen::AngleAxisd(0.15, Eigen::Vector3d(0.2, 0.3, 1).normalized()).toRotationMatrix() * Eigen::Vector3d(1.04, 0.97, 1.02).asDiagonal();
  const Eigen::Vector3d t(3.0, -2.0, 1.5);
  CoarseFrameState st;
  st.positions = d.coarseRest;
  st.rotations = {Eigen::Vector4f(0, 0, 0, 1)};
  Eigen::Matrix4d M = Eigen::Matrix4d::Identity();
  M.topLeftCorner<3, 3>() = A;
  M.topRightCorner<3, 1>() = c + t - A * c;
  st.handles = {M.cast<float>()};
  gpu.runFrame(st, vk::Redo::Region);
  const auto vol = gpu.readVolume();
  const auto& g = f.q.geometry;
  const Eigen::Matrix3d Ainv = A.inverse();
  std::size_t checked = 0;
  double worst = 0;
  for (int k = 0; k < g.dims.z(); ++k)
    for (int j = 0; j < g.dims.y(); ++j)
      for (int i = 0; i < g.dims.x(); ++i) {
        const Eigen::Vector3d x = g.toWorld(Eigen::Vector3d(i, j, k));
        if (!inRegion(x, lo, hi)) continue;
        const Eigen::Vector3d X = c + Ainv * (x - c - t);
        if (((X - lo).array() < 1.0).any() || ((hi - X).array() < 1.0).any()) continue;  // near the moved boundary
        const std::size_t lin = f.phantom.ct.linearIndex(i, j, k);
        const double expect = f.phantom.ct.sampleLinear((g.worldToIndex() * X.homogeneous()).head<3>());
        worst = std::max(worst, std::abs(double(f.q.toValue(vol[lin] / 65535.0f)) - expect));
        ++checked;
      }
  EXPECT_GT(checked, 10000u);
  EXPECT_LT(worst, 1.0) << "HU";
  const Agreement ag = compareWithReference(f, gpu, mesh, lo, hi);
  EXPECT_GE(ag.fractionWithin1Hu, 0.999);
  EXPECT_GE(ag.maskAgreement, 0.999);
}

TEST_F(DeformGpu, InconsistentInputIsRefused) {
  const Fixture& f = fixture();
  const Images im = upload(f.q, f.mask);
  auto bad = f.data;
  bad.node[5] = {FineInterpolationData::Corner, 1u << 30, 0, 0};
  EXPECT_THROW(vk::GpuDeformer(test::gpuContext(), im.volume, im.mask, setupFor(f, bad, f.scene.meshes.fine.tets, f.scene.lo, f.scene.hi)), Error);
  auto badHandle = f.data;
  for (auto& n : badHandle.node)
    if (n[0] == FineInterpolationData::Interior && n[3] > 0) {
      badHandle.blocks[n[2] + 3 * badHandle.cornersPerElement].x() = 5.0f;  // there is one handle
      break;
    }
  EXPECT_THROW(vk::GpuDeformer(test::gpuContext(), im.volume, im.mask, setupFor(f, badHandle, f.scene.meshes.fine.tets, f.scene.lo, f.scene.hi)), Error);
  std::vector<std::array<int, 4>> tets = f.scene.meshes.fine.tets;
  tets[0][2] = -1;
  EXPECT_THROW(vk::GpuDeformer(test::gpuContext(), im.volume, im.mask, setupFor(f, f.data, tets, f.scene.lo, f.scene.hi)), Error);
  EXPECT_THROW(vk::GpuDeformer(test::gpuContext(), im.volume, im.mask,
                               setupFor(f, f.data, f.scene.meshes.fine.tets, Eigen::Vector3d(5000, 5000, 5000), Eigen::Vector3d(5100, 5100, 5100))),
               Error);
  vk::GpuDeformer gpu(test::gpuContext(), im.volume, im.mask, setupFor(f, f.data, f.scene.meshes.fine.tets, f.scene.lo, f.scene.hi));
  CoarseFrameState st;
  EXPECT_THROW(gpu.runFrame(st, vk::Redo::Region), Error);
}

// A refined state (fine positions from the two-level steps) is uploaded and drawn like any other:
// equal to a fresh whole-region redo of the same positions, and to the CPU reference. Returns the
// frame of the coarse state `st` drawn after it.
FrameResult expectRefinedStateDrawnLikeAWholeRegionRedo(VolumeRenderer& renderer, const Fixture& f, const Motion& m, const gpu::RenderParams& p,
                                                        const CoarseFrameState& st) {
  FineRefiner refiner(*f.model, f.scene.fineK);
  auto xc = m.xc;
  auto fine = f.model->reconstruct(m.T, xc);
  refiner.step(m.T, xc, fine, 10);
  const Eigen::Matrix4d w2i = f.q.geometry.worldToIndex();
  std::vector<Eigen::Vector4f> idx(fine.size());
  for (std::size_t i = 0; i < fine.size(); ++i) idx[i] = (w2i * fine[i].homogeneous()).cast<float>();
  FrameRequest req;
  req.params = p;
  req.deformFine = &idx;
  renderer.submit(req);
  renderer.waitLast();
  const auto shown = renderer.deformer()->readVolume();
  FineInterpolationData restData;
  restData.node.assign(fine.size(), {FineInterpolationData::Rest, 0, 0, 0});
  for (const auto& X : f.scene.meshes.fine.nodes) restData.rest.emplace_back(float(X.x()), float(X.y()), float(X.z()), 1.0f);
  restData.coarseRest = {Eigen::Vector4f(0, 0, 0, 1)};
  restData.elementCorners = {{0, 0, 0, 0}, {0, 0, 0, 0}};
  const Images im = upload(f.q, f.mask);
  vk::GpuDeformer fresh(test::gpuContext(), im.volume, im.mask, setupFor(f, restData, f.scene.meshes.fine.tets, f.scene.lo, f.scene.hi));
  fresh.runFrame(idx);
  EXPECT_EQ(shown, fresh.readVolume()) << "the moved box of the refined state equals a whole-region redo";
  Volume out;
  rasterizeDeformed(f.phantom.ct, f.scene.meshes.fine, fine, {f.scene.lo, f.scene.hi, f.backgroundHu}, out);
  std::size_t within = 0;
  for (std::size_t i = 0; i < shown.size(); ++i) within += std::abs(f.q.toValue(shown[i] / 65535.0f) - out.value(i)) <= 1.0f ? 1 : 0;
  EXPECT_GE(double(within) / double(shown.size()), 0.999);
  // Back to the coarse state for the frames below, drawn at its exact state (a frame during
  // motion may lag it by the allowed lag; the next frame without a new state would settle it).
  req = FrameRequest{};
  req.params = p;
  req.deform = &st;
  req.deformExact = true;
  renderer.submit(req);
  return renderer.waitLast();
}

// A mask edit while deforming (a live selection elsewhere, a handle inside the region) shows at
// once: outside the region copied, inside it carried through the deformation. Both edits undone.
void expectMaskEditsShowWhileDeforming(VolumeRenderer& renderer, const Fixture& f, const gpu::RenderParams& p) {
  FrameRequest req;
  const Eigen::Vector3i rlo = renderer.deformer()->regionVoxelLo(), rhi = renderer.deformer()->regionVoxelHi();
  MaskUpload outside, inside;
  outside.min = Eigen::Vector3i(0, 0, 0);
  outside.dims = Eigen::Vector3i(3, 3, 3);
  ASSERT_TRUE((outside.min + outside.dims).x() <= rlo.x() || (outside.min + outside.dims).y() <= rlo.y() || (outside.min + outside.dims).z() <= rlo.z());
  outside.ids.assign(27, 7);
  inside.min = (rlo + rhi) / 2;
  inside.dims = Eigen::Vector3i(2, 2, 2);
  inside.ids.assign(8, 9);
  auto uploadBoth = [&] {
    for (const MaskUpload* up2 : {&outside, &inside}) {
      req = FrameRequest{};
      req.params = p;
      req.maskUpload = up2;
      renderer.submit(req);
      renderer.waitLast();
    }
  };
  uploadBoth();
  const auto m2 = renderer.deformer()->readMask();
  std::size_t sevens = 0, nines = 0;
  for (auto v : m2) sevens += v == 7, nines += v == 9;
  EXPECT_EQ(sevens, 27u);
  EXPECT_GT(nines, 0u);
  // Undo both edits (the frames below compare with the images before them).
  outside.ids.assign(27, 0);
  inside.ids.assign(8, 0);
  for (std::size_t i = 0; i < 8; ++i) {
    const Eigen::Vector3i v = inside.min + Eigen::Vector3i(int(i & 1), int((i >> 1) & 1), int((i >> 2) & 1));
    inside.ids[i] = f.mask[std::size_t(v.x()) + std::size_t(f.q.geometry.dims.x()) * (std::size_t(v.y()) + std::size_t(f.q.geometry.dims.y()) * std::size_t(v.z()))];
  }
  uploadBoth();
}

TEST_F(DeformGpu, FrameGraphDeformsThenRaymarchesAndPicksTheDeformedVolume) {
  // interpolation -> resampling (volume + mask) -> raymarch -> picking in one frame graph: the
  // frame equals the CPU raymarch of the GPU's deformed volume and mask, and a pick through the
  // kidney's new place hits the handle there.
  const Fixture& f = fixture();
  VolumeRenderer renderer(test::gpuContext());
  renderer.setVolume(f.q);
  const auto lut = transferFunctionPreset("ct-abdomen").lookupTable(f.q);
  renderer.setTransferFunction(lut);
  std::vector<glm::vec4> tints(gpu::kMaxHandleIds, glm::vec4(0.0f));
  tints[kKidneyId] = glm::vec4(0.2f, 0.9f, 0.3f, 0.6f);
  renderer.setHandleTints(tints);
  MaskUpload up;
  up.dims = f.q.geometry.dims;
  up.ids = f.mask;
  RenderSettings rs;
  rs.width = rs.height = 96;
  const OrbitCamera cam = OrbitCamera::framing(f.q.geometry, glm::radians(0.0), glm::radians(-90.0));
  const gpu::RenderParams p = makeRenderParams(f.q.geometry, cam.view(), cam.projection(1.0), glm::vec3(cam.eye()), rs, 1);
  FrameRequest req;
  req.params = p;
  req.maskUpload = &up;
  renderer.submit(req);
  const FrameResult before = renderer.waitLast();

  vk::DeformSetup setup = setupFor(f, f.data, f.scene.meshes.fine.tets, f.scene.lo, f.scene.hi);
  renderer.beginDeformation(setup);
  ASSERT_TRUE(renderer.deforming());
  const Motion m = kidneyMotion(f, 20, 0);
  const CoarseFrameState st = packFrameState(m.xc, f.model->elementRotations(m.xc), m.T);
  // A pick at the kidney's moved centroid, projected to the screen.
  const Eigen::Vector3d moved = m.T[0].apply(f.scene.handleCentroid[0]);
  const glm::dvec4 clip = cam.projection(1.0) * cam.view() * glm::dvec4(moved.x(), moved.y(), moved.z(), 1.0);
  const glm::vec2 ndc(float(clip.x / clip.w), float(clip.y / clip.w));
  req = FrameRequest{};
  req.params = p;
  req.deform = &st;
  req.pickPoints = {ndc};
  renderer.submit(req);
  const FrameResult after = renderer.waitLast();
  ASSERT_EQ(after.picks.size(), 1u);
  EXPECT_GT(after.picks[0].world.w, 0.5f);
  EXPECT_EQ(after.picks[0].voxel.w, kKidneyId) << "the pick lands on the moved kidney";
  bool ran = false;
  for (const auto& t : after.timings) ran = ran || t.id == PassId::DeformResolve;
  EXPECT_TRUE(ran || after.timings.empty());

  // The CPU raymarch of the deformed volume and mask the GPU made.
  QuantizedVolume dq = f.q;
  dq.data = renderer.deformer()->readVolume();
  const auto dmask = renderer.deformer()->readMask();
  const ReferenceScene ref{&dq, &lut, &renderer.occupancy(), &dmask, &tints};
  const auto cpu = raymarchReference(ref, p);
  std::size_t over = 0, changed = 0;
  for (std::size_t i = 0; i + 3 < cpu.size(); i += 4) {
    int d = 0, c = 0;
    for (int k = 0; k < 3; ++k) {
      d = std::max(d, std::abs(int(cpu[i + k]) - int(after.rgba[i + k])));
      c = std::max(c, std::abs(int(before.rgba[i + k]) - int(after.rgba[i + k])));
    }
    over += d > 2;
    changed += c > 8;
  }
  std::printf("deformed frame: %zu of %zu pixels changed by the drag, %zu off the CPU reference by > 2/255\n", changed, cpu.size() / 4, over);
  EXPECT_LE(double(over) / double(cpu.size() / 4), 0.01) << "pixels off the CPU reference by more than 2/255";
  EXPECT_GT(changed, 20u) << "the kidney moved on screen";

  const FrameResult coarseAgain = expectRefinedStateDrawnLikeAWholeRegionRedo(renderer, f, m, p, st);
  expectMaskEditsShowWhileDeforming(renderer, f, p);
  if (HasFatalFailure()) return;

  // A frame without new state shows the same deformed volume; ending the deformation restores the input.
  req = FrameRequest{};
  req.params = p;
  renderer.submit(req);
  EXPECT_EQ(renderer.waitLast().rgba, coarseAgain.rgba);
  EXPECT_FALSE(renderer.deformationLagging()) << "a frame without a new state settles the deformation";
  renderer.endDeformation();
  req = FrameRequest{};
  req.params = p;
  renderer.submit(req);
  EXPECT_EQ(renderer.waitLast().rgba, before.rgba);
}

TEST_F(DeformGpu, ATornStateIsDrawnWithoutItsStretchedTetsAsOnTheCpu) {
  // One fine node thrown 300 mm away (a torn solve): its tets would cover most of the region. They
  // are skipped and counted on the GPU and on the CPU alike; the rest is drawn as usual.
  const Fixture& f = fixture();
  const Images im = upload(f.q, f.mask);
  const auto& mesh = f.scene.meshes.fine;
  FineInterpolationData rest;  // positions come from the caller
  rest.node.assign(mesh.nodes.size(), {FineInterpolationData::Rest, 0, 0, 0});
  for (const auto& X : mesh.nodes) rest.rest.emplace_back(float(X.x()), float(X.y()), float(X.z()), 1.0f);
  rest.coarseRest = {Eigen::Vector4f(0, 0, 0, 1)};
  rest.elementCorners = {{0, 0, 0, 0}, {0, 0, 0, 0}};
  vk::GpuDeformer gpu(test::gpuContext(), im.volume, im.mask, setupFor(f, rest, mesh.tets, f.scene.lo, f.scene.hi));
  std::vector<Eigen::Vector3d> world = mesh.nodes;
  std::size_t far = 0;  // a node near the region's centre, nowhere near the fixed faces
  const Eigen::Vector3d c = 0.5 * (f.scene.lo + f.scene.hi);
  for (std::size_t i = 0; i < world.size(); ++i)
    if ((world[i] - c).norm() < (world[far] - c).norm()) far = i;
  world[far] += Eigen::Vector3d(300, 250, -200);
  const Eigen::Matrix4d w2i = f.q.geometry.worldToIndex();
  std::vector<Eigen::Vector4f> idx(world.size());
  for (std::size_t i = 0; i < world.size(); ++i) idx[i] = (w2i * world[i].homogeneous()).cast<float>();
  const auto st = gpu.runFrame(idx);
  EXPECT_GT(st.skippedTets, 0u);
  Volume out;
  const RasterStats cpu = rasterizeDeformed(f.phantom.ct, mesh, world, {f.scene.lo, f.scene.hi, f.backgroundHu}, out,
                                            {nullptr, nullptr, defaultMaxTetVoxels(mesh, w2i), nullptr, {}});
  EXPECT_EQ(cpu.skipped, st.skippedTets);
  const auto vol = gpu.readVolume();
  std::size_t within = 0;
  for (std::size_t i = 0; i < vol.size(); ++i) within += std::abs(f.q.toValue(vol[i] / 65535.0f) - out.value(i)) <= 1.0f ? 1 : 0;
  EXPECT_GE(double(within) / double(vol.size()), 0.999);
  // Brick frames from rest to the torn state (the torn node's tets reach across the region: their
  // bricks are marked, or every brick when they span more than a tet may mark): the same image as
  // the region redo, the same tets skipped.
  vk::GpuDeformer bricks(test::gpuContext(), im.volume, im.mask, setupFor(f, rest, mesh.tets, f.scene.lo, f.scene.hi));
  const auto sb = bricks.runFrameFromPositions(idx, vk::Redo::BricksDuringMotion);
  EXPECT_EQ(sb.skippedTets, st.skippedTets);
  EXPECT_EQ(bricks.readVolume(), vol);
  // A whole-region scale of the same kind: every node thrown far, so tets span more bricks than
  // they may mark and every brick is redone.
  std::vector<Eigen::Vector4f> spread(idx.size());
  const Eigen::Vector4f mid = (w2i * c.homogeneous()).cast<float>();
  for (std::size_t i = 0; i < idx.size(); ++i) spread[i] << mid.head<3>() + 40.0f * (idx[i].head<3>() - mid.head<3>()), 1.0f;
  const auto all = bricks.runFrameFromPositions(spread, vk::Redo::BricksDuringMotion);
  EXPECT_TRUE(all.allBricks);
  vk::GpuDeformer region(test::gpuContext(), im.volume, im.mask, setupFor(f, rest, mesh.tets, f.scene.lo, f.scene.hi));
  region.runFrame(spread);
  EXPECT_EQ(bricks.readVolume(), region.readVolume());
}
