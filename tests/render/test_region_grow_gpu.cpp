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

// Grows on CPU and GPU at several extents (growing and shrinking) and compares the selections
// over the box. Returns the largest selection's size.
std::size_t compareOn(const QuantizedVolume& q, const Eigen::Vector3i& seed, GrowCriterion c, const std::vector<double>& extents,
                      bool dense) {
  auto& ctx = test::gpuContext();
  const auto& d = q.geometry.dims;
  vk::Image volume(ctx, {std::uint32_t(d.x()), std::uint32_t(d.y()), std::uint32_t(d.z()), fg::Format::R16Unorm},
                   VK_IMAGE_USAGE_SAMPLED_BIT | VK_IMAGE_USAGE_TRANSFER_DST_BIT, true);
  vk::uploadToImage(ctx, volume, q.data.data(), q.data.size() * 2, VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL);
  vk::Sampler sampler(ctx, false);
  GrowParams p;
  p.criterion = c;
  RegionGrower cpu(q, seed, p);
  EXPECT_EQ(cpu.setup().criterion, c) << "the seed lies in a structure too thin for a core: pick another";
  vk::GpuRegionGrower gpu(ctx, volume, sampler);
  // Box: the ball of the largest extent (plus a voxel), clipped to the volume.
  double maxExtent = 0;
  for (double e : extents) maxExtent = std::max(maxExtent, e);
  const Eigen::Vector3i r = growReach(c, maxExtent, q.geometry.spacing) + Eigen::Vector3i::Ones();
  const Eigen::Vector3i lo = (seed - r).cwiseMax(Eigen::Vector3i::Zero());
  const Eigen::Vector3i hi = (seed + r).cwiseMin(d - Eigen::Vector3i::Ones());
  gpu.begin(cpu.setup(), lo, hi - lo + Eigen::Vector3i::Ones());
  std::size_t largest = 0;
  for (double e : extents) {
    cpu.growTo(e);
    const std::uint32_t bound = cpu.bound(e);
    gpu.growTo(bound, dense);
    const auto gk = gpu.readKeys();
    const auto& bd = gpu.boxDims();
    std::size_t both = 0, onlyCpu = 0, onlyGpu = 0;
    for (int k = 0; k < bd.z(); ++k)
      for (int j = 0; j < bd.y(); ++j)
        for (int i = 0; i < bd.x(); ++i) {
          const std::size_t v = std::size_t(lo.x() + i) + std::size_t(d.x()) * (std::size_t(lo.y() + j) + std::size_t(d.y()) * std::size_t(lo.z() + k));
          const bool a = cpu.keys()[v] <= bound;
          const bool b = gk[std::size_t(i) + std::size_t(bd.x()) * (std::size_t(j) + std::size_t(bd.y()) * std::size_t(k))] <= bound;
          both += a && b;
          onlyCpu += a && !b;
          onlyGpu += b && !a;
          if (a && b) {
            EXPECT_EQ(cpu.keys()[v], gk[std::size_t(i) + std::size_t(bd.x()) * (std::size_t(j) + std::size_t(bd.y()) * std::size_t(k))]);
          }
        }
    EXPECT_EQ(onlyCpu, 0u) << growCriterionName(c) << " extent " << e;
    EXPECT_EQ(onlyGpu, 0u) << growCriterionName(c) << " extent " << e;
    EXPECT_EQ(both, cpu.count(e)) << "the selection lies inside the box";
    largest = std::max(largest, both);
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
  const auto& d = q.geometry.dims;
  const fg::ImageDesc desc{std::uint32_t(d.x()), std::uint32_t(d.y()), std::uint32_t(d.z()), fg::Format::R16Unorm};
  vk::Image volume(ctx, desc, VK_IMAGE_USAGE_SAMPLED_BIT | VK_IMAGE_USAGE_TRANSFER_DST_BIT, true);
  vk::uploadToImage(ctx, volume, q.data.data(), q.data.size() * 2, VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL);
  vk::Sampler sampler(ctx, false);
  RegionGrower cpu(q, seed, GrowParams{});
  ASSERT_EQ(cpu.setup().criterion, GrowCriterion::Core);
  const double e1 = 15, e2 = 40;
  const Eigen::Vector3i r = growReach(GrowCriterion::Core, e2, q.geometry.spacing) + Eigen::Vector3i::Ones();
  const Eigen::Vector3i lo = (seed - r).cwiseMax(Eigen::Vector3i::Zero());
  const Eigen::Vector3i hi = (seed + r).cwiseMin(d - Eigen::Vector3i::Ones());
  vk::GpuRegionGrower gpu(ctx, volume, sampler);
  gpu.begin(cpu.setup(), lo, hi - lo + Eigen::Vector3i::Ones());
  gpu.setBound(cpu.bound(e1));
  vk::GraphExecutor x(ctx, 1);
  int frames = 0;
  for (; frames < 2000 && gpu.activeBricks() != 0; ++frames) {
    if (frames == 3) gpu.setBound(cpu.bound(e2));  // the fingers spread while the front moves
    x.beginFrame();
    fg::FrameGraph g;
    const fg::ResourceHandle v = g.importImage("volume", desc, fg::Access::Sampled);
    gpu.addRounds(g, 1, false, v);
    g.compile();
    x.setGraph(&g);
    x.bindImage(v, volume);
    gpu.bind(x);
    g.execute(x);
    x.setGraph(nullptr);
    x.submit();
    x.waitLastFrame();
    gpu.frameDone(g);
  }
  EXPECT_EQ(gpu.activeBricks(), 0u) << "the growth did not stop in " << frames << " frames";
  EXPECT_GT(frames, 3) << "the extent was raised after the growth had stopped: not a mid-growth change";
  cpu.growTo(e2);
  const std::uint32_t bound = cpu.bound(e2);
  const auto gk = gpu.readKeys();
  const Eigen::Vector3i bd = gpu.boxDims();
  std::size_t differ = 0, selected = 0;
  for (int k = 0; k < bd.z(); ++k)
    for (int j = 0; j < bd.y(); ++j)
      for (int i = 0; i < bd.x(); ++i) {
        const std::size_t v =
            std::size_t(lo.x() + i) + std::size_t(d.x()) * (std::size_t(lo.y() + j) + std::size_t(d.y()) * std::size_t(lo.z() + k));
        const std::uint32_t a = cpu.keys()[v] <= bound ? cpu.keys()[v] : handson::gpu::kGrowUnreached;
        const std::uint32_t gkv = gk[std::size_t(i) + std::size_t(bd.x()) * (std::size_t(j) + std::size_t(bd.y()) * std::size_t(k))];
        const std::uint32_t b = gkv <= bound ? gkv : handson::gpu::kGrowUnreached;
        differ += a != b;
        selected += b <= bound;
      }
  EXPECT_EQ(differ, 0u) << "voxels whose key up to the bound differs from the CPU reference's";
  EXPECT_EQ(selected, cpu.count(e2)) << "the selection lies inside the box";
  EXPECT_GT(selected, 500u);
}
