// Frame-graph logic without a GPU: a recording executor checks culling, ordering and barriers.
#include <gtest/gtest.h>

#include <set>
#include <string>
#include <vector>

#include "render/frame_graph.h"
#include "render/pass_resources.h"
#include "sim/base/error.h"

using namespace handson::fg;

namespace {

struct MockExecutor : Executor {
  std::vector<std::string> log;
  std::vector<std::vector<Barrier>> barrierCalls;
  std::vector<std::string> realized;
  const FrameGraph* graph = nullptr;
  void realizeTransient(ResourceHandle, const ResourceInfo& info) override { realized.push_back(info.name); }
  void beginPass(const PassInfo& p) override { log.push_back("begin " + p.name); }
  void barriers(const std::vector<Barrier>& list) override {
    log.push_back("barrier x" + std::to_string(list.size()));
    barrierCalls.push_back(list);
  }
  void endPass(const PassInfo& p) override { log.push_back("end " + p.name); }
  void finalBarriers(const std::vector<Barrier>& list) override {
    log.push_back("final x" + std::to_string(list.size()));
    barrierCalls.push_back(list);
  }
};

const ImageDesc kImg{64, 64, 1, Format::Rgba8Unorm};
const ImageDesc kVol{32, 32, 32, Format::R16Unorm};

}  // namespace

TEST(FrameGraph, CullsPassesWhoseOutputsNobodyUses) {
  FrameGraph g;
  auto vol = g.importImage("volume", kVol, Access::Sampled);
  auto a = g.createImage("a", kImg);
  auto b = g.createImage("b", kImg);
  auto c = g.createImage("c", kImg);
  std::vector<std::string> ran;
  g.addPass("make-a", [&](PassBuilder& p) { p.read(vol, Access::Sampled); p.write(a, Access::StorageWrite); }, [&](Executor&) { ran.push_back("make-a"); });
  g.addPass("make-b", [&](PassBuilder& p) { p.read(a, Access::StorageRead); p.write(b, Access::StorageWrite); }, [&](Executor&) { ran.push_back("make-b"); });
  g.addPass("unused", [&](PassBuilder& p) { p.read(a, Access::StorageRead); p.write(c, Access::StorageWrite); }, [&](Executor&) { ran.push_back("unused"); });
  g.exportResource(b, Access::TransferSrc);
  g.compile();
  EXPECT_FALSE(g.isCulled(0));
  EXPECT_FALSE(g.isCulled(1));
  EXPECT_TRUE(g.isCulled(2));
  MockExecutor ex;
  g.execute(ex);
  EXPECT_EQ(ran, (std::vector<std::string>{"make-a", "make-b"}));
  // The culled pass's transient output is never allocated.
  EXPECT_EQ(ex.realized, (std::vector<std::string>{"a", "b"}));
}

TEST(FrameGraph, APassAddedByIdIsNamedFromTheTableAndTheExecutorSeesItsId) {
  // Callers find a pass's time by its id (the frame budget reads the raymarch's): the executor
  // gets the id with the name, and a pass added by name alone is Unnamed.
  FrameGraph g;
  auto a = g.createImage("a", kImg);
  auto b = g.createImage("b", kImg);
  g.addPass(handson::PassId::Raymarch, [&](PassBuilder& p) { p.write(a, Access::StorageWrite); }, [](Executor&) {});
  g.addPass("copy", [&](PassBuilder& p) { p.read(a, Access::StorageRead); p.write(b, Access::StorageWrite); }, [](Executor&) {});
  g.exportResource(b, Access::TransferSrc);
  g.compile();
  struct Ids : MockExecutor {
    std::vector<PassInfo> seen;
    void beginPass(const PassInfo& p) override { seen.push_back(p); }
  } ex;
  g.execute(ex);
  ASSERT_EQ(ex.seen.size(), 2u);
  EXPECT_EQ(ex.seen[0].id, handson::PassId::Raymarch);
  EXPECT_EQ(ex.seen[0].name, "raymarch");
  EXPECT_EQ(ex.seen[1].id, handson::PassId::Unnamed);
  EXPECT_EQ(ex.seen[1].name, "copy");
}

TEST(FrameGraph, EveryPassIdHasItsOwnName) {
  // The timing log's columns and the benchmarks' figures are the names: one each, never shared.
  std::set<std::string> names;
  for (int i = 1; i < int(handson::PassId::Count); ++i) {
    const std::string n = handson::passName(handson::PassId(i));
    EXPECT_FALSE(n.empty()) << i;
    EXPECT_TRUE(names.insert(n).second) << n;
  }
  EXPECT_EQ(std::string(handson::passName(handson::PassId::Unnamed)), "");
}

TEST(FrameGraph, SideEffectAndImportedWritesKeepPassesAlive) {
  FrameGraph g;
  auto persistent = g.importBuffer("mask", {1024}, Access::None);
  auto t = g.createBuffer("scratch", {1024});
  g.addPass("write-imported", [&](PassBuilder& p) { p.write(persistent, Access::StorageWrite); }, nullptr);
  g.addPass("side-effect", [&](PassBuilder& p) { p.write(t, Access::StorageWrite); p.sideEffect(); }, nullptr);
  g.addPass("dead", [&](PassBuilder& p) { p.write(g.createBuffer("x", {4}), Access::StorageWrite); }, nullptr);
  g.compile();
  EXPECT_FALSE(g.isCulled(0));
  EXPECT_FALSE(g.isCulled(1));
  EXPECT_TRUE(g.isCulled(2));
}

TEST(FrameGraph, ReadAfterWriteGetsOneBarrierWithLayoutTransition) {
  FrameGraph g;
  auto img = g.createImage("color", kImg);
  auto host = g.importBuffer("readback", {64 * 64 * 4}, Access::None);
  g.addPass("raymarch", [&](PassBuilder& p) { p.write(img, Access::StorageWrite); }, nullptr);
  g.addPass("copy", [&](PassBuilder& p) { p.read(img, Access::TransferSrc); p.write(host, Access::TransferDst); p.sideEffect(); }, nullptr);
  g.exportResource(host, Access::HostRead);
  g.compile();
  const auto& cp = g.compiled();
  ASSERT_EQ(cp.size(), 2u);
  // First use of a transient: Undefined -> General, nothing to wait for.
  ASSERT_EQ(cp[0].barriers.size(), 1u);
  EXPECT_EQ(cp[0].barriers[0].src, 0u);
  EXPECT_EQ(cp[0].barriers[0].oldLayout, Layout::Undefined);
  EXPECT_EQ(cp[0].barriers[0].newLayout, Layout::General);
  // Copy: the image waits for the storage write and moves to TransferSrc; the imported buffer
  // (state None, layout-free) needs no barrier.
  ASSERT_EQ(cp[1].barriers.size(), 1u);
  const Barrier& b = cp[1].barriers[0];
  EXPECT_EQ(b.resource, img);
  EXPECT_EQ(b.src, accessBit(Access::StorageWrite));
  EXPECT_EQ(b.dst, Access::TransferSrc);
  EXPECT_EQ(b.oldLayout, Layout::General);
  EXPECT_EQ(b.newLayout, Layout::TransferSrc);
  // End of frame: the host read waits for the transfer write.
  ASSERT_EQ(g.finalBarriers().size(), 1u);
  EXPECT_EQ(g.finalBarriers()[0].resource, host);
  EXPECT_EQ(g.finalBarriers()[0].src, accessBit(Access::TransferDst));
  EXPECT_EQ(g.finalBarriers()[0].dst, Access::HostRead);
  MockExecutor ex;
  g.execute(ex);
  EXPECT_EQ(ex.log, (std::vector<std::string>{"begin raymarch", "barrier x1", "end raymarch", "begin copy", "barrier x1", "end copy", "final x1"}));
}

TEST(FrameGraph, RepeatedReadsOfTheSameKindNeedNoNewBarrier) {
  FrameGraph g;
  auto buf = g.createBuffer("positions", {4096});
  auto o1 = g.createBuffer("o1", {16});
  auto o2 = g.createBuffer("o2", {16});
  g.addPass("interpolate", [&](PassBuilder& p) { p.write(buf, Access::StorageWrite); }, nullptr);
  g.addPass("resample", [&](PassBuilder& p) { p.read(buf, Access::StorageRead); p.write(o1, Access::StorageWrite); }, nullptr);
  g.addPass("mask", [&](PassBuilder& p) { p.read(buf, Access::StorageRead); p.write(o2, Access::StorageWrite); }, nullptr);
  g.exportResource(o1, Access::StorageRead);
  g.exportResource(o2, Access::StorageRead);
  g.compile();
  const auto& cp = g.compiled();
  ASSERT_EQ(cp.size(), 3u);
  auto barriersOn = [&](std::size_t pass, ResourceHandle h) {
    int n = 0;
    for (const auto& b : cp[pass].barriers) n += b.resource == h;
    return n;
  };
  EXPECT_EQ(barriersOn(1, buf), 1);  // RAW
  EXPECT_EQ(barriersOn(2, buf), 0);  // already visible to storage reads
}

TEST(FrameGraph, WriteAfterReadWaitsForTheReads) {
  FrameGraph g;
  auto vol = g.importImage("deformed", kVol, Access::Sampled);
  auto out = g.createImage("color", kImg);
  g.addPass("raymarch", [&](PassBuilder& p) { p.read(vol, Access::Sampled); p.write(out, Access::StorageWrite); }, nullptr);
  g.addPass("resample", [&](PassBuilder& p) { p.write(vol, Access::StorageWrite); }, nullptr);
  g.exportResource(out, Access::TransferSrc);
  g.compile();
  const auto& cp = g.compiled();
  ASSERT_EQ(cp.size(), 2u);
  ASSERT_EQ(cp[0].barriers.size(), 1u);  // only the output's first-use transition
  EXPECT_EQ(cp[0].barriers[0].resource, out);
  ASSERT_EQ(cp[1].barriers.size(), 1u);
  const Barrier& b = cp[1].barriers[0];
  EXPECT_EQ(b.src, accessBit(Access::Sampled));
  EXPECT_EQ(b.oldLayout, Layout::ShaderReadOnly);
  EXPECT_EQ(b.newLayout, Layout::General);
  EXPECT_EQ(g.stateAfterFrame(vol), Access::StorageWrite);
}

TEST(FrameGraph, WriteAfterWriteAndReadWriteMerge) {
  FrameGraph g;
  auto mask = g.createImage("mask", kVol);
  g.addPass("clear", [&](PassBuilder& p) { p.write(mask, Access::TransferDst); }, nullptr);
  g.addPass("grow", [&](PassBuilder& p) { p.read(mask, Access::StorageRead); p.write(mask, Access::StorageReadWrite); }, nullptr);
  g.exportResource(mask, Access::Sampled);
  g.compile();
  const auto& cp = g.compiled();
  ASSERT_EQ(cp.size(), 2u);
  // One merged barrier on the mask in "grow": waits for the clear, ends in General for read-write.
  ASSERT_EQ(cp[1].barriers.size(), 1u);
  EXPECT_EQ(cp[1].barriers[0].src & accessBit(Access::TransferDst), accessBit(Access::TransferDst));
  EXPECT_EQ(cp[1].barriers[0].dst, Access::StorageReadWrite);
  EXPECT_EQ(cp[1].barriers[0].oldLayout, Layout::TransferDst);
  EXPECT_EQ(cp[1].barriers[0].newLayout, Layout::General);
  ASSERT_EQ(g.finalBarriers().size(), 1u);
  EXPECT_EQ(g.finalBarriers()[0].newLayout, Layout::ShaderReadOnly);
  EXPECT_EQ(g.finalBarriers()[0].src, accessBit(Access::StorageReadWrite));
}

TEST(FrameGraph, ImportedImageInRightLayoutNeedsNoBarrierForReads) {
  FrameGraph g;
  auto vol = g.importImage("volume", kVol, Access::Sampled);
  auto out = g.createImage("color", kImg);
  g.addPass("raymarch", [&](PassBuilder& p) { p.read(vol, Access::Sampled); p.write(out, Access::StorageWrite); }, nullptr);
  g.exportResource(out, Access::TransferSrc);
  g.compile();
  for (const auto& b : g.compiled()[0].barriers) EXPECT_NE(b.resource, vol);
}

TEST(FrameGraph, MisuseIsReported) {
  {
    FrameGraph g;
    auto t = g.createImage("never-written", kImg);
    auto o = g.createImage("o", kImg);
    g.addPass("reads-undefined", [&](PassBuilder& p) { p.read(t, Access::StorageRead); p.write(o, Access::StorageWrite); }, nullptr);
    g.exportResource(o, Access::TransferSrc);
    EXPECT_THROW(g.compile(), handson::Error);
  }
  {
    FrameGraph g;
    auto t = g.createImage("t", kImg);
    EXPECT_THROW(g.addPass("bad-write", [&](PassBuilder& p) { p.write(t, Access::Sampled); }, nullptr), handson::Error);
    EXPECT_THROW(g.addPass("bad-read", [&](PassBuilder& p) { p.read(t, Access::StorageWrite); }, nullptr), handson::Error);
    EXPECT_THROW(g.addPass("bad-handle", [&](PassBuilder& p) { p.read(ResourceHandle{99}, Access::StorageRead); }, nullptr), handson::Error);
    MockExecutor ex;
    EXPECT_THROW(g.execute(ex), handson::Error);  // not compiled
  }
}

// A pass that reads one buffer two ways (region growing's active list: indirect dispatch arguments
// and a storage buffer) gets one barrier that waits for the writer on behalf of both reads.
TEST(FrameGraph, ABufferReadTwoWaysInOnePassIsMadeVisibleToBoth) {
  FrameGraph g;
  auto list = g.createBuffer("active-list", {256});
  auto out = g.createBuffer("keys", {1024});
  g.addPass(
      "compact", [&](PassBuilder& p) { p.write(list, Access::StorageWrite); }, nullptr);
  g.addPass(
      "relax",
      [&](PassBuilder& p) {
        p.read(list, Access::IndirectRead);
        p.read(list, Access::StorageRead);
        p.write(out, Access::StorageWrite);
      },
      nullptr);
  g.exportResource(out, Access::TransferSrc);
  g.compile();
  const auto& cp = g.compiled();
  ASSERT_EQ(cp.size(), 2u);
  int onList = 0;
  for (const auto& b : cp[1].barriers) {
    if (!(b.resource == list)) continue;
    ++onList;
    EXPECT_EQ(b.src, accessBit(Access::StorageWrite));
    EXPECT_EQ((b.dstAlso | accessBit(b.dst)), accessBit(Access::IndirectRead) | accessBit(Access::StorageRead));
  }
  EXPECT_EQ(onList, 1);
}

TEST(FrameGraph, AnImportKeepsWhatItNamesForTheExecutor) {
  // vk::importImage / importBuffer pass the resource they bind; the graph keeps it, opaque.
  FrameGraph g;
  const int owner = 7;
  const ResourceHandle named = g.importBuffer("named", {4}, Access::StorageRead, &owner);
  const ResourceHandle plain = g.importBuffer("plain", {4}, Access::StorageRead);
  EXPECT_EQ(g.resource(named).external, &owner);
  EXPECT_EQ(g.resource(plain).external, nullptr);
}

TEST(PassResources, ThePassDeclaresEachResourceOnceWithTheAccessItIsBoundFor) {
  // A pass names each resource once (binding, handle, access); its declaration to the graph comes
  // from the same list, writes as writes, in the order named.
  FrameGraph g;
  const ResourceHandle args = g.importBuffer("args", {16}, Access::StorageWrite);
  const ResourceHandle in = g.importBuffer("in", {16}, Access::StorageRead);
  const ResourceHandle out = g.importImage("out", {4, 4, 1, Format::R32Sfloat}, Access::None);
  const handson::vk::PassResources r = handson::vk::PassResources()
                                           .buffer(0, in, Access::StorageRead)
                                           .use(args, Access::IndirectRead)
                                           .buffer(1, args, Access::StorageRead)
                                           .storageImage(2, out, Access::StorageWrite);
  g.addPass("pass", [&](PassBuilder& b) { r.declare(b); }, [](Executor&) {});
  const auto& uses = g.passUses(0);
  ASSERT_EQ(uses.size(), 4u);
  const std::vector<std::pair<std::uint32_t, Access>> want = {
      {in.id, Access::StorageRead}, {args.id, Access::IndirectRead}, {args.id, Access::StorageRead}, {out.id, Access::StorageWrite}};
  for (std::size_t i = 0; i < want.size(); ++i) {
    EXPECT_EQ(uses[i].resource.id, want[i].first) << i;
    EXPECT_EQ(uses[i].access, want[i].second) << i;
  }
  g.exportResource(out, Access::Sampled);
  EXPECT_NO_THROW(g.compile());
}
