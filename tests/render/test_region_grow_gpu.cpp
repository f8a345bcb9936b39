// The region-growing compute pass against its CPU reference: the same voxel set, sparse and dense.
#include <gtest/gtest.h>

#include <filesystem>

#include "app/io/nifti_io.h"
#include "gpu_test_env.h"
#include "interaction/region_grow.h"
#include "render/frame_graph.h"
#include "render/region_grow_pass.h"
#include "render/vk_graph_executor.h"
#include "render/vk_resources.h"
#include "shaders/shared.h"
#include "sim/phantom.h"
#include "sim/quantized_volume.h"

using namespace handson;

namespace {

class RegionGrowGpu : public test::GpuTest {};

fg::ImageDesc volumeDesc(const QuantizedVolume& q) {
  const auto& d = q.geometry.dims;
  return {std::uint32_t(d.x()), std::uint32_t(d.y()), std::uint32_t(d.z()), fg::Format::R16Unorm};
}

vk::Image uploadedVolume(const QuantizedVolume& q) {
  vk::Image volume(test::gpuContext(), volumeDesc(q), VK_IMAGE_USAGE_SAMPLED_BIT | VK_IMAGE_USAGE_TRANSFER_DST_BIT, true);
  vk::uploadToImage(test::gpuContext(), volume, q.data.data(), q.data.size() * 2, VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL);
  return volume;
}

/// The GPU box: the reach of the largest extent (plus a voxel) around the seed, clipped to the volume.
void boxAround(const QuantizedVolume& q, const Eigen::Vector3i& seed, const GrowSetup& s, double maxExtent, Eigen::Vector3i& lo,
               Eigen::Vector3i& dims) {
  const Eigen::Vector3i r = growReach(s.criterion, s.bound, maxExtent, q.geometry.spacing) + Eigen::Vector3i::Ones();
  lo = (seed - r).cwiseMax(Eigen::Vector3i::Zero());
  const Eigen::Vector3i hi = (seed + r).cwiseMin(q.geometry.dims - Eigen::Vector3i::Ones());
  dims = hi - lo + Eigen::Vector3i::Ones();
}

/// The GPU's selection up to `bound` against the CPU reference's over the box: voxels only one
/// selects, voxels both select with different keys, and how many both select (d: the volume's dims).
struct KeyComparison {
  std::size_t onlyCpu = 0, onlyGpu = 0, keyDiffers = 0, both = 0;
};
KeyComparison compareKeys(const RegionGrower& cpu, const vk::GpuRegionGrower& gpu, std::uint32_t bound, const Eigen::Vector3i& d) {
  const auto gk = gpu.readKeys();
  const Eigen::Vector3i& lo = gpu.boxMin();
  const Eigen::Vector3i& bd = gpu.boxDims();
  KeyComparison out;
  for (int k = 0; k < bd.z(); ++k)
    for (int j = 0; j < bd.y(); ++j)
      for (int i = 0; i < bd.x(); ++i) {
        const std::size_t v =
            std::size_t(lo.x() + i) + std::size_t(d.x()) * (std::size_t(lo.y() + j) + std::size_t(d.y()) * std::size_t(lo.z() + k));
        const std::uint32_t a = cpu.keys()[v],
                            b = gk[std::size_t(i) + std::size_t(bd.x()) * (std::size_t(j) + std::size_t(bd.y()) * std::size_t(k))];
        out.both += a <= bound && b <= bound;
        out.onlyCpu += a <= bound && b > bound;
        out.onlyGpu += b <= bound && a > bound;
        out.keyDiffers += a <= bound && b <= bound && a != b;
      }
  return out;
}

// Grows on CPU and GPU at several extents (growing and shrinking) and compares the selections
// over the box. Returns the largest selection's size.
std::size_t compareOn(const QuantizedVolume& q, const Eigen::Vector3i& seed, GrowCriterion c, const std::vector<double>& extents,
                      bool dense, GrowBound b = GrowBound::Ball) {
  auto& ctx = test::gpuContext();
  const vk::Image volume = uploadedVolume(q);
  vk::Sampler sampler(ctx, false);
  GrowParams p;
  p.criterion = c;
  p.bound = b;
  RegionGrower cpu(q, seed, p);
  EXPECT_EQ(cpu.setup().bound, c == GrowCriterion::Paper ? GrowBound::Ball : b);
  EXPECT_EQ(cpu.setup().criterion, c) << "the seed lies in a structure too thin for a core: pick another";
  vk::GpuRegionGrower gpu(ctx, volume, sampler);
  Eigen::Vector3i lo, dims;
  boxAround(q, seed, cpu.setup(), *std::max_element(extents.begin(), extents.end()), lo, dims);
  gpu.begin(cpu.setup(), lo, dims);
  std::size_t largest = 0;
  for (double e : extents) {
    cpu.growTo(e);
    const std::uint32_t bound = cpu.bound(e);
    gpu.growTo(bound, dense);
    const KeyComparison k = compareKeys(cpu, gpu, bound, q.geometry.dims);
    EXPECT_EQ(k.onlyCpu, 0u) << growCriterionName(c) << " " << growBoundName(b) << " extent " << e;
    EXPECT_EQ(k.onlyGpu, 0u) << growCriterionName(c) << " " << growBoundName(b) << " extent " << e;
    EXPECT_EQ(k.keyDiffers, 0u) << growCriterionName(c) << " " << growBoundName(b) << " extent " << e;
    EXPECT_EQ(k.both, cpu.count(e)) << "the selection lies inside the box";
    largest = std::max(largest, k.both);
  }
  return largest;
}

}  // namespace

TEST_F(RegionGrowGpu, SameVoxelSetAsCpuOnThePhantom) {
  PhantomOptions o;
  o.spacingMm = 3.0;
  const Phantom ph = makePhantom(o);
  const QuantizedVolume q = quantizeVolume(ph.ct);
  const Eigen::Vector3i kidney = ph.ct.geometry().toIndex(ph.geometry.kidneyRightCenter).array().round().cast<int>();
  const Eigen::Vector3i liver = ph.ct.geometry().toIndex(ph.geometry.liverCenter).array().round().cast<int>();
  for (GrowCriterion c : {GrowCriterion::Paper, GrowCriterion::Smoothed, GrowCriterion::Core}) {
    EXPECT_GT(compareOn(q, kidney, c, {6, 15, 30, 20}, false), 50u);
    EXPECT_GT(compareOn(q, liver, c, {12, 40}, true), 500u);
  }
  // Path keys (sums of step lengths): the same shortest paths whatever order the rounds relax them in.
  for (GrowCriterion c : {GrowCriterion::Smoothed, GrowCriterion::Core}) {
    EXPECT_GT(compareOn(q, kidney, c, {6, 15, 30, 20}, false, GrowBound::Path), 50u);
    EXPECT_GT(compareOn(q, liver, c, {12, 40}, true, GrowBound::Path), 500u);
  }
}

TEST_F(RegionGrowGpu, SameVoxelSetAsCpuOnRealCt) {
  const std::string path = std::string(HANDSON_SHARED_DATA_DIR) + "/totalseg-small/ct.nii.gz";
  if (!std::filesystem::exists(path)) GTEST_SKIP() << "no " << path;
  const Volume ct = readNifti(path);
  const QuantizedVolume q = quantizeVolume(ct);
  // Seeds inside the right kidney and the liver of this scan (voxel indices from its labels).
  for (GrowCriterion c : {GrowCriterion::Paper, GrowCriterion::Smoothed, GrowCriterion::Core}) {
    EXPECT_GT(compareOn(q, {79, 35, 12}, c, {10, 20, 40}, false), 20u);
    EXPECT_GT(compareOn(q, {86, 47, 29}, c, {20, 10}, false), 20u);
  }
  for (GrowCriterion c : {GrowCriterion::Smoothed, GrowCriterion::Core}) {
    EXPECT_GT(compareOn(q, {79, 35, 12}, c, {10, 20, 40}, false, GrowBound::Path), 20u);
    EXPECT_GT(compareOn(q, {86, 47, 29}, c, {20, 10}, true, GrowBound::Path), 20u);
  }
}

// A live selection: one round per frame, each frame its own graph that imports the volume itself
// (as the app's frame does), and the extent raised while the front is still moving. The keys up
// to the final bound must be the CPU reference's, and the growth must stop by itself.
TEST_F(RegionGrowGpu, RoundsSpreadOverFramesWithTheExtentRaisedMidGrowthGiveTheCpuSet) {
  PhantomOptions o;
  o.spacingMm = 3.0;
  const Phantom ph = makePhantom(o);
  const QuantizedVolume q = quantizeVolume(ph.ct);
  const Eigen::Vector3i seed = ph.ct.geometry().toIndex(ph.geometry.liverCenter).array().round().cast<int>();
  auto& ctx = test::gpuContext();
  const vk::Image volume = uploadedVolume(q);
  vk::Sampler sampler(ctx, false);
  for (GrowBound b : {GrowBound::Ball, GrowBound::Path}) {
    GrowParams p;
    p.bound = b;
    RegionGrower cpu(q, seed, p);
    ASSERT_EQ(cpu.setup().criterion, GrowCriterion::Core);
    const double e1 = 15, e2 = 40;
    Eigen::Vector3i lo, dims;
    boxAround(q, seed, cpu.setup(), e2, lo, dims);
    vk::GpuRegionGrower gpu(ctx, volume, sampler);
    gpu.begin(cpu.setup(), lo, dims);
    gpu.setBound(cpu.bound(e1));
    vk::GraphExecutor x(ctx, 1);
    int frames = 0;
    for (; frames < 2000 && gpu.growing(); ++frames) {
      if (frames == 2) gpu.setBound(cpu.bound(e2));  // the fingers spread while the front moves
      x.beginFrame();
      fg::FrameGraph g;
      const fg::ResourceHandle v = g.importImage("volume", volumeDesc(q), fg::Access::Sampled);
      gpu.addRounds(g, 1, false, v);
      g.compile();
      x.setGraph(&g);
      x.bindImage(v, volume);
      g.execute(x);
      x.setGraph(nullptr);
      x.submit();
      x.waitLastFrame();
      gpu.frameDone(g);
    }
    EXPECT_FALSE(gpu.growing()) << growBoundName(b) << ": the growth did not stop in " << frames << " frames";
    EXPECT_EQ(gpu.activeBricks(), 0u);
    EXPECT_GT(frames, 2) << growBoundName(b) << ": the extent was raised after the growth had stopped: not a mid-growth change";
    cpu.growTo(e2);
    const KeyComparison k = compareKeys(cpu, gpu, cpu.bound(e2), q.geometry.dims);
    EXPECT_EQ(k.onlyCpu, 0u) << growBoundName(b);
    EXPECT_EQ(k.onlyGpu, 0u) << growBoundName(b);
    EXPECT_EQ(k.keyDiffers, 0u) << growBoundName(b);
    EXPECT_EQ(k.both, cpu.count(e2)) << "the selection lies inside the box";
    EXPECT_GT(k.both, 500u);
  }
}
