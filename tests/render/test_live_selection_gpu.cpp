// A pinch's live selection grown by the GPU inside the renderer's frames (render/live_selection.h)
// against its CPU references: region growing's keys (interaction/region_grow.h) and paintLiveBox
// (live_mask.comp's reference). Lavapipe, validation layer on.
#include <gtest/gtest.h>

#include <algorithm>

#include "gpu_test_env.h"
#include "interaction/camera.h"
#include "interaction/region_grow.h"
#include "render/live_selection.h"
#include "render/render_params.h"
#include "render/transfer_function.h"
#include "render/volume_renderer.h"
#include "shaders/shared.h"
#include "sim/base/error.h"
#include "sim/phantom.h"

using namespace handson;

namespace {

class LiveSelectionGpu : public test::GpuTest {};

constexpr std::uint8_t kHandle = 3;

std::size_t linear(const Eigen::Vector3i& v, const Eigen::Vector3i& d) {
  return std::size_t(v.x()) + std::size_t(d.x()) * (std::size_t(v.y()) + std::size_t(d.y()) * std::size_t(v.z()));
}

/// What the mask must hold: `ids` outside the box, paintLiveBox of the reference's keys inside it.
std::vector<std::uint8_t> expectedMask(const RegionGrower& cpu, const std::vector<std::uint8_t>& ids, const Eigen::Vector3i& lo,
                                       const Eigen::Vector3i& dims, const Eigen::Vector3i& volumeDims, std::uint32_t bound) {
  std::vector<std::uint32_t> keys;
  std::vector<std::uint8_t> base;
  for (int k = 0; k < dims.z(); ++k)
    for (int j = 0; j < dims.y(); ++j)
      for (int i = 0; i < dims.x(); ++i) {
        const std::size_t v = linear(lo + Eigen::Vector3i(i, j, k), volumeDims);
        keys.push_back(cpu.keys()[v]);
        base.push_back(ids[v]);
      }
  const auto painted = vk::paintLiveBox(keys, base, bound);
  std::vector<std::uint8_t> out = ids;
  std::size_t b = 0;
  for (int k = 0; k < dims.z(); ++k)
    for (int j = 0; j < dims.y(); ++j)
      for (int i = 0; i < dims.x(); ++i) out[linear(lo + Eigen::Vector3i(i, j, k), volumeDims)] = painted[b++];
  return out;
}

// The liver of a 3 mm phantom, a renderer on it and a small frame (no image read back).
struct LiverScene {
  static PhantomOptions options() {
    PhantomOptions o;
    o.spacingMm = 3.0;
    return o;
  }
  Phantom ph = makePhantom(options());
  QuantizedVolume q = quantizeVolume(ph.ct);
  Eigen::Vector3i seed = ph.ct.geometry().toIndex(ph.geometry.liverCenter).array().round().cast<int>();
  VolumeRenderer renderer{test::gpuContext()};
  FrameRequest req;
  LiverScene() {
    renderer.setVolume(q);
    renderer.setTransferFunction(transferFunctionPreset("ct-abdomen").lookupTable(q));
    RenderSettings rs;
    rs.width = rs.height = 24;
    const OrbitCamera cam = OrbitCamera::framing(ph.ct.geometry(), 0.6, 0.3, 1.0);
    req.params = makeRenderParams(ph.ct.geometry(), cam.view(), cam.projection(1.0), glm::vec3(cam.eye()), rs, 0);
    req.readbackImage = false;
  }
};

}  // namespace

TEST(LiveSelection, PaintLiveBoxMarksKeysWithinTheBoundAndKeepsTheBaseElsewhere) {
  const std::vector<std::uint32_t> keys = {0, 5, 9, gpu::kGrowUnreached, 6};
  const std::vector<std::uint8_t> base = {0, 2, 2, 7, 0};
  EXPECT_EQ(vk::paintLiveBox(keys, base, 6), (std::vector<std::uint8_t>{255, 255, 2, 7, 255}));
  EXPECT_EQ(vk::paintLiveBox(keys, base, 0), (std::vector<std::uint8_t>{255, 2, 2, 7, 0}));
  EXPECT_THROW(vk::paintLiveBox(keys, {1, 2}, 6), Error);
}

// The liver of a 3 mm phantom pinched at 15 mm, closed to 8 mm, spread to 40 mm; a handle's ids lie
// in part of the box. After each change the frames grow the selection by themselves; the mask they
// leave equals the reference's selection painted over the handle ids (live id 255 where the key is
// within the bound), while growing it holds only voxels of the final selection, and finishing
// returns the reference's voxels.
TEST_F(LiveSelectionGpu, FramesGrowItPaintTheReferenceSelectionIntoTheMaskAndFinishWithItsVoxels) {
  LiverScene scene;
  const Eigen::Vector3i d = scene.q.geometry.dims;

  RegionGrower cpu(scene.q, scene.seed, GrowParams{});
  const double e0 = 8, e1 = 15, e2 = 40;
  const Eigen::Vector3i reach = growReach(cpu.setup().criterion, cpu.setup().bound, e2, scene.q.geometry.spacing) + Eigen::Vector3i::Ones();
  const Eigen::Vector3i lo = (scene.seed - reach).cwiseMax(Eigen::Vector3i::Zero());
  const Eigen::Vector3i dims = (scene.seed + reach).cwiseMin(d - Eigen::Vector3i::Ones()) - lo + Eigen::Vector3i::Ones();
  // A handle in the box's lower slabs, uploaded into the mask as the controller would.
  std::vector<std::uint8_t> ids(scene.q.data.size(), 0);
  for (int k = lo.z(); k < lo.z() + 3; ++k)
    for (int j = 0; j < d.y(); ++j)
      for (int i = 0; i < d.x(); ++i) ids[linear({i, j, k}, d)] = kHandle;
  MaskUpload up;
  up.dims = d;
  up.ids = ids;
  scene.req.maskUpload = &up;
  scene.renderer.submit(scene.req);
  scene.renderer.waitLast();
  scene.req.maskUpload = nullptr;
  auto boxOf = [&](const std::vector<std::uint8_t>& all) {
    std::vector<std::uint8_t> box;
    for (int k = 0; k < dims.z(); ++k)
      for (int j = 0; j < dims.y(); ++j)
        for (int i = 0; i < dims.x(); ++i) box.push_back(all[linear(lo + Eigen::Vector3i(i, j, k), d)]);
    return box;
  };
  const std::vector<std::uint8_t> base = boxOf(ids);

  scene.renderer.setLiveRoundsPerFrame(1);  // rounds spread over many frames
  scene.renderer.beginLiveSelection(cpu.setup(), lo, dims, base);
  ASSERT_NE(scene.renderer.liveSelection(), nullptr);
  scene.renderer.setLiveSelectionBound(cpu.bound(e1));
  cpu.growTo(e2);
  auto growFrames = [&]() -> int {
    int frames = 0;
    do {
      scene.renderer.submit(scene.req);
      scene.renderer.waitLast();
      ++frames;
      if (frames == 1) {  // mid-growth: only voxels of the final selection are live
        const auto mask = scene.renderer.readMask();
        std::size_t outside = 0;
        for (std::size_t v = 0; v < mask.size(); ++v) outside += mask[v] == 255 && cpu.keys()[v] > scene.renderer.liveSelection()->bound() ? 1 : 0;
        EXPECT_EQ(outside, 0u);
      }
    } while (scene.renderer.liveSelection()->growing() && frames < 500);
    EXPECT_FALSE(scene.renderer.liveSelection()->growing()) << frames << " frames";
    return frames;
  };
  EXPECT_GT(growFrames(), 2) << "one round a frame cannot grow a 15 mm liver selection in two frames";
  const auto afterE1 = scene.renderer.readMask();
  EXPECT_EQ(afterE1, expectedMask(cpu, ids, lo, dims, d, cpu.bound(e1)));
  EXPECT_GT(std::count(afterE1.begin(), afterE1.end(), 255), 100);

  scene.renderer.setLiveSelectionBound(cpu.bound(e0));  // closing the fingers: one frame repaints
  scene.renderer.submit(scene.req);
  scene.renderer.waitLast();
  EXPECT_FALSE(scene.renderer.liveSelection()->growing());
  EXPECT_EQ(scene.renderer.readMask(), expectedMask(cpu, ids, lo, dims, d, cpu.bound(e0)));

  scene.renderer.setLiveSelectionBound(cpu.bound(e2));  // spreading them: growth resumes
  growFrames();
  const auto afterE2 = scene.renderer.readMask();
  EXPECT_EQ(afterE2, expectedMask(cpu, ids, lo, dims, d, cpu.bound(e2)));
  EXPECT_GT(std::count(afterE2.begin(), afterE2.end(), 255), std::count(afterE1.begin(), afterE1.end(), 255));

  // A frame with nothing to grow or repaint carries no growth passes and leaves the mask alone.
  scene.renderer.submit(scene.req);
  EXPECT_FALSE(scene.renderer.liveSelection()->inFlight());
  scene.renderer.waitLast();
  EXPECT_EQ(scene.renderer.readMask(), afterE2);

  // The handles change under the pinch (another handle's ids in the box's upper slabs): the next
  // frame repaints the box over the new ids.
  for (int k = lo.z() + dims.z() - 3; k < lo.z() + dims.z(); ++k)
    for (int j = 0; j < d.y(); ++j)
      for (int i = 0; i < d.x(); ++i) ids[linear({i, j, k}, d)] = kHandle + 1;
  up.ids = ids;
  scene.req.maskUpload = &up;
  scene.renderer.setLiveSelectionBase(boxOf(ids));
  scene.renderer.submit(scene.req);
  scene.renderer.waitLast();
  scene.req.maskUpload = nullptr;
  EXPECT_EQ(scene.renderer.readMask(), expectedMask(cpu, ids, lo, dims, d, cpu.bound(e2)));

  std::vector<std::uint32_t> reference;
  for (std::size_t v = 0; v < scene.q.data.size(); ++v)
    if (cpu.keys()[v] <= cpu.bound(e2)) reference.push_back(std::uint32_t(v));
  EXPECT_EQ(scene.renderer.finishLiveSelection(), reference);
  EXPECT_EQ(scene.renderer.liveSelection(), nullptr);
  EXPECT_THROW(scene.renderer.setLiveSelectionBound(1), Error);
  EXPECT_THROW(scene.renderer.finishLiveSelection(), Error);
  // A box outside the volume is refused.
  EXPECT_THROW(scene.renderer.beginLiveSelection(cpu.setup(), d, dims, base), Error);
}

// Spreading past the box: a larger box around the same scene.seed replaces it, holding the bound the
// mask shows. Its frames grow without painting until the keys up to that bound are final (the mask
// keeps the old selection: never less of it), then paint and grow on to the reference's selection.
TEST_F(LiveSelectionGpu, ALargerBoxKeepsShowingTheOldSelectionUntilItHasGrownThatFar) {
  LiverScene scene;
  const Eigen::Vector3i d = scene.q.geometry.dims;
  RegionGrower cpu(scene.q, scene.seed, GrowParams{});
  const double e1 = 15, e2 = 40;
  cpu.growTo(e2);
  const std::vector<std::uint8_t> ids(scene.q.data.size(), 0);
  auto boxFor = [&](double extent) {
    const Eigen::Vector3i reach = growReach(cpu.setup().criterion, cpu.setup().bound, extent, scene.q.geometry.spacing) + Eigen::Vector3i::Ones();
    const Eigen::Vector3i lo = (scene.seed - reach).cwiseMax(Eigen::Vector3i::Zero());
    return std::make_pair(lo, Eigen::Vector3i((scene.seed + reach).cwiseMin(d - Eigen::Vector3i::Ones()) - lo + Eigen::Vector3i::Ones()));
  };
  const auto [lo1, dims1] = boxFor(e1);
  const auto [lo2, dims2] = boxFor(e2);
  ASSERT_GT(dims2.prod(), dims1.prod());
  scene.renderer.setLiveRoundsPerFrame(1);
  scene.renderer.beginLiveSelection(cpu.setup(), lo1, dims1, std::vector<std::uint8_t>(std::size_t(dims1.prod()), 0));
  scene.renderer.setLiveSelectionBound(cpu.bound(e1));
  for (int f = 0; f < 500 && scene.renderer.liveSelection()->growing(); ++f) {
    scene.renderer.submit(scene.req);
    scene.renderer.waitLast();
  }
  const auto old = scene.renderer.readMask();
  ASSERT_EQ(old, expectedMask(cpu, ids, lo1, dims1, d, cpu.bound(e1)));

  scene.renderer.beginLiveSelection(cpu.setup(), lo2, dims2, std::vector<std::uint8_t>(std::size_t(dims2.prod()), 0), cpu.bound(e1));
  scene.renderer.setLiveSelectionBound(cpu.bound(e2));
  int held = 0, frames = 0;
  for (; frames < 500 && scene.renderer.liveSelection()->growing(); ++frames) {
    scene.renderer.submit(scene.req);
    scene.renderer.waitLast();
    const auto mask = scene.renderer.readMask();
    if (scene.renderer.liveSelection()->holding()) {  // the frame carried rounds only (the hold ends in a frame's recording)
      ++held;
      EXPECT_EQ(mask, old) << "frame " << frames << " painted while holding";
    }
    std::size_t lost = 0, outside = 0;
    for (std::size_t v = 0; v < mask.size(); ++v) {
      lost += old[v] == 255 && mask[v] != 255 ? 1 : 0;
      outside += mask[v] == 255 && cpu.keys()[v] > cpu.bound(e2) ? 1 : 0;
    }
    EXPECT_EQ(lost, 0u) << "frame " << frames << " shows less than the old selection";
    EXPECT_EQ(outside, 0u) << "frame " << frames;
  }
  EXPECT_GT(held, 2) << "one round a frame cannot regrow a 15 mm selection in two frames";
  EXPECT_GT(frames, held) << "growth went on past the held bound";
  EXPECT_FALSE(scene.renderer.liveSelection()->growing());
  EXPECT_EQ(scene.renderer.readMask(), expectedMask(cpu, ids, lo2, dims2, d, cpu.bound(e2)));
  std::vector<std::uint32_t> reference;
  for (std::size_t v = 0; v < scene.q.data.size(); ++v)
    if (cpu.keys()[v] <= cpu.bound(e2)) reference.push_back(std::uint32_t(v));
  EXPECT_EQ(scene.renderer.finishLiveSelection(), reference);
}
