// Corrections of a selection (interaction/selection_edit.h): the split at the narrowest neck
// against brute force, and differences and unions of handles that take the leak and keep the organ.
#include "interaction/selection_edit.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <functional>

#include "sim/distance_transform.h"

using namespace handson;

namespace {

VolumeGeometry grid(int n) {
  VolumeGeometry g;
  g.dims = Eigen::Vector3i::Constant(n);
  g.spacing = Eigen::Vector3d(1.0, 1.0, 1.0);
  return g;
}

std::vector<std::uint32_t> voxelsWhere(const VolumeGeometry& g, const std::function<bool(const Eigen::Vector3d&)>& in) {
  std::vector<std::uint32_t> out;
  for (int k = 0; k < g.dims.z(); ++k)
    for (int j = 0; j < g.dims.y(); ++j)
      for (int i = 0; i < g.dims.x(); ++i)
        if (in(Eigen::Vector3d(i, j, k))) out.push_back(std::uint32_t(linearIndex(g, {i, j, k})));
  return out;
}

// Two balls on the x axis joined by a thin bridge: the organ (radius 7 about x = 12), the leak
// (radius 6 about x = 30) and a bridge of radius 1.5 between them (a 40^3 grid of 1 mm voxels).
struct Dumbbell {
  VolumeGeometry g = grid(40);
  static bool organ(const Eigen::Vector3d& p) { return (p - Eigen::Vector3d(12, 20, 20)).norm() <= 7.0; }
  static bool leak(const Eigen::Vector3d& p) { return (p - Eigen::Vector3d(30, 20, 20)).norm() <= 6.0; }
  static bool bridge(const Eigen::Vector3d& p) { return p.x() > 12 && p.x() < 30 && std::hypot(p.y() - 20, p.z() - 20) <= 1.5; }
  std::vector<std::uint32_t> all = voxelsWhere(g, [](const Eigen::Vector3d& p) { return organ(p) || leak(p) || bridge(p); });
  std::uint32_t at(int i, int j, int k) const { return std::uint32_t(linearIndex(g, {i, j, k})); }
};

TEST(SelectionEdit, TheSplitFollowsTheWidestPathsAsBruteForceFindsThem) {
  // A region of overlapping boxes and balls; markers anywhere in it. Each voxel's widest-path
  // width from each marker by brute-force relaxation (Bellman-Ford on the quantized distance
  // transform, the same 1/16 mm units): where one marker's is strictly wider, the split must give
  // the voxel to it.
  const VolumeGeometry g = grid(24);
  const auto region = voxelsWhere(g, [](const Eigen::Vector3d& p) {
    return (p - Eigen::Vector3d(7, 8, 9)).norm() <= 5.5 || (p - Eigen::Vector3d(16, 14, 12)).norm() <= 4.5 ||
           (p.x() >= 6 && p.x() <= 18 && p.y() >= 10 && p.y() <= 12 && p.z() >= 9 && p.z() <= 11);
  });
  const std::uint32_t keep = std::uint32_t(linearIndex(g, {9, 8, 9})), cut = std::uint32_t(linearIndex(g, {15, 14, 12}));
  const NeckSplit split = splitAtNeck(region, keep, cut, g);
  ASSERT_FALSE(split.cutSide.empty());
  // Brute force: the distance transform, the keep marker's climb, then the widest paths.
  std::vector<std::uint8_t> inside(std::size_t(g.dims.prod()), 0);
  for (std::uint32_t v : region) inside[v] = 1;
  const auto d2 = squaredDistanceToOutside(inside, g.dims, g.spacing);
  auto width = [&](std::uint32_t v) { return long(std::sqrt(double(d2[v])) * 16.0); };
  std::uint32_t top = keep;
  for (bool moved = true; moved;) {
    moved = false;
    const Eigen::Vector3i p = g.voxelOf(top);
    std::uint32_t best = top;
    for (int dz = -1; dz <= 1; ++dz)
      for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx) {
          const Eigen::Vector3i q = p + Eigen::Vector3i(dx, dy, dz);
          if (g.contains(q) && d2[linearIndex(g, q)] > d2[best]) best = std::uint32_t(linearIndex(g, q));
        }
    moved = best != top;
    top = best;
  }
  auto widest = [&](std::uint32_t from) {
    std::vector<long> w(inside.size(), -1);
    w[from] = width(from);
    for (bool changed = true; changed;) {
      changed = false;
      for (std::uint32_t v : region)
        for (const Eigen::Vector3i& d : {Eigen::Vector3i(1, 0, 0), Eigen::Vector3i(-1, 0, 0), Eigen::Vector3i(0, 1, 0), Eigen::Vector3i(0, -1, 0),
                                         Eigen::Vector3i(0, 0, 1), Eigen::Vector3i(0, 0, -1)}) {
          const Eigen::Vector3i q = g.voxelOf(v) + d;
          if (!g.contains(q) || !inside[linearIndex(g, q)]) continue;
          const long through = std::min(w[linearIndex(g, q)], width(v));
          if (through > w[v]) {
            w[v] = through;
            changed = true;
          }
        }
    }
    return w;
  };
  const auto wk = widest(top), wc = widest(cut);
  int decided = 0;
  for (std::uint32_t v : region) {
    const bool onCut = std::binary_search(split.cutSide.begin(), split.cutSide.end(), v);
    if (wk[v] > wc[v]) {
      EXPECT_FALSE(onCut) << g.voxelOf(v).transpose();
    }
    if (wc[v] > wk[v]) {
      EXPECT_TRUE(onCut) << g.voxelOf(v).transpose();
    }
    decided += wk[v] != wc[v];
  }
  // The split is decided by width, not by the tie rule, for a good part of the region (the rest:
  // voxels whose widest paths to both markers pass the same narrowest point).
  EXPECT_GT(decided, int(region.size()) / 4);
}

TEST(SelectionEdit, ADumbbellSplitsAtItsBridge) {
  // The organ's marker off its centre (it climbs to the centre); the leak's at its centre: the
  // split gives every voxel of the leak's ball to the cut side and none of the organ's, and the
  // neck is the bridge's width (its inscribed radius, ~1.5 mm on the voxel grid).
  Dumbbell d;
  const NeckSplit s = splitAtNeck(d.all, d.at(9, 18, 21), d.at(30, 20, 20), d.g);
  for (std::uint32_t v : d.all) {
    const Eigen::Vector3d p = d.g.voxelOf(v).cast<double>();
    const bool onCut = std::binary_search(s.cutSide.begin(), s.cutSide.end(), v);
    if (Dumbbell::organ(p)) {
      EXPECT_FALSE(onCut);
    }
    if (Dumbbell::leak(p)) {
      EXPECT_TRUE(onCut);
    }
  }
  // The marker climbed to the organ's centre, sqrt(50) mm from the nearest voxel outside the ball
  // (an offset of (5, 5, 0) voxels, just past its 7 mm radius).
  EXPECT_DOUBLE_EQ(s.keepWidthMm, std::sqrt(50.0));
  EXPECT_LE(s.neckWidthMm, 2.5);
  EXPECT_GE(s.neckWidthMm, 1.0);
  // Markers outside the region, or a keep marker that climbs onto the cut marker: no split.
  EXPECT_TRUE(splitAtNeck(d.all, d.at(0, 0, 0), d.at(30, 20, 20), d.g).cutSide.empty());
  EXPECT_TRUE(splitAtNeck(d.all, d.at(11, 20, 20), d.at(12, 20, 20), d.g).cutSide.empty());
}

TEST(SelectionEdit, ADifferenceTakesTheLeakAndGivesTheOrganBack) {
  // The handle leaked through the bridge; the removal pinch grew from the leak's centre back into
  // half the organ (a ball of 18 mm about the leak). Grown takes the organ's half with it; Neck
  // takes the leak and the bridge's far half, and the organ's voxels the pinch claimed return.
  Dumbbell d;
  const auto pinch = voxelsWhere(d.g, [](const Eigen::Vector3d& p) { return (p - Eigen::Vector3d(30, 20, 20)).norm() <= 18.0; });
  for (const CorrectionRule rule : {CorrectionRule::Grown, CorrectionRule::Neck}) {
    HandleSet h;
    const int a = h.add(d.all, d.at(12, 20, 20));
    const int b = h.add(pinch, d.at(30, 20, 20));
    ASSERT_TRUE(subtractHandle(h, a, b, rule, d.g));
    std::size_t organ = 0, leak = 0;
    for (std::uint32_t v : h.find(a)->voxels) {
      organ += Dumbbell::organ(d.g.voxelOf(v).cast<double>());
      leak += Dumbbell::leak(d.g.voxelOf(v).cast<double>());
    }
    const std::size_t organAll = std::size_t(std::count_if(d.all.begin(), d.all.end(), [&](std::uint32_t v) { return Dumbbell::organ(d.g.voxelOf(v).cast<double>()); }));
    EXPECT_EQ(leak, 0u) << correctionRuleName(rule);
    if (rule == CorrectionRule::Neck) {
      EXPECT_EQ(organ, organAll);
      // One handle per voxel: the pinch's handle keeps only what a lost.
      for (std::uint32_t v : h.find(b)->voxels) EXPECT_FALSE(std::binary_search(h.find(a)->voxels.begin(), h.find(a)->voxels.end(), v));
    } else {
      EXPECT_LT(organ, organAll * 9 / 10);
    }
    // One undo step: back to the handles after the pinch's claim.
    const std::vector<std::uint32_t> afterClaim = [&] {
      HandleSet c;
      c.add(d.all);
      c.add(pinch);
      return c.find(1)->voxels;
    }();
    EXPECT_TRUE(h.undo());
    EXPECT_EQ(h.find(a)->voxels, afterClaim);
  }
}

TEST(SelectionEdit, AUnionAddsTheStructureThePinchWasPlacedOnNotWhatItLeakedInto) {
  // The selection is the organ ball; the addition's pinch was placed on a thin branch (radius 1.5)
  // and leaked through it into a wide blob (radius 6): Neck adds the branch's side of its neck,
  // Grown the blob too.
  Dumbbell d;
  const auto organ = voxelsWhere(d.g, Dumbbell::organ);
  const auto pinch = voxelsWhere(d.g, [](const Eigen::Vector3d& p) { return Dumbbell::bridge(p) || Dumbbell::leak(p) || (p - Eigen::Vector3d(12, 20, 20)).norm() <= 3.0; });
  for (const CorrectionRule rule : {CorrectionRule::Grown, CorrectionRule::Neck}) {
    HandleSet h;
    const int a = h.add(organ, d.at(12, 20, 20));
    const int b = h.add(pinch, d.at(21, 20, 20));
    ASSERT_TRUE(uniteHandle(h, a, b, rule, d.g));
    EXPECT_EQ(h.find(b), nullptr);
    std::size_t leak = 0, branch = 0, kept = 0;
    for (std::uint32_t v : h.find(a)->voxels) {
      const Eigen::Vector3d p = d.g.voxelOf(v).cast<double>();
      leak += Dumbbell::leak(p);
      branch += Dumbbell::bridge(p) && !Dumbbell::organ(p) && !Dumbbell::leak(p) && p.x() < 21;
      kept += Dumbbell::organ(p);
    }
    EXPECT_EQ(kept, organ.size()) << correctionRuleName(rule);  // the organ's voxels the pinch claimed come back
    EXPECT_GT(branch, 0u);
    if (rule == CorrectionRule::Neck) {
      EXPECT_EQ(leak, 0u);
    } else {
      EXPECT_GT(leak, 0u);
    }
  }
}

TEST(SelectionEdit, APinchThatAddsOrRemovesIsOneUndoStepAndARefusedOneChangesNothing) {
  Dumbbell d;
  const auto organ = voxelsWhere(d.g, Dumbbell::organ);
  const auto pinch = voxelsWhere(d.g, [](const Eigen::Vector3d& p) { return Dumbbell::bridge(p) || Dumbbell::leak(p); });
  HandleSet h;
  const PinchEdit first = applyPinch(h, d.all, d.at(12, 20, 20), {PinchOp::New, 0, CorrectionRule::Neck}, d.g);
  ASSERT_EQ(first.handle, 1);
  // Remove the leak and the bridge's far half: one handle left, one undo step back to the whole.
  const PinchEdit removed = applyPinch(h, pinch, d.at(30, 20, 20), {PinchOp::Remove, first.handle, CorrectionRule::Neck}, d.g);
  EXPECT_EQ(removed.handle, first.handle);
  EXPECT_TRUE(removed.refusal.empty());
  ASSERT_EQ(h.handles().size(), 1u);
  EXPECT_LT(h.find(1)->voxels.size(), d.all.size());
  EXPECT_GE(h.find(1)->voxels.size(), organ.size());
  EXPECT_TRUE(h.undo());
  EXPECT_EQ(h.find(1)->voxels, d.all);
  // A removal whose seed lies in the handle's own lobe takes nothing: refused, nothing changed,
  // the undone removal still there to redo.
  const PinchEdit refused = applyPinch(h, organ, d.at(12, 20, 20), {PinchOp::Remove, 1, CorrectionRule::Neck}, d.g);
  EXPECT_EQ(refused.handle, 0);
  EXPECT_FALSE(refused.refusal.empty());
  EXPECT_EQ(h.find(1)->voxels, d.all);
  EXPECT_EQ(h.handles().size(), 1u);
  ASSERT_TRUE(h.canRedo());
  EXPECT_TRUE(h.redo());
  const auto before = h.find(1)->voxels;
  EXPECT_LT(before.size(), d.all.size());
  // Add the leak back: one handle, one undo step.
  const PinchEdit added = applyPinch(h, pinch, d.at(30, 20, 20), {PinchOp::Add, 1, CorrectionRule::Grown}, d.g);
  EXPECT_EQ(added.handle, 1);
  EXPECT_EQ(h.find(1)->voxels, d.all);
  EXPECT_TRUE(h.undo());
  EXPECT_EQ(h.find(1)->voxels, before);
  // A correction with no such target makes a new handle.
  EXPECT_EQ(applyPinch(h, pinch, d.at(30, 20, 20), {PinchOp::Add, 7, CorrectionRule::Neck}, d.g).handle, 2);
}

TEST(SelectionEdit, AnEditMadeOnACopyGivesTheHandlesTheSameEditMadeInPlaceGives) {
  // The app's background edits (app/session/selection_controller.h): a pinch removed, refused,
  // added; a union and a difference of handles; each on a copy, taken in with replace, against
  // the same edit on the set itself.
  Dumbbell d;
  const auto organ = voxelsWhere(d.g, Dumbbell::organ);
  const auto pinch = voxelsWhere(d.g, [](const Eigen::Vector3d& p) { return Dumbbell::bridge(p) || Dumbbell::leak(p); });
  HandleSet inPlace, copied;
  auto same = [&](const char* what) {
    ASSERT_EQ(inPlace.handles().size(), copied.handles().size()) << what;
    for (std::size_t i = 0; i < inPlace.handles().size(); ++i) {
      EXPECT_EQ(inPlace.handles()[i].id, copied.handles()[i].id) << what;
      EXPECT_EQ(inPlace.handles()[i].voxels, copied.handles()[i].voxels) << what;
      EXPECT_EQ(inPlace.handles()[i].seed, copied.handles()[i].seed) << what;
    }
  };
  auto pinchBoth = [&](const std::vector<std::uint32_t>& voxels, std::uint32_t seed, PinchRequest r) {
    const PinchEdit e = applyPinch(inPlace, voxels, seed, r, d.g);
    EditOnCopy c = applyPinchOnCopy(copied.handles(), voxels, seed, r, d.g);
    EXPECT_EQ(c.handle, e.handle);
    EXPECT_EQ(c.refusal, e.refusal);
    EXPECT_EQ(c.changed, e.handle != 0);
    if (c.changed) copied.replace(std::move(c.after));
  };
  pinchBoth(d.all, d.at(12, 20, 20), {PinchOp::New, 0, CorrectionRule::Neck});
  same("first pinch");
  pinchBoth(pinch, d.at(30, 20, 20), {PinchOp::Remove, 1, CorrectionRule::Neck});
  same("removal");
  pinchBoth(organ, d.at(12, 20, 20), {PinchOp::Remove, 1, CorrectionRule::Neck});  // refused
  same("refused removal");
  pinchBoth(pinch, d.at(30, 20, 20), {PinchOp::New, 0, CorrectionRule::Neck});
  same("second handle");
  for (const bool unite : {false, true}) {
    const bool ok = unite ? uniteHandle(inPlace, 1, 2, CorrectionRule::Neck, d.g) : subtractHandle(inPlace, 1, 2, CorrectionRule::Neck, d.g);
    EditOnCopy c = correctOnCopy(copied.handles(), 1, 2, unite, CorrectionRule::Neck, d.g);
    EXPECT_EQ(c.changed, ok);
    if (c.changed) copied.replace(std::move(c.after));
    same(unite ? "union" : "difference");
  }
  EXPECT_FALSE(correctOnCopy(copied.handles(), 1, 9, true, CorrectionRule::Neck, d.g).changed);  // no handle 9: refused
  // Undone, both go back to the same handles: each edit was one undo step.
  while (inPlace.undo()) ASSERT_TRUE(copied.undo());
  EXPECT_FALSE(copied.undo());
}

TEST(SelectionEdit, ClaimsGiveBackOnlyWhatTheClaimerStillHoldsToHandlesThatStillExist) {
  // A new handle that empties another: its claim on it is dropped (the id is reused next).
  HandleSet h;
  const int a = h.add({1, 2});
  const int b = h.add({1, 2, 3});
  ASSERT_EQ(h.find(a), nullptr);
  const int c = h.add({7});
  ASSERT_EQ(c, a);
  EXPECT_EQ(h.voxelsBeforeClaim(c, b), (std::vector<std::uint32_t>{7}));
  // A claim partly taken on by a third handle: only what the claimer still holds goes back, and
  // every voxel stays in one handle.
  HandleSet k;
  const int x = k.add({1, 2, 3});
  const int y = k.add({3, 4});
  const int z = k.add({3});
  EXPECT_EQ(k.voxelsBeforeClaim(x, y), (std::vector<std::uint32_t>{1, 2}));
  ASSERT_TRUE(k.unite(x, y, {4}));
  EXPECT_EQ(k.find(x)->voxels, (std::vector<std::uint32_t>{1, 2, 4}));
  EXPECT_EQ(k.find(z)->voxels, (std::vector<std::uint32_t>{3}));
  // Released, a pinch gives back what it took from every handle.
  HandleSet r;
  const int p = r.add({1, 2, 3});
  const int q = r.add({10, 11});
  const int pinch = r.add({3, 10, 20});
  ASSERT_TRUE(r.release(pinch));
  EXPECT_EQ(r.find(p)->voxels, (std::vector<std::uint32_t>{1, 2, 3}));
  EXPECT_EQ(r.find(q)->voxels, (std::vector<std::uint32_t>{10, 11}));
  EXPECT_EQ(r.find(pinch), nullptr);
}

TEST(SelectionEdit, ClaimsAreForgottenWithTheHandleTheyWereTakenFrom) {
  // b took 3 from a; a is deleted and its id reused by c: b's claim must not give 3 to c.
  HandleSet h;
  const int a = h.add({1, 2, 3});
  const int b = h.add({3, 4});
  ASSERT_EQ(h.voxelsBeforeClaim(a, b), (std::vector<std::uint32_t>{1, 2, 3}));
  ASSERT_TRUE(h.remove(a));
  const int c = h.add({7, 8});
  ASSERT_EQ(c, a);
  EXPECT_EQ(h.voxelsBeforeClaim(c, b), (std::vector<std::uint32_t>{7, 8}));
  // A difference with an empty cut takes nothing and gives the claim back.
  HandleSet k;
  const int x = k.add({1, 2, 3}), y = k.add({3, 4});
  ASSERT_TRUE(k.subtract(x, y, {}));
  EXPECT_EQ(k.find(x)->voxels, (std::vector<std::uint32_t>{1, 2, 3}));
  EXPECT_EQ(k.find(y)->voxels, (std::vector<std::uint32_t>{4}));
}

}  // namespace
