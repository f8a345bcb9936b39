#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <chrono>
#include <cstdlib>
#include <thread>

#include "interaction/handles.h"
#include "interaction/selection.h"
#include "sim/base/error.h"
#include "sim/phantom.h"
#include "sim/quantized_volume.h"

using namespace handson;

TEST(HandleSet, LastClaimerWinsAndEditsUndo) {
  HandleSet h;
  const int a = h.add({5, 1, 3, 3, 7});
  ASSERT_EQ(a, 1);
  EXPECT_EQ(h.find(a)->voxels, (std::vector<std::uint32_t>{1, 3, 5, 7}));
  const int b = h.add({7, 9});
  EXPECT_EQ(h.find(a)->voxels, (std::vector<std::uint32_t>{1, 3, 5}));  // 7 now belongs to b
  EXPECT_EQ(h.find(b)->voxels, (std::vector<std::uint32_t>{7, 9}));
  EXPECT_TRUE(h.setStatus(b, HandleStatus::Fixed));
  EXPECT_FALSE(h.setStatus(b, HandleStatus::Fixed));  // no change, no undo step
  EXPECT_TRUE(h.subtract(a, b));  // disjoint: a keeps all its voxels (a valid, if idle, edit)
  EXPECT_EQ(h.find(a)->voxels, (std::vector<std::uint32_t>{1, 3, 5}));
  EXPECT_TRUE(h.undo());
  EXPECT_TRUE(h.unite(a, b));
  EXPECT_EQ(h.find(a)->voxels, (std::vector<std::uint32_t>{1, 3, 5, 7, 9}));
  EXPECT_EQ(h.find(b), nullptr);
  EXPECT_TRUE(h.undo());  // the union
  ASSERT_NE(h.find(b), nullptr);
  EXPECT_EQ(h.find(b)->status, HandleStatus::Fixed);
  EXPECT_TRUE(h.undo());  // the status
  EXPECT_EQ(h.find(b)->status, HandleStatus::Active);
  EXPECT_TRUE(h.redo());
  EXPECT_EQ(h.find(b)->status, HandleStatus::Fixed);
  EXPECT_TRUE(h.remove(b));
  EXPECT_FALSE(h.remove(b));
  EXPECT_EQ(h.handles().size(), 1u);
  // A handle whose voxels are all claimed by a new one disappears.
  h.add({1, 3, 5});
  EXPECT_EQ(h.find(a), nullptr);
  EXPECT_FALSE(h.unite(a, a));
  EXPECT_EQ(h.add({}), 0);
  const auto t = h.tints();
  EXPECT_EQ(t.size(), 256u);
  EXPECT_GT(t[HandleSet::kLiveSelectionId].a, 0.0f);
}

TEST(HandleSet, DifferenceRemovesTheOtherHandlesVoxelsAndKeepsIt) {
  HandleSet h;
  const int a = h.add({1, 2, 3, 4});
  const int b = h.add({10, 11});
  ASSERT_TRUE(h.unite(a, b));  // a = {1,2,3,4,10,11}
  const int c = h.add({20});
  EXPECT_TRUE(h.subtract(a, c));
  EXPECT_EQ(h.find(a)->voxels.size(), 6u);
  ASSERT_TRUE(h.undo());  // back to before the subtraction
  ASSERT_TRUE(h.undo());  // before c
  ASSERT_TRUE(h.undo());  // before the union
  ASSERT_NE(h.find(b), nullptr);
  // a \ b where b overlaps a: claim {3, 4} for a new handle d, unite it back into... use a fresh set.
  HandleSet g;
  const int x = g.add({1, 2, 3});
  const int y = g.add({5});
  ASSERT_TRUE(g.unite(x, y));  // x = {1,2,3,5}
  const int z = g.add({7});
  EXPECT_TRUE(g.subtract(x, z));            // nothing shared: x unchanged
  EXPECT_EQ(g.find(x)->voxels.size(), 4u);
  EXPECT_NE(g.find(z), nullptr);             // the subtrahend stays
  HandleSet only;
  const int p = only.add({1});
  const int r = only.add({2});
  ASSERT_TRUE(only.unite(p, r));
  EXPECT_FALSE(only.subtract(p, p));
}

namespace {

// The default phantom (2 mm voxels, CT-like noise: the 7 mm cortex spans a few voxels) seen from
// the patient's right (+x) on a 512 px viewport, and a pinch's touches fed to a selection.
struct PinchRig {
  Phantom ph = makePhantom();
  QuantizedVolume q = quantizeVolume(ph.ct);
  OrbitCamera cam = OrbitCamera::framing(ph.ct.geometry(), glm::radians(90.0), 0.0);
  Viewport vp{512, 512};
  TouchInput in;
  PinchRig() { in.setViewport(vp); }
  void feed(PinchSelection& sel, TouchPhase p, int id, double x, double y) {
    TouchEvent e{p, id, {x, y}, 1.0, 0.0};
    ASSERT_TRUE(in.apply(e));
    sel.onTouch(e, in, cam, vp);
  }
  /// Two fingers down 20 px apart, both picks answered on the right kidney's surface.
  void pinchKidney(PinchSelection& sel) {
    feed(sel, TouchPhase::Down, 1, 200, 270);
    feed(sel, TouchPhase::Down, 2, 220, 270);
    ASSERT_EQ(sel.takePickRequest().size(), 2u);
    const Eigen::Vector3d k = ph.geometry.kidneyRightCenter;
    sel.onPicks({glm::dvec3(k.x() + 20, k.y() - 3, k.z()), glm::dvec3(k.x() + 20, k.y() + 3, k.z())}, cam, vp);
  }
};

}  // namespace

TEST(HandleSet, TheMaskChangeTakesAMaskOfTheHandlesBeforeToTheOneAfterAsBruteForceFindsIt) {
  // Random adds, unions, differences, removals and undos on a 1,000-voxel grid: the mask of ids
  // painted from the handles before, with the change applied (cleared, then joined), must be the
  // mask painted from the handles after; and the change names only voxels whose id changed.
  std::srand(7);
  auto paint = [](const std::vector<Handle>& hs) {
    std::vector<std::uint8_t> m(1000, 0);
    for (const Handle& h : hs)
      for (std::uint32_t v : h.voxels) m[v] = std::uint8_t(h.id);
    return m;
  };
  HandleSet h;
  for (int step = 0; step < 300; ++step) {
    const std::vector<Handle> before = h.handles();
    const int op = std::rand() % 5, a = 1 + std::rand() % 6, b = 1 + std::rand() % 6;
    if (op == 0) {
      std::vector<std::uint32_t> v;
      const std::uint32_t start = std::uint32_t(std::rand() % 900);
      for (std::uint32_t i = 0; i < 100; ++i) v.push_back(start + i * std::uint32_t(1 + std::rand() % 2) % 100);
      h.add(v);
    } else if (op == 1) {
      h.unite(a, b);
    } else if (op == 2) {
      h.subtract(a, b);
    } else if (op == 3) {
      h.remove(a);
    } else {
      h.undo();
    }
    const HandleSet::MaskChange c = HandleSet::maskChange(before, h.handles());
    std::vector<std::uint8_t> m = paint(before);
    const std::vector<std::uint8_t> was = m;
    for (std::uint32_t v : c.cleared) m[v] = 0;
    for (const auto& [v, id] : c.joined) m[v] = id;
    ASSERT_EQ(m, paint(h.handles())) << "step " << step;
    for (std::uint32_t v : c.cleared) EXPECT_NE(was[v], m[v]);  // left a handle: none now, or another's
    for (const auto& [v, id] : c.joined) EXPECT_NE(was[v], id);
  }
}

TEST(HandleSet, ReplacingEveryHandleIsOneUndoStep) {
  HandleSet h;
  const int a = h.add({1, 2, 3});
  HandleSet copy(h.handles());  // no history
  EXPECT_FALSE(copy.canUndo());
  copy.add({3, 4});
  h.replace(copy.handles());
  EXPECT_EQ(h.handles().size(), 2u);
  EXPECT_EQ(h.find(a)->voxels, (std::vector<std::uint32_t>{1, 2}));
  EXPECT_TRUE(h.undo());
  ASSERT_EQ(h.handles().size(), 1u);
  EXPECT_EQ(h.find(a)->voxels, (std::vector<std::uint32_t>{1, 2, 3}));
  EXPECT_TRUE(h.redo());
  EXPECT_EQ(h.handles().size(), 2u);
}

TEST(PinchSelection, GrowsFromTheMidpointAndEndsWhenAFingerLifts) {
  PinchRig rig;
  const Phantom& ph = rig.ph;
  const OrbitCamera& cam = rig.cam;
  const Viewport& vp = rig.vp;
  PinchSelection sel(rig.q, GrowParams{});
  auto feed = [&](TouchPhase p, int id, double x, double y) { rig.feed(sel, p, id, x, y); };
  feed(TouchPhase::Down, 1, 200, 270);
  EXPECT_TRUE(sel.takePickRequest().empty());  // one finger: nothing yet
  feed(TouchPhase::Down, 2, 220, 270);
  const auto req = sel.takePickRequest();
  ASSERT_EQ(req.size(), 2u);
  EXPECT_TRUE(sel.takePickRequest().empty());  // sent once
  // Both picks on the right kidney's surface (from the right, +x): seed at the kidney.
  const Eigen::Vector3d k = ph.geometry.kidneyRightCenter;
  sel.onPicks({glm::dvec3(k.x() + 20, k.y() - 3, k.z()), glm::dvec3(k.x() + 20, k.y() + 3, k.z())}, cam, vp);
  ASSERT_EQ(sel.state(), PinchSelection::State::Growing);
  const double e0 = sel.extentMm();
  EXPECT_NEAR(e0, 20 * cam.pixelSizeAt(cam.distance - k.x() - 20, 512), 0.05);
  const std::size_t n0 = sel.liveVoxels().size();
  feed(TouchPhase::Move, 2, 240, 270);  // spread: grows
  EXPECT_GT(sel.extentMm(), e0);
  EXPECT_GT(sel.liveVoxels().size(), n0);
  feed(TouchPhase::Move, 2, 225, 270);  // close: shrinks (a threshold)
  EXPECT_LT(sel.liveVoxels().size(), sel.grower()->count(sel.grower()->grownExtent()) + 1);
  std::size_t inKidney = 0;
  for (std::uint32_t v : sel.liveVoxels()) inKidney += ph.labels.value(v) == float(label::kKidneyRight);
  EXPECT_GE(double(inKidney) / double(sel.liveVoxels().size()), 0.9);  // precision, as for region growing
  feed(TouchPhase::Up, 1, 200, 270);
  EXPECT_EQ(sel.state(), PinchSelection::State::Idle);
  const auto done = sel.takeFinished();
  ASSERT_TRUE(done.has_value());
  EXPECT_GT(done->size(), 10u);
  EXPECT_FALSE(sel.takeFinished().has_value());
}

TEST(PinchSelection, TheLiftLeavesItsVoxelsInTheGrowerForWhoeverCompletesThePinch) {
  // The lift hands the grower on (no gathering, no clearing of its arrays on the frame's thread):
  // the voxels are the ones shown live, gathered where the pinch is completed. Completed on another
  // thread while the next pinch starts here, that pinch's grower waits for the workspace's arrays
  // and grows what a pinch on a fresh selection grows (the arrays came back cleared). A finished
  // pinch nobody took is gathered when the next one starts (it would otherwise wait for itself).
  PinchRig rig, refRig;
  PinchSelection sel(rig.q, GrowParams{}), ref(refRig.q, GrowParams{});
  rig.pinchKidney(sel);
  rig.feed(sel, TouchPhase::Move, 2, 240, 270);
  std::vector<std::uint32_t> shown = sel.liveVoxels();
  rig.feed(sel, TouchPhase::Up, 1, 200, 270);
  rig.feed(sel, TouchPhase::Up, 2, 240, 270);
  std::optional<FinishedPinch> first = sel.takeFinishedPinch();
  ASSERT_TRUE(first.has_value());
  ASSERT_TRUE(first->grower != nullptr) << "the voxels stay in the grower until completed";
  EXPECT_TRUE(first->voxels.empty());
  refRig.pinchKidney(ref);
  refRig.feed(ref, TouchPhase::Move, 2, 240, 270);
  refRig.feed(ref, TouchPhase::Up, 1, 200, 270);
  refRig.feed(ref, TouchPhase::Up, 2, 240, 270);
  const std::vector<std::uint32_t> expected = *ref.takeFinished();
  std::vector<std::uint32_t> completed;
  std::atomic<std::int64_t> workerStarts{0};
  const auto since = [t0 = std::chrono::steady_clock::now()] {
    return std::int64_t(std::chrono::duration_cast<std::chrono::microseconds>(std::chrono::steady_clock::now() - t0).count());
  };
  std::thread worker([&] {
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
    workerStarts = since();
    completed = std::move(*first).complete();
  });
  rig.pinchKidney(sel);  // waits for the worker's grower to give the arrays back
  const std::int64_t pinchStarted = since();
  worker.join();
  EXPECT_GE(pinchStarted, workerStarts.load()) << "the next pinch's grower waited for the arrays";
  EXPECT_EQ(completed, expected);
  std::vector<std::uint32_t> shownSorted = shown;
  std::sort(shownSorted.begin(), shownSorted.end());
  EXPECT_TRUE(std::includes(completed.begin(), completed.end(), shownSorted.begin(), shownSorted.end())) << "what was shown, and its rim";
  refRig.pinchKidney(ref);
  EXPECT_EQ(sel.liveVoxels(), ref.liveVoxels());
  // Finished and not taken: the next pinch gathers it here.
  for (auto [r, s] : {std::pair{&rig, &sel}, std::pair{&refRig, &ref}}) {
    r->feed(*s, TouchPhase::Up, 1, 200, 270);
    r->feed(*s, TouchPhase::Up, 2, 220, 270);
  }
  rig.pinchKidney(sel);
  EXPECT_EQ(sel.state(), PinchSelection::State::Growing);
  EXPECT_EQ(*sel.takeFinished(), *ref.takeFinished());
}

TEST(PinchSelection, AFingerLiftedBeforeThePicksReturnEndsTheSelectionWhenTheyDo) {
  // A quick pinch on slow frames: down, spread, up, and only then the depth-picks. The selection
  // grows at the fingers' last spread and ends at once, as if the picks had come first.
  PinchRig quickRig, slowRig, cancelRig;  // each its own touch input
  const Eigen::Vector3d k = quickRig.ph.geometry.kidneyRightCenter;
  const std::vector<std::optional<glm::dvec3>> picks{glm::dvec3(k.x() + 20, k.y() - 3, k.z()), glm::dvec3(k.x() + 20, k.y() + 3, k.z())};
  PinchSelection quick(quickRig.q, GrowParams{}), slow(slowRig.q, GrowParams{}), cancelled(cancelRig.q, GrowParams{});
  for (auto [rig, s] : {std::pair{&quickRig, &quick}, std::pair{&slowRig, &slow}, std::pair{&cancelRig, &cancelled}}) {
    rig->feed(*s, TouchPhase::Down, 1, 200, 270);
    rig->feed(*s, TouchPhase::Down, 2, 220, 270);
    ASSERT_EQ(s->takePickRequest().size(), 2u);
  }
  // The reference: picks first, then the spread and the lift.
  slow.onPicks(picks, slowRig.cam, slowRig.vp);
  slowRig.feed(slow, TouchPhase::Move, 2, 240, 270);
  slowRig.feed(slow, TouchPhase::Up, 1, 200, 270);
  // The quick pinch: the spread and the lift first.
  quickRig.feed(quick, TouchPhase::Move, 2, 240, 270);
  quickRig.feed(quick, TouchPhase::Up, 1, 200, 270);
  quickRig.feed(quick, TouchPhase::Move, 2, 260, 270);  // the other finger drifts on: it ended at the lift
  EXPECT_EQ(quick.state(), PinchSelection::State::WaitingForPicks);
  EXPECT_FALSE(quick.takeFinished().has_value());
  quick.onPicks(picks, quickRig.cam, quickRig.vp);
  EXPECT_EQ(quick.state(), PinchSelection::State::Idle);
  const auto a = quick.takeFinished(), b = slow.takeFinished();
  ASSERT_TRUE(a.has_value());
  ASSERT_TRUE(b.has_value());
  EXPECT_EQ(*a, *b);
  EXPECT_EQ(quick.finishedSeed(), slow.finishedSeed());
  // A cancel while the picks are on their way ends the pinch with nothing.
  cancelRig.feed(cancelled, TouchPhase::Cancel, 1, 200, 270);
  EXPECT_EQ(cancelled.state(), PinchSelection::State::Idle);
  cancelled.onPicks(picks, cancelRig.cam, cancelRig.vp);
  EXPECT_FALSE(cancelled.takeFinished().has_value());
}

// A growth engine that records what the pinch asks of it and answers with the reference's voxels
// in reverse order (the pinch hands them on sorted).
class RecordingEngine : public GrowthEngine {
 public:
  void start(const RegionGrower& reference) override {
    ref = &reference;
    ++starts;
  }
  void show(std::uint32_t bound, double extentMm) override { shown.push_back({bound, extentMm}); }
  std::vector<std::uint32_t> finish() override {
    ++finishes;
    RegionGrower own(*volume, ref->setup().seed, GrowParams{});  // the same seed and statistics
    own.growTo(shown.back().second);
    std::vector<std::uint32_t> out;
    for (std::size_t v = 0; v < own.keys().size(); ++v)
      if (own.keys()[v] <= shown.back().first) out.push_back(std::uint32_t(v));
    std::reverse(out.begin(), out.end());
    return out;
  }
  const QuantizedVolume* volume = nullptr;
  const RegionGrower* ref = nullptr;
  int starts = 0, finishes = 0;
  std::vector<std::pair<std::uint32_t, double>> shown;
};

TEST(PinchSelection, WithAGrowthEngineThePinchHandsItTheSeedAndEveryExtentAndTakesItsVoxels) {
  PinchRig rig;
  const QuantizedVolume& q = rig.q;
  GrowParams withRim;
  withRim.boundaryRim = true;  // what the pinch adds to the engine's voxels
  PinchSelection sel(q, withRim);
  RecordingEngine engine;
  engine.volume = &q;
  sel.setEngine(&engine);
  auto feed = [&](TouchPhase p, int id, double x, double y) { rig.feed(sel, p, id, x, y); };
  rig.pinchKidney(sel);
  ASSERT_EQ(sel.state(), PinchSelection::State::Growing);
  ASSERT_EQ(engine.starts, 1);
  ASSERT_EQ(engine.shown.size(), 1u);
  EXPECT_EQ(engine.shown[0].first, sel.grower()->bound(sel.extentMm()));
  EXPECT_DOUBLE_EQ(engine.shown[0].second, sel.extentMm());
  EXPECT_TRUE(sel.liveVoxels().empty()) << "the engine shows the live selection, not the CPU";
  EXPECT_EQ(sel.grower()->grownExtent(), -1.0) << "nothing grown on the CPU beyond the seed statistics";
  feed(TouchPhase::Move, 2, 240, 270);
  feed(TouchPhase::Move, 2, 230, 270);
  ASSERT_EQ(engine.shown.size(), 3u);
  EXPECT_GT(engine.shown[1].second, engine.shown[0].second);
  EXPECT_LT(engine.shown[2].second, engine.shown[1].second);
  EXPECT_EQ(engine.shown[2].first, sel.grower()->bound(sel.extentMm()));
  // The reference grown to the last extent: the engine's answer must be its selection.
  RegionGrower check(q, sel.grower()->setup().seed, GrowParams{});
  check.growTo(sel.extentMm());
  feed(TouchPhase::Up, 1, 200, 270);
  EXPECT_EQ(engine.finishes, 1);
  const auto done = sel.takeFinished();
  ASSERT_TRUE(done.has_value());
  EXPECT_TRUE(std::is_sorted(done->begin(), done->end()));
  // The reference's voxels, ending with their boundary rim (GrowParams::boundaryRim).
  std::vector<std::uint32_t> grown;
  for (std::size_t v = 0; v < check.keys().size(); ++v)
    if (check.keys()[v] <= check.bound(sel.extentMm())) grown.push_back(std::uint32_t(v));
  EXPECT_EQ(*done, withBoundaryRim(check, grown));
  EXPECT_GT(done->size(), grown.size()) << "the kidney's partial-volume rim";
  EXPECT_GT(grown.size(), 10u);
}

// An engine that fails on its second extent (a box too large for the device, say).
class FailingEngine : public GrowthEngine {
 public:
  void start(const RegionGrower&) override {}
  void show(std::uint32_t, double) override {
    if (++shows == 2) throw Error("the selection's box is larger than this device's storage buffers allow");
  }
  std::vector<std::uint32_t> finish() override { throw Error("not reached"); }
  int shows = 0;
};

TEST(PinchSelection, WhenTheGrowthEngineFailsThePinchGoesOnWithTheCpuReferenceAndSaysSo) {
  PinchRig rig;
  PinchSelection sel(rig.q, GrowParams{});
  FailingEngine engine;
  sel.setEngine(&engine);
  auto feed = [&](TouchPhase p, int id, double x, double y) { rig.feed(sel, p, id, x, y); };
  rig.pinchKidney(sel);
  EXPECT_TRUE(sel.liveVoxels().empty());
  EXPECT_TRUE(sel.feedback().empty());
  feed(TouchPhase::Move, 2, 240, 270);  // the engine fails here
  EXPECT_EQ(engine.shows, 2);
  EXPECT_NE(sel.feedback().find("grows on the CPU: the selection's box is larger"), std::string::npos) << sel.feedback();
  ASSERT_EQ(sel.state(), PinchSelection::State::Growing);
  const std::size_t n = sel.liveVoxels().size();
  EXPECT_EQ(n, sel.grower()->count(sel.extentMm())) << "the CPU grew to the fingers' extent at once";
  EXPECT_GT(n, 10u);
  feed(TouchPhase::Move, 2, 250, 270);
  EXPECT_EQ(engine.shows, 2) << "the failed engine is not asked again in this pinch";
  feed(TouchPhase::Up, 1, 200, 270);
  const auto done = sel.takeFinished();
  ASSERT_TRUE(done.has_value());
  EXPECT_GT(done->size(), n);
  EXPECT_TRUE(std::is_sorted(done->begin(), done->end()));
}

TEST(PinchSelection, APinchWhoseSpreadGivesNoExtentIsRefusedWithFeedback) {
  PinchRig rig;
  rig.cam.distance = std::nan("");  // a broken camera: no pixel size at the seed's depth
  PinchSelection sel(rig.q, GrowParams{});
  rig.pinchKidney(sel);
  EXPECT_EQ(sel.state(), PinchSelection::State::Idle);
  EXPECT_NE(sel.feedback().find("gives no extent"), std::string::npos) << sel.feedback();
  EXPECT_FALSE(sel.takeFinished().has_value());
}

TEST(PinchSelection, APinchInEmptySpaceIsRefusedWithFeedback) {
  PhantomOptions o;
  o.spacingMm = 8.0;
  const Phantom ph = makePhantom(o);
  const QuantizedVolume q = quantizeVolume(ph.ct);
  PinchSelection sel(q, GrowParams{});
  const OrbitCamera cam = OrbitCamera::framing(ph.ct.geometry());
  const Viewport vp{100, 100};
  TouchInput in;
  in.setViewport(vp);
  for (int id : {1, 2}) {
    TouchEvent e{TouchPhase::Down, id, {double(id), 1.0}, 1.0, 0.0};
    in.apply(e);
    sel.onTouch(e, in, cam, vp);
  }
  ASSERT_EQ(sel.takePickRequest().size(), 2u);
  sel.onPicks({std::nullopt, glm::dvec3(0.0)}, cam, vp);
  EXPECT_EQ(sel.state(), PinchSelection::State::Idle);
  EXPECT_NE(sel.feedback().find("visible anatomy"), std::string::npos);
  EXPECT_FALSE(sel.takeFinished().has_value());
}
