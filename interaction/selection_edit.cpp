#include "selection_edit.h"

#include <algorithm>
#include <cmath>
#include <iterator>

#include "sim/distance_transform.h"

namespace handson {

namespace {

std::uint32_t nearestTo(const std::vector<std::uint32_t>& voxels, std::uint32_t to, const VolumeGeometry& g) {
  const Eigen::Vector3i t = g.voxelOf(to);
  std::uint32_t best = voxels.front();
  double bestD = 1e300;
  for (std::uint32_t v : voxels) {
    const double d = (g.voxelOf(v) - t).cast<double>().cwiseProduct(g.spacing).squaredNorm();
    if (d < bestD) {
      bestD = d;
      best = v;
    }
  }
  return best;
}

bool contains(const std::vector<std::uint32_t>& sorted, std::uint32_t v) { return std::binary_search(sorted.begin(), sorted.end(), v); }

// Steepest ascent of the distance transform from box voxel i (26 neighbours) to a local top.
std::size_t climb(const RegionDistance& b, std::size_t i) {
  const long sy = b.dims.x(), sz = sy * b.dims.y();
  for (;;) {
    std::size_t best = i;
    for (int dz = -1; dz <= 1; ++dz)
      for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx) {
          const std::size_t j = std::size_t(long(i) + dx + dy * sy + dz * sz);
          if (b.d2[j] > b.d2[best]) best = j;
        }
    if (best == i) return i;
    i = best;
  }
}

}  // namespace

const char* correctionRuleName(CorrectionRule r) { return r == CorrectionRule::Neck ? "neck" : "grown"; }

bool parseCorrectionRule(const std::string& s, CorrectionRule& out) {
  for (CorrectionRule r : {CorrectionRule::Neck, CorrectionRule::Grown})
    if (s == correctionRuleName(r)) {
      out = r;
      return true;
    }
  return false;
}

NeckSplit splitAtNeck(const std::vector<std::uint32_t>& region, std::uint32_t keep, std::uint32_t cut, const VolumeGeometry& g, bool climbCut) {
  NeckSplit out;
  if (region.empty() || (keep != kNoSeed && !contains(region, keep)) || !contains(region, cut)) return out;
  const RegionDistance b = regionDistance(region, g);
  if (keep == kNoSeed) keep = deepestVoxelOf(region, b, g);
  // The handle's marker climbs to the top of its lobe (its seed may lie anywhere in it); the
  // tap's stays where the pinch grew from.
  const std::size_t ik = climb(b, b.index(g.voxelOf(keep)));
  const std::size_t ic = climbCut ? climb(b, b.index(g.voxelOf(cut))) : b.index(g.voxelOf(cut));
  out.keepWidthMm = std::sqrt(double(b.d2[ik]));
  out.cutWidthMm = std::sqrt(double(b.d2[ic]));
  if (ik == ic) return out;
  // Widths quantized to 1/16 of the smallest spacing: a bucket queue taken from the widest down,
  // each bucket first in, first out; a voxel belongs to the flood that reaches it first.
  const double unit = g.spacing.minCoeff() / 16.0;
  auto width = [&](std::size_t i) { return std::uint32_t(std::sqrt(double(b.d2[i])) / unit); };
  std::vector<std::uint8_t> owner(b.d2.size(), 0);  // 0 none, 1 keep, 2 cut
  std::vector<std::uint32_t> key(b.d2.size(), 0);
  std::vector<std::vector<std::uint32_t>> buckets;
  auto push = [&](std::size_t i, std::uint32_t w, std::uint8_t who) {
    owner[i] = who;
    key[i] = w;
    if (w >= buckets.size()) buckets.resize(std::size_t(w) + 1);
    buckets[w].push_back(std::uint32_t(i));
  };
  push(ik, width(ik), 1);
  push(ic, width(ic), 2);
  std::uint32_t neck = 0;
  bool met = false;
  const std::size_t sy = std::size_t(b.dims.x()), sz = sy * std::size_t(b.dims.y());
  for (std::size_t w = buckets.size(); w-- > 0;) {
    for (std::size_t n = 0; n < buckets[w].size(); ++n) {  // the bucket may grow while it is taken
      const std::size_t i = buckets[w][n];
      for (const std::size_t j : {i - 1, i + 1, i - sy, i + sy, i - sz, i + sz}) {
        if (b.d2[j] <= 0.0f) continue;  // outside the region (the box's margin among it)
        if (owner[j] && owner[j] != owner[i]) {
          neck = std::max(neck, std::min(std::uint32_t(w), key[j]));
          met = true;
        }
        if (!owner[j]) push(j, std::min(std::uint32_t(w), width(j)), owner[i]);
      }
    }
  }
  out.neckWidthMm = met ? neck * unit : 0.0;
  for (std::uint32_t v : region)
    if (owner[b.index(g.voxelOf(v))] == 2) out.cutSide.push_back(v);
  return out;
}

bool subtractHandle(HandleSet& handles, int a, int b, CorrectionRule rule, const VolumeGeometry& g) {
  const Handle* ha = handles.find(a);
  const Handle* hb = handles.find(b);
  if (rule == CorrectionRule::Grown || !ha || !hb || a == b) return handles.subtract(a, b);
  const std::vector<std::uint32_t> region = handles.voxelsBeforeClaim(a, b);
  std::vector<std::uint32_t> shared;
  std::set_intersection(region.begin(), region.end(), hb->voxels.begin(), hb->voxels.end(), std::back_inserter(shared));
  if (shared.empty()) return handles.subtract(a, b);
  const std::uint32_t keep = ha->seed != kNoSeed && contains(region, ha->seed) ? ha->seed : kNoSeed;  // none: the deepest
  std::uint32_t cut = hb->seed;
  if (cut == kNoSeed) cut = deepestVoxelOf(shared, regionDistance(shared, g), g);
  else if (!contains(region, cut)) cut = nearestTo(shared, cut, g);
  const std::vector<std::uint32_t> removal = splitAtNeck(region, keep, cut, g).cutSide;
  std::vector<std::uint32_t> taken;
  std::set_intersection(removal.begin(), removal.end(), hb->voxels.begin(), hb->voxels.end(), std::back_inserter(taken));
  if (taken.empty()) return false;  // the pinch's seed lies in the handle's own lobe: nothing beyond a neck
  return handles.subtract(a, b, taken);
}

bool uniteHandle(HandleSet& handles, int a, int b, CorrectionRule rule, const VolumeGeometry& g) {
  const Handle* ha = handles.find(a);
  const Handle* hb = handles.find(b);
  if (rule == CorrectionRule::Grown || !ha || !hb || a == b) return handles.unite(a, b);
  const std::vector<std::uint32_t>& pinch = hb->voxels;
  if (hb->seed == kNoSeed || !contains(pinch, hb->seed)) return handles.unite(a, b);  // no seed in it: the pinch's widest lobe
  const NeckSplit split = splitAtNeck(pinch, kNoSeed, hb->seed, g, true);
  if (split.cutSide.empty()) return handles.unite(a, b);  // the seed's lobe is the pinch's widest
  return handles.unite(a, b, split.cutSide);
}

const char* pinchOpName(PinchOp op) {
  switch (op) {
    case PinchOp::New: return "new";
    case PinchOp::Add: return "add";
    case PinchOp::Remove: return "remove";
  }
  return "?";
}

bool parsePinchOp(const std::string& s, PinchOp& out) {
  for (PinchOp op : {PinchOp::New, PinchOp::Add, PinchOp::Remove})
    if (s == pinchOpName(op)) {
      out = op;
      return true;
    }
  return false;
}

PinchEdit applyPinch(HandleSet& handles, std::vector<std::uint32_t> voxels, std::uint32_t seed, const PinchRequest& request, const VolumeGeometry& g) {
  const auto [op, target, rule] = request;
  const bool correct = op != PinchOp::New && handles.find(target);
  const std::uint64_t start = handles.editCount();
  const int b = handles.add(std::move(voxels), seed);
  if (b == 0) return {0, "No handle is left for the selection"};
  if (!correct) return {b, ""};
  PinchEdit out{target, ""};
  if (op == PinchOp::Add) {
    if (handles.find(target)) uniteHandle(handles, target, b, rule, g);
    else out.handle = b;  // the pinch took all of the target: the union is the pinch
  } else if (handles.find(target) && subtractHandle(handles, target, b, rule, g)) {
    handles.release(b);  // what the pinch took from other handles goes back to them
  } else {
    handles.revert();
    return {0, "Nothing removed: the pinch would take all of the handle, or none of it lies beyond a neck from the pinch"};
  }
  handles.squashSince(start);
  return out;
}

namespace {

void growBox(EditOnCopy& e, std::uint32_t v, const VolumeGeometry& g) {
  const Eigen::Vector3i p = g.voxelOf(v);
  e.boxMin = e.boxMin.cwiseMin(p);
  e.boxMax = e.boxMax.cwiseMax(p);
}

// The edited set taken out of `edited` into `out`, with the mask's change from `before` and its box.
void tookIn(const std::vector<Handle>& before, HandleSet& edited, const VolumeGeometry& g, EditOnCopy& out) {
  out.changed = true;
  out.after = edited.handles();
  out.mask = HandleSet::maskChange(before, out.after);
  for (std::uint32_t v : out.mask.cleared) growBox(out, v, g);
  for (const auto& [v, id] : out.mask.joined) growBox(out, v, g);
}

}  // namespace

EditOnCopy applyPinchOnCopy(std::vector<Handle> handles, std::vector<std::uint32_t> voxels, std::uint32_t seed, const PinchRequest& request,
                            const VolumeGeometry& g) {
  HandleSet set(handles);
  EditOnCopy out;
  for (std::uint32_t v : voxels) growBox(out, v, g);  // the pinch drawn meanwhile is repainted too
  const PinchEdit edit = applyPinch(set, std::move(voxels), seed, request, g);
  if (edit.handle != 0) tookIn(handles, set, g, out);
  out.refusal = edit.refusal;
  out.handle = edit.handle;
  return out;
}

EditOnCopy correctOnCopy(std::vector<Handle> handles, int a, int b, bool unite, CorrectionRule rule, const VolumeGeometry& g) {
  HandleSet set(handles);
  EditOnCopy out;
  if (unite ? uniteHandle(set, a, b, rule, g) : subtractHandle(set, a, b, rule, g)) tookIn(handles, set, g, out);
  return out;
}

}  // namespace handson
