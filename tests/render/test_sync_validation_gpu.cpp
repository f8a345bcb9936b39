// Synchronization validation's positive control: a frame graph whose barriers are dropped (a
// test-only hook of the executor) must be reported as a hazard, so a layer or setting that ignores
// synchronization fails the suite instead of passing it silently; the same graph with its barriers
// is clean.
#include <gtest/gtest.h>

#include <cstdlib>
#include <cstring>

#include "gpu_test_env.h"
#include "render/frame_graph.h"
#include "render/vk_graph_executor.h"
#include "render/vk_resources.h"

namespace handson {
namespace {

using test::gpuContext;

// Two transfer passes on one buffer: a fill writes it, a copy reads it into a host-visible one. The
// graph puts a TransferDst -> TransferSrc barrier between them; without it the copy's read races
// the fill's write (a read after write).
void fillThenCopy(bool dropBarriers) {
  auto& ctx = gpuContext();
  constexpr VkDeviceSize kSize = 4096;
  vk::Buffer a(ctx, kSize, VK_BUFFER_USAGE_TRANSFER_DST_BIT | VK_BUFFER_USAGE_TRANSFER_SRC_BIT, vk::Buffer::Memory::Device);
  vk::Buffer b(ctx, kSize, VK_BUFFER_USAGE_TRANSFER_DST_BIT, vk::Buffer::Memory::HostVisible);
  vk::GraphExecutor x(ctx, 1);
  x.dropBarriersForTest(dropBarriers);
  x.beginFrame();
  fg::FrameGraph g;
  const auto ha = g.importBuffer("a", {kSize}, fg::Access::None);
  const auto hb = g.importBuffer("b", {kSize}, fg::Access::None);
  g.addPass("fill", [&](fg::PassBuilder& p) { p.write(ha, fg::Access::TransferDst); },
            [&](fg::Executor&) { vkCmdFillBuffer(x.cmd(), a.handle(), 0, kSize, 0x5a5a5a5au); });
  g.addPass("copy", [&](fg::PassBuilder& p) { p.read(ha, fg::Access::TransferSrc); p.write(hb, fg::Access::TransferDst); },
            [&](fg::Executor&) {
              const VkBufferCopy region{0, 0, kSize};
              vkCmdCopyBuffer(x.cmd(), a.handle(), b.handle(), 1, &region);
            });
  g.exportResource(hb, fg::Access::HostRead);
  g.compile();
  x.setGraph(&g);
  x.bindBuffer(ha, a);
  x.bindBuffer(hb, b);
  g.execute(x);
  x.setGraph(nullptr);
  x.submit();
  x.waitLastFrame();
}

bool reportedHazard() {
  for (const auto& m : gpuContext().validationMessages())
    if (m.find("SYNC-HAZARD") != std::string::npos) return true;
  return false;
}

TEST(SyncValidation, AMissingBarrierIsReportedAsAHazard) {
  auto& ctx = gpuContext();
  if (const char* off = std::getenv("HANDSON_NO_SYNC_VALIDATION"); off && std::strcmp(off, "1") == 0)
    GTEST_SKIP() << "synchronization validation turned off by HANDSON_NO_SYNC_VALIDATION=1";
  ASSERT_TRUE(ctx.syncValidationEnabled()) << "the GPU tests run with synchronization validation";
  ctx.resetValidationMessages();
  fillThenCopy(true);
  EXPECT_TRUE(reportedHazard()) << "a copy reading what a fill wrote with no barrier between them was not reported: "
                                   "synchronization validation is not running";
  ctx.resetValidationMessages();  // the expected report must not fail the tests after this one
}

class SyncValidationClean : public test::GpuTest {};

TEST_F(SyncValidationClean, TheSameGraphWithItsBarriersIsClean) {
  fillThenCopy(false);
  EXPECT_FALSE(reportedHazard());
}

}  // namespace
}  // namespace handson
