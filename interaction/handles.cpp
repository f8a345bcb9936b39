#include "handles.h"

#include <algorithm>
#include <iterator>

namespace handson {

const char* handleStatusName(HandleStatus s) {
  switch (s) {
    case HandleStatus::Active: return "active";
    case HandleStatus::Fixed: return "fixed";
    case HandleStatus::Idle: return "idle";
  }
  return "?";
}

bool parseHandleStatus(const std::string& s, HandleStatus& out) {
  for (auto v : {HandleStatus::Active, HandleStatus::Fixed, HandleStatus::Idle})
    if (s == handleStatusName(v)) {
      out = v;
      return true;
    }
  return false;
}

namespace {
// h.voxels := h.voxels ∪ voxels (both sorted).
void gain(Handle& h, const std::vector<std::uint32_t>& voxels) {
  std::vector<std::uint32_t> u;
  std::set_union(h.voxels.begin(), h.voxels.end(), voxels.begin(), voxels.end(), std::back_inserter(u));
  h.voxels = std::move(u);
}
// What b still holds of a claim it made (a later handle may have taken some of it on).
std::vector<std::uint32_t> held(const Claim& c, const Handle& b) {
  std::vector<std::uint32_t> out;
  std::set_intersection(c.voxels.begin(), c.voxels.end(), b.voxels.begin(), b.voxels.end(), std::back_inserter(out));
  return out;
}
}  // namespace

void HandleSet::snapshot(bool move) {
  ++edits_;
  if (move) undo_.push_back(std::move(handles_));
  else undo_.push_back(handles_);
  trimmed_.reset();
  if (undo_.size() > 64) {
    trimmed_ = std::move(undo_.front());
    undo_.erase(undo_.begin());
  }
  clearedRedo_ = std::move(redo_);
  redo_.clear();
}

Handle* HandleSet::get(int id) {
  for (auto& h : handles_)
    if (h.id == id) return &h;
  return nullptr;
}

const Handle* HandleSet::find(int id) const {
  for (const auto& h : handles_)
    if (h.id == id) return &h;
  return nullptr;
}

template <class Pred> void HandleSet::erase(Pred gone) {
  std::vector<int> ids;
  for (const auto& h : handles_)
    if (gone(h)) ids.push_back(h.id);
  handles_.erase(std::remove_if(handles_.begin(), handles_.end(), gone), handles_.end());
  for (auto& h : handles_)
    h.claims.erase(std::remove_if(h.claims.begin(), h.claims.end(), [&](const Claim& c) { return std::count(ids.begin(), ids.end(), c.from) > 0; }),
                   h.claims.end());
}

int HandleSet::add(std::vector<std::uint32_t> voxels, std::uint32_t seed) {
  if (voxels.empty() || int(handles_.size()) >= kMaxHandles) return 0;
  int id = 1;
  while (find(id)) ++id;
  std::sort(voxels.begin(), voxels.end());
  voxels.erase(std::unique(voxels.begin(), voxels.end()), voxels.end());
  snapshot();
  std::vector<Claim> claims;
  for (auto& h : handles_) {  // the last claimer wins
    std::vector<std::uint32_t> rest, taken;
    std::set_difference(h.voxels.begin(), h.voxels.end(), voxels.begin(), voxels.end(), std::back_inserter(rest));
    std::set_intersection(h.voxels.begin(), h.voxels.end(), voxels.begin(), voxels.end(), std::back_inserter(taken));
    if (!taken.empty()) claims.push_back({h.id, std::move(taken)});
    h.voxels = std::move(rest);
  }
  erase([](const Handle& h) { return h.voxels.empty(); });
  claims.erase(std::remove_if(claims.begin(), claims.end(), [&](const Claim& c) { return !find(c.from); }), claims.end());  // ids are reused
  handles_.push_back({id, HandleStatus::Active, std::move(voxels), RigidTransform{}, seed, {}});
  handles_.back().claims = std::move(claims);
  return id;
}

bool HandleSet::release(int b) {
  if (!find(b)) return false;
  snapshot();
  const Handle hb = *find(b);
  for (const Claim& c : hb.claims)
    if (Handle* h = get(c.from)) gain(*h, held(c, hb));
  erase([b](const Handle& h) { return h.id == b; });
  return true;
}

bool HandleSet::remove(int id) {
  if (!find(id)) return false;
  snapshot();
  erase([id](const Handle& h) { return h.id == id; });
  return true;
}

bool HandleSet::setStatus(int id, HandleStatus s) {
  Handle* h = get(id);
  if (!h || h->status == s) return false;
  snapshot();
  get(id)->status = s;
  return true;
}

bool HandleSet::unite(int a, int b) {
  const Handle* hb = find(b);
  return hb && unite(a, b, std::vector<std::uint32_t>(hb->voxels));  // all of b: nothing goes back
}

bool HandleSet::subtract(int a, int b) {
  if (a == b || !find(a) || !find(b)) return false;
  std::vector<std::uint32_t> rest;
  std::set_difference(find(a)->voxels.begin(), find(a)->voxels.end(), find(b)->voxels.begin(), find(b)->voxels.end(), std::back_inserter(rest));
  if (rest.empty()) return false;
  snapshot();
  get(a)->voxels = std::move(rest);
  return true;
}

bool HandleSet::unite(int a, int b, const std::vector<std::uint32_t>& part) {
  if (a == b || !find(a) || !find(b)) return false;
  snapshot();
  const Handle hb = *find(b);
  std::vector<std::uint32_t> kept;
  std::set_intersection(part.begin(), part.end(), hb.voxels.begin(), hb.voxels.end(), std::back_inserter(kept));
  for (const Claim& c : hb.claims)
    if (Handle* h = get(c.from)) {
      const std::vector<std::uint32_t> still = held(c, hb);
      std::vector<std::uint32_t> back;
      std::set_difference(still.begin(), still.end(), kept.begin(), kept.end(), std::back_inserter(back));
      gain(*h, back);
    }
  gain(*get(a), kept);
  erase([b](const Handle& h) { return h.id == b; });
  return true;
}

std::vector<std::uint32_t> HandleSet::voxelsBeforeClaim(int a, int b) const {
  const Handle* ha = find(a);
  const Handle* hb = find(b);
  if (!ha) return {};
  Handle before{a, ha->status, ha->voxels, {}, kNoSeed, {}};
  if (hb)
    for (const Claim& c : hb->claims)
      if (c.from == a) gain(before, held(c, *hb));
  return before.voxels;
}

bool HandleSet::subtract(int a, int b, const std::vector<std::uint32_t>& cut) {
  if (a == b || !find(a) || !find(b)) return false;
  const std::vector<std::uint32_t> before = voxelsBeforeClaim(a, b);
  const std::vector<std::uint32_t>& vb = find(b)->voxels;
  std::vector<std::uint32_t> taken, rest, bRest;
  std::set_intersection(cut.begin(), cut.end(), vb.begin(), vb.end(), std::back_inserter(taken));
  std::set_difference(before.begin(), before.end(), taken.begin(), taken.end(), std::back_inserter(rest));
  if (rest.empty()) return false;
  std::set_difference(vb.begin(), vb.end(), rest.begin(), rest.end(), std::back_inserter(bRest));
  snapshot();
  Handle* hb = get(b);
  hb->claims.erase(std::remove_if(hb->claims.begin(), hb->claims.end(), [a](const Claim& c) { return c.from == a; }), hb->claims.end());
  hb->voxels = std::move(bRest);
  get(a)->voxels = std::move(rest);
  erase([](const Handle& h) { return h.voxels.empty(); });
  return true;
}

bool HandleSet::setPose(int id, const RigidTransform& pose, bool undoable) {
  if (!find(id) || !pose.R.allFinite() || !pose.t.allFinite()) return false;
  if (undoable) snapshot();
  get(id)->pose = pose;
  return true;
}

bool HandleSet::undo() {
  if (undo_.empty()) return false;
  redo_.push_back(handles_);
  handles_ = std::move(undo_.back());
  undo_.pop_back();
  return true;
}

void HandleSet::squashSince(std::uint64_t count) {
  // Each snapshot holds the state before its edit: keeping the group's first undoes them all.
  const std::uint64_t n = edits_ > count ? edits_ - count : 0;
  if (n < 2 || undo_.empty()) return;
  const std::size_t drop = std::min<std::size_t>(std::size_t(n - 1), undo_.size() - 1);
  undo_.erase(undo_.end() - std::ptrdiff_t(drop), undo_.end());
}

bool HandleSet::revert() {
  if (undo_.empty()) return false;
  handles_ = std::move(undo_.back());
  undo_.pop_back();
  --edits_;
  // The history as it was before that edit: its redo steps, and the oldest undo step it trimmed.
  redo_ = std::move(clearedRedo_);
  clearedRedo_.clear();
  if (trimmed_) undo_.insert(undo_.begin(), std::move(*trimmed_));
  trimmed_.reset();
  return true;
}

bool HandleSet::redo() {
  if (redo_.empty()) return false;
  undo_.push_back(handles_);
  handles_ = std::move(redo_.back());
  redo_.pop_back();
  return true;
}

std::vector<glm::vec4> HandleSet::tints(int highlight) const {
  std::vector<glm::vec4> t(256, glm::vec4(0.0f));
  for (const auto& h : handles_) {
    glm::vec4 c;
    switch (h.status) {
      case HandleStatus::Active: c = {1.0f, 0.75f, 0.1f, 0.7f}; break;
      case HandleStatus::Fixed: c = {0.2f, 0.45f, 1.0f, 0.7f}; break;
      case HandleStatus::Idle: c = {0.6f, 0.6f, 0.6f, 0.45f}; break;
    }
    if (h.id == highlight) c.a = 0.95f;
    t[std::size_t(h.id)] = c;
  }
  t[kLiveSelectionId] = {0.2f, 1.0f, 0.3f, 0.8f};
  return t;
}

HandleSet::MaskChange HandleSet::maskChange(const std::vector<Handle>& before, const std::vector<Handle>& after) {
  MaskChange out;
  static const std::vector<std::uint32_t> none;
  auto voxelsOf = [](const std::vector<Handle>& side, int id) -> const std::vector<std::uint32_t>& {
    for (const Handle& h : side)
      if (h.id == id) return h.voxels;
    return none;
  };
  for (const Handle& h : before) {
    const auto& now = voxelsOf(after, h.id);
    std::set_difference(h.voxels.begin(), h.voxels.end(), now.begin(), now.end(), std::back_inserter(out.cleared));
  }
  std::vector<std::uint32_t> joined;
  for (const Handle& h : after) {
    const auto& was = voxelsOf(before, h.id);
    joined.clear();
    std::set_difference(h.voxels.begin(), h.voxels.end(), was.begin(), was.end(), std::back_inserter(joined));
    for (std::uint32_t v : joined) out.joined.emplace_back(v, std::uint8_t(h.id));
  }
  return out;
}

void HandleSet::replace(std::vector<Handle> after) {
  snapshot(true);
  handles_ = std::move(after);
}

}  // namespace handson
