// The frame graph's barrier check (render/graph_check.h) without a GPU: a recording executor
// captures what the graph hands a backend, and the check must pass the graph's own barriers and
// report each kind of mistake put into them by hand.
#include <gtest/gtest.h>

#include <algorithm>
#include <string>
#include <vector>

#include "render/frame_graph.h"
#include "render/graph_check.h"

using namespace handson::fg;

namespace {

// Records the barriers the graph hands the backend before each pass and at the end of the frame.
struct RecordingExecutor : Executor {
  const FrameGraph& graph;
  GraphTrace trace;
  explicit RecordingExecutor(const FrameGraph& g) : graph(g) {
    for (std::uint32_t i = 0; i < g.resourceCount(); ++i) trace.resources.push_back(g.resource(ResourceHandle{i}));
  }
  void realizeTransient(ResourceHandle, const ResourceInfo&) override {}
  void beginPass(const PassInfo& p) override { trace.steps.push_back({p.name, {}, graph.passUses(p.index)}); }
  void barriers(const std::vector<Barrier>& list) override { trace.steps.back().barriers = list; }
  void endPass(const PassInfo&) override {}
  void finalBarriers(const std::vector<Barrier>& list) override { trace.finalBarriers = list; }
};

const ImageDesc kImg{64, 64, 1, Format::Rgba8Unorm};

// A raymarch writes an image, a second pass samples it and writes a buffer, a copy reads the image
// into a host buffer; the image ends as a transfer source, the host buffer readable by the host.
struct ThreePasses {
  FrameGraph g;
  ResourceHandle color, stats, host;
  ThreePasses() {
    color = g.createImage("color", kImg);
    stats = g.importBuffer("stats", {256}, Access::StorageRead);
    host = g.importBuffer("host", {64 * 64 * 4}, Access::None);
    g.addPass("raymarch", [&](PassBuilder& p) { p.write(color, Access::StorageWrite); }, nullptr);
    g.addPass("reduce", [&](PassBuilder& p) { p.read(color, Access::Sampled); p.write(stats, Access::StorageWrite); }, nullptr);
    g.addPass("copy", [&](PassBuilder& p) { p.read(color, Access::TransferSrc); p.write(host, Access::TransferDst); p.sideEffect(); }, nullptr);
    g.exportResource(host, Access::HostRead);
    g.compile();
  }
  GraphTrace recorded() {
    RecordingExecutor ex(g);
    g.execute(ex);
    return ex.trace;
  }
};

bool mentions(const std::vector<std::string>& problems, const std::string& text) {
  for (const auto& p : problems)
    if (p.find(text) != std::string::npos) return true;
  return false;
}

std::string joined(const std::vector<std::string>& problems) {
  std::string all;
  for (const auto& p : problems) all += p + "\n";
  return all;
}

Barrier* barrierOn(GraphTrace& t, const std::string& pass, ResourceHandle r) {
  for (auto& s : t.steps)
    if (s.pass == pass)
      for (auto& b : s.barriers)
        if (b.resource == r) return &b;
  return nullptr;
}

}  // namespace

TEST(GraphCheck, TheGraphsOwnBarriersCoverEveryUse) {
  ThreePasses f;
  const GraphTrace t = f.recorded();
  EXPECT_EQ(t.steps.size(), 3u);
  EXPECT_TRUE(barrierProblems(t).empty()) << joined(barrierProblems(t));
  EXPECT_TRUE(barrierProblems(traceOf(f.g)).empty()) << "the compiled graph's trace, as compile() checks it";
}

TEST(GraphCheck, AReadWithNoBarrierAfterTheWriteIsReported) {
  ThreePasses f;
  GraphTrace t = f.recorded();
  // The reduce pass's barrier on the image (raymarch's write made visible, general -> read-only) dropped.
  auto& barriers = t.steps[1].barriers;
  barriers.erase(std::remove_if(barriers.begin(), barriers.end(), [&](const Barrier& b) { return b.resource == f.color; }), barriers.end());
  const auto p = barrierProblems(t);
  EXPECT_TRUE(mentions(p, "pass 'reduce', 'color': sampled needs layout shader-read-only")) << joined(p);
  EXPECT_TRUE(mentions(p, "pass 'reduce', 'color': sampled does not see storage-write")) << joined(p);
}

TEST(GraphCheck, AWriteNotOrderedAfterAnEarlierReadIsReported) {
  ThreePasses f;
  GraphTrace t = f.recorded();
  // stats was read by the previous frame (imported as storage-read): the reduce pass's write must wait for it.
  Barrier* b = barrierOn(t, "reduce", f.stats);
  ASSERT_NE(b, nullptr) << "the graph orders the write after the earlier read";
  b->src = 0;
  const auto p = barrierProblems(t);
  EXPECT_TRUE(mentions(p, "pass 'reduce', 'stats': storage-write is not ordered after storage-read")) << joined(p);
}

TEST(GraphCheck, ATransitionThatDiscardsWrittenContentsOrMissesAnAccessIsReported) {
  {
    ThreePasses f;
    GraphTrace t = f.recorded();
    Barrier* b = barrierOn(t, "copy", f.color);
    ASSERT_NE(b, nullptr);
    b->oldLayout = Layout::Undefined;  // the raymarch's picture thrown away by the transition
    EXPECT_TRUE(mentions(barrierProblems(t), "a transition from undefined discards what was written")) << joined(barrierProblems(t));
  }
  {
    ThreePasses f;
    GraphTrace t = f.recorded();
    Barrier* b = barrierOn(t, "copy", f.color);
    ASSERT_NE(b, nullptr);
    b->src = 0;  // the transition to transfer-src does not wait for the reduce pass's sampling
    EXPECT_TRUE(mentions(barrierProblems(t), "the layout transition does not wait for")) << joined(barrierProblems(t));
  }
  {
    ThreePasses f;
    GraphTrace t = f.recorded();
    Barrier* b = barrierOn(t, "copy", f.color);
    ASSERT_NE(b, nullptr);
    b->oldLayout = Layout::General;  // the image is shader-read-only after the reduce pass
    EXPECT_TRUE(mentions(barrierProblems(t), "a transition from general but the image is shader-read-only")) << joined(barrierProblems(t));
  }
}

TEST(GraphCheck, AFinalBarrierMissingLeavesTheHostReadUncovered) {
  ThreePasses f;
  GraphTrace t = f.recorded();
  ASSERT_FALSE(t.finalBarriers.empty());
  t.finalBarriers.clear();
  EXPECT_TRUE(mentions(barrierProblems(t), "pass '(end of frame)', 'host': host-read does not see transfer-dst")) << joined(barrierProblems(t));
}
