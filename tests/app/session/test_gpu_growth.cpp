// The GPU growth engine of the app's pinches (app/session/gpu_growth.h) on whatever Vulkan device is
// present, validation on: the voxels it finishes with are the CPU reference's, and an engine that
// fails stops cleanly so that the pinch can go on with the CPU.
#include <gtest/gtest.h>

#include <algorithm>

#include "app/session/gpu_growth.h"
#include "interaction/region_grow.h"
#include "render/transfer_function.h"
#include "render/vk_context.h"
#include "sim/base/error.h"
#include "sim/phantom.h"

using namespace handson;

TEST(GpuGrowth, ItGrowsTheReferenceSelectionInBoxesThatFollowTheExtentAndStopsCleanlyWhenItFails) {
  vk::ContextOptions co;
  co.validation = true;
  co.requireValidation = true;
  vk::Context ctx(co);
  PhantomOptions po;
  po.spacingMm = 3.0;
  const Phantom ph = makePhantom(po);
  const QuantizedVolume q = quantizeVolume(ph.ct);
  VolumeRenderer renderer(ctx);
  renderer.setVolume(q);
  renderer.setTransferFunction(transferFunctionPreset("ct-abdomen").lookupTable(q));
  const std::vector<std::uint8_t> mask(q.data.size(), 0);
  const Eigen::Vector3i seed = ph.ct.geometry().toIndex(ph.geometry.liverCenter).array().round().cast<int>();
  RegionGrower reference(q, seed, GrowParams{});

  GpuGrowthEngine engine(renderer, q, mask);
  engine.start(reference);
  EXPECT_TRUE(engine.growing());
  EXPECT_EQ(renderer.liveSelection(), nullptr) << "the box waits for the first extent";
  engine.show(reference.bound(12.0), 12.0);  // a box for 24 mm
  ASSERT_NE(renderer.liveSelection(), nullptr);
  const Eigen::Vector3i firstBox = renderer.liveSelection()->boxDims();
  engine.show(reference.bound(8.0), 8.0);
  EXPECT_EQ(renderer.liveSelection()->boxDims(), firstBox) << "closing the fingers keeps the box";
  engine.show(reference.bound(35.0), 35.0);  // past the box: a box for 70 mm
  EXPECT_GT(renderer.liveSelection()->boxDims().prod(), firstBox.prod());
  const Eigen::Vector3i lastMin = renderer.liveSelection()->boxMin(), lastDims = renderer.liveSelection()->boxDims();
  reference.growTo(35.0);
  std::vector<std::uint32_t> expected;
  for (std::size_t v = 0; v < q.data.size(); ++v)
    if (reference.keys()[v] <= reference.bound(35.0)) expected.push_back(std::uint32_t(v));
  EXPECT_EQ(engine.finish(), expected);
  EXPECT_FALSE(engine.growing());
  const auto painted = engine.takePaintedBox();
  ASSERT_TRUE(painted.has_value()) << "the box the live selection painted, for the controller to repaint";
  EXPECT_EQ(painted->first, lastMin);
  EXPECT_EQ(painted->second, lastDims);
  EXPECT_FALSE(engine.takePaintedBox().has_value()) << "taken once";

  // A failure under the engine (here its live selection ended from outside): the engine stops,
  // ends what is left on the GPU and passes the error on (the pinch then grows on the CPU).
  engine.start(reference);
  engine.show(reference.bound(10.0), 10.0);
  renderer.endLiveSelection();
  std::string why;
  try {
    engine.show(reference.bound(11.0), 11.0);
  } catch (const Error& e) {
    why = e.what();
  }
  EXPECT_NE(why.find("no live selection"), std::string::npos) << why;
  EXPECT_FALSE(engine.growing());
  EXPECT_EQ(renderer.liveSelection(), nullptr);
  try {
    engine.finish();
    ADD_FAILURE() << "a stopped engine finished";
  } catch (const Error& e) {
    EXPECT_EQ(std::string(e.what()), why) << "later calls of the pinch say why it stopped";
  }
  engine.rebase();  // nothing growing: nothing to do
  EXPECT_EQ(ctx.validationMessageCount(), 0u);
}
