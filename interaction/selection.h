#pragma once
// Selection by a two-finger pinch (docs/touch-app.md): in select mode, when the second
// finger lands, both fingers' screen points are depth-picked (by the GPU, answered a frame or two
// later). Seed s = midpoint of the two surface points; the pixel scale sigma_px at the seed's depth;
// extent d = sigma_px * |p_i - p_t|, following the fingers as they spread or close. Lifting a finger
// ends the selection. A pinch whose fingers do not both land on visible anatomy is refused, with a
// message for the UI.
#include <glm/glm.hpp>

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "camera.h"
#include "region_grow.h"
#include "touch.h"

namespace handson {

/// Where a pinch's selection grows when not on the CPU reference (the app hands it to the GPU
/// pass: app/session/gpu_growth.h). The reference grower is built either way: its seed statistics
/// (setup) and key bounds are what the engine grows with, so both select the same voxels. An engine
/// that cannot go on (a box larger than the device allows, no memory, a lost device) throws
/// handson::Error: the pinch then grows on the CPU reference from there, and says so (feedback()).
class GrowthEngine {
 public:
  virtual ~GrowthEngine() = default;
  /// A selection starts from the reference's seed and statistics.
  virtual void start(const RegionGrower& reference) = 0;
  /// The fingers' extent changed: show the selection up to this key bound (reference.bound(mm)).
  virtual void show(std::uint32_t bound, double extentMm) = 0;
  /// The pinch ended: the selection's voxels up to the last bound shown (linear indices, ascending).
  virtual std::vector<std::uint32_t> finish() = 0;
};

/// A pinch's selection as its fingers lifted, before its voxels are gathered, sorted and rimmed:
/// what the window finishes off the frame's thread (app/session/selection_controller.h). Grown on
/// the CPU, its voxels are still the grower's keys up to `bound`, and the grower still holds its
/// workspace's arrays: gathering them and clearing those (2.2 M voxels of a liver: ~40 ms) is left
/// to gather() or complete(), on any thread; a new pinch's grower waits for the arrays meanwhile.
struct FinishedPinch {
  std::vector<std::uint32_t> voxels;     ///< as grown, in any order (gathered, or the engine's)
  std::optional<BoundaryRimRule> rim;    ///< set when GrowParams::boundaryRim
  std::uint32_t seed = 0xffffffffu;      ///< the voxel it grew from (PinchSelection::finishedSeed)
  std::unique_ptr<RegionGrower> grower;  ///< set until gathered: the voxels are its keys <= bound
  std::uint32_t bound = 0;
  /// The voxels from the grower into `voxels`, and the grower let go (its arrays back, cleared).
  void gather();
  /// The final voxels: ascending, with their boundary rim (withBoundaryRim); gathered first.
  std::vector<std::uint32_t> complete() &&;
};

class PinchSelection {
 public:
  enum class State : std::uint8_t { Idle, WaitingForPicks, Growing };

  /// Sizes the growers' per-voxel arrays for the volume now (GrowWorkspace): a pinch then starts in
  /// milliseconds, not the time to clear a large CT's worth of them.
  PinchSelection(const QuantizedVolume& volume, const GrowParams& params)
      : volume_(volume), params_(params), workspace_(std::make_shared<GrowWorkspace>()) {
    workspace_->reserve(volume.data.size());
  }

  /// Feed select-mode touches (after the input layer accepted them).
  void onTouch(const TouchEvent& e, const TouchInput& input, const OrbitCamera& camera, const Viewport& viewport);
  /// Screen points (pixels) to depth-pick for the pending pinch; empty when nothing is pending.
  /// Taking them marks the request as sent.
  std::vector<glm::dvec2> takePickRequest();
  /// The picks answered for the request: world points (RAS mm) or nullopt for a miss.
  void onPicks(const std::vector<std::optional<glm::dvec3>>& worldPoints, const OrbitCamera& camera, const Viewport& viewport);

  State state() const { return state_; }
  double extentMm() const { return extent_; }
  /// Voxels of the live selection (linear indices), valid while Growing on the CPU.
  std::vector<std::uint32_t> liveVoxels() const;
  /// Set when the selection ended with the lift of a finger: the final voxels, ascending, with their
  /// boundary rim when GrowParams::boundaryRim (withBoundaryRim; the live voxels before the lift
  /// are the grown ones alone). Taken once.
  std::optional<std::vector<std::uint32_t>> takeFinished();
  /// The same before its voxels are sorted and rimmed (FinishedPinch::complete, on any thread).
  std::optional<FinishedPinch> takeFinishedPinch() { return std::exchange(finished_, std::nullopt); }
  /// The voxel the last finished selection grew from (linear index; HandleSet's seed of its handle).
  std::uint32_t finishedSeed() const { return finishedSeed_; }
  /// A user-facing message about the last pinch ("" if none), e.g. a refusal.
  const std::string& feedback() const { return feedback_; }
  bool changed() { return std::exchange(changed_, false); }
  /// Grow on `engine` from the next pinch on (nullptr: on the CPU reference, the default). While an
  /// engine grows, liveVoxels() is empty: the engine shows the live selection itself.
  void setEngine(GrowthEngine* engine) { engine_ = engine; }
  GrowthEngine* engine() const { return engine_; }
  const RegionGrower* grower() const { return grower_.get(); }

 private:
  void updateExtent(const TouchInput& input);
  /// Ends the selection: the finished voxels (Growing) or nothing, and back to Idle.
  void finish();
  /// Runs `call` on the engine; if it throws, the pinch goes on with the CPU reference.
  template <class Call> void onEngine(Call&& call);
  const QuantizedVolume& volume_;
  GrowParams params_;
  State state_ = State::Idle;
  std::int64_t fingerA_ = 0, fingerB_ = 0;
  glm::dvec2 pickA_{0.0}, pickB_{0.0};
  bool requestPending_ = false;
  double pixelMm_ = 0.0, extent_ = 0.0;
  std::shared_ptr<GrowWorkspace> workspace_;  // before grower_: outlives it (and a finished pinch's grower)
  std::unique_ptr<RegionGrower> grower_;
  GrowthEngine* engine_ = nullptr;
  GrowthEngine* growingOn_ = nullptr;  // the engine of the pinch now growing (nullptr: the CPU)
  std::optional<FinishedPinch> finished_;
  std::uint32_t finishedSeed_ = 0xffffffffu;
  bool liftedBeforePicks_ = false;  ///< a finger lifted while the picks were on their way
  std::string feedback_;
  bool changed_ = false;
};

}  // namespace handson
