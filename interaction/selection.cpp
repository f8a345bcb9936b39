#include "selection.h"

#include <algorithm>
#include <cmath>

#include "sim/base/error.h"

namespace handson {

namespace {
constexpr double kMaxExtentMm = 500.0;  // the largest extent a pinch may spread to
}  // namespace

template <class Call> void PinchSelection::onEngine(Call&& call) {
  try {
    call(*growingOn_);
  } catch (const Error& e) {
    growingOn_ = nullptr;  // the CPU reference grows this selection from here on
    grower_->growTo(extent_);
    feedback_ = std::string("The selection grows on the CPU: ") + e.what();
  }
}

void PinchSelection::onTouch(const TouchEvent& e, const TouchInput& input, const OrbitCamera& camera, const Viewport& viewport) {
  (void)camera;
  (void)viewport;
  const auto& f = input.fingers();
  switch (state_) {
    case State::Idle:
      if (e.phase == TouchPhase::Down && f.size() == 2) {
        fingerA_ = f[0].id;
        fingerB_ = f[1].id;
        pickA_ = f[0].px;
        pickB_ = f[1].px;
        requestPending_ = true;
        state_ = State::WaitingForPicks;
        feedback_.clear();
      }
      break;
    case State::WaitingForPicks:
    case State::Growing: {
      const bool bothDown = input.find(fingerA_) && input.find(fingerB_);
      if (!bothDown && state_ == State::WaitingForPicks && e.phase != TouchPhase::Cancel) {
        // A finger lifted before the depth-picks came back (a quick pinch, slow frames): the
        // selection ends as soon as they do, at the fingers' last spread, whatever the other
        // finger does meanwhile. (A cancel ends it now.)
        liftedBeforePicks_ = true;
        break;
      }
      if (!bothDown) {  // a finger lifted: the selection ends
        finish();
        break;
      }
      if (e.phase != TouchPhase::Move) break;
      if (state_ == State::Growing) {
        updateExtent(input);
      } else {  // the spread the selection will start from when the picks come back
        pickA_ = input.find(fingerA_)->px;
        pickB_ = input.find(fingerB_)->px;
      }
      break;
    }
  }
}

void PinchSelection::finish() {
  if (state_ == State::Growing && grower_) {
    std::optional<std::vector<std::uint32_t>> voxels;
    if (growingOn_) onEngine([&voxels](GrowthEngine& g) { voxels = g.finish(); });
    finishedSeed_ = std::uint32_t(linearIndex(volume_.geometry, grower_->setup().seed));
    finished_.emplace();
    finished_->seed = finishedSeed_;
    if (params_.boundaryRim) finished_->rim.emplace(*grower_);
    if (voxels) {
      finished_->voxels = std::move(*voxels);
    } else {  // the CPU's (also after a fallback), gathered later: the lift stays cheap
      finished_->bound = grower_->bound(extent_);
      finished_->grower = std::move(grower_);
    }
    changed_ = true;
  }
  growingOn_ = nullptr;
  grower_.reset();
  state_ = State::Idle;
  requestPending_ = false;
  liftedBeforePicks_ = false;
}

std::vector<glm::dvec2> PinchSelection::takePickRequest() {
  if (!requestPending_) return {};
  requestPending_ = false;
  return {pickA_, pickB_};
}

void PinchSelection::onPicks(const std::vector<std::optional<glm::dvec3>>& world, const OrbitCamera& camera, const Viewport& viewport) {
  if (state_ != State::WaitingForPicks) return;
  const bool lifted = std::exchange(liftedBeforePicks_, false);
  if (world.size() != 2 || !world[0] || !world[1]) {
    feedback_ = "Pinch on visible anatomy: a finger was not on the volume";
    state_ = State::Idle;
    changed_ = true;
    return;
  }
  const glm::dvec3 seedWorld = 0.5 * (*world[0] + *world[1]);
  const Eigen::Vector3d idx = volume_.geometry.toIndex(Eigen::Vector3d(seedWorld.x, seedWorld.y, seedWorld.z)).array().round();
  if (!idx.allFinite() || !volume_.geometry.contains(Eigen::Vector3i(idx.cast<int>()))) {
    feedback_ = "Pinch on visible anatomy: the seed fell outside the volume";
    state_ = State::Idle;
    changed_ = true;
    return;
  }
  // The midpoint of two surface points lies on the organ's surface, where the 3x3x3 statistics
  // straddle the edge; snap to the most homogeneous voxel within two voxels (smallest 3x3x3
  // standard deviation, the nearest on ties).
  const Eigen::Vector3i seed = mostHomogeneousNear(volume_, idx.cast<int>(), 2);
  const double depth = glm::dot(seedWorld - camera.eye(), camera.forward());
  pixelMm_ = camera.pixelSizeAt(std::max(depth, 1e-3), viewport.height);
  grower_.reset();  // gives the workspace back before the next grower takes it
  if (finished_) finished_->gather();  // so does a finished pinch not taken yet (on this thread: it would wait for itself)
  try {
    grower_ = std::make_unique<RegionGrower>(volume_, seed, params_, workspace_);
  } catch (const Error& e) {
    feedback_ = std::string("Pinch refused: ") + e.what();
    state_ = State::Idle;
    changed_ = true;
    return;
  }
  state_ = State::Growing;
  extent_ = 0.0;
  feedback_.clear();
  // The fingers' current spread decides the first extent.
  extent_ = std::min(pixelMm_ * glm::length(pickA_ - pickB_), kMaxExtentMm);
  if (!std::isfinite(extent_)) {  // a camera or fingers that give no pixel size: nothing to grow
    feedback_ = "Pinch on visible anatomy: the fingers' spread gives no extent";
    grower_.reset();
    state_ = State::Idle;
    changed_ = true;
    return;
  }
  growingOn_ = engine_;
  if (growingOn_) {
    onEngine([this](GrowthEngine& g) {
      g.start(*grower_);
      g.show(grower_->bound(extent_), extent_);
    });
  } else {
    grower_->growTo(extent_);
  }
  changed_ = true;
  if (lifted) finish();
}

void PinchSelection::updateExtent(const TouchInput& input) {
  const Finger* a = input.find(fingerA_);
  const Finger* b = input.find(fingerB_);
  if (!a || !b || !grower_) return;
  pickA_ = a->px;
  pickB_ = b->px;
  const double e = pixelMm_ * glm::length(a->px - b->px);
  if (!std::isfinite(e) || std::abs(e - extent_) < 1e-9) return;
  extent_ = std::min(e, kMaxExtentMm);
  if (growingOn_) onEngine([this](GrowthEngine& g) { g.show(grower_->bound(extent_), extent_); });
  else if (extent_ > grower_->grownExtent()) grower_->growTo(extent_);
  changed_ = true;
}

std::vector<std::uint32_t> PinchSelection::liveVoxels() const {
  std::vector<std::uint32_t> out;
  if (!grower_ || growingOn_) return out;
  return grower_->selected(grower_->bound(extent_));
}

std::optional<std::vector<std::uint32_t>> PinchSelection::takeFinished() {
  auto f = takeFinishedPinch();
  if (!f) return std::nullopt;
  return std::move(*f).complete();
}

void FinishedPinch::gather() {
  if (!grower) return;
  voxels = grower->selected(bound);
  grower.reset();
}

std::vector<std::uint32_t> FinishedPinch::complete() && {
  gather();
  std::vector<std::uint32_t> out = std::move(voxels);
  std::sort(out.begin(), out.end());  // the same handle whichever engine grew it
  return rim ? withBoundaryRim(*rim, out) : out;
}

}  // namespace handson
