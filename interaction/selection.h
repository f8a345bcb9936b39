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

class PinchSelection {
 public:
  enum class State : std::uint8_t { Idle, WaitingForPicks, Growing };

  PinchSelection(const QuantizedVolume& volume, const GrowParams& params) : volume_(volume), params_(params) {}

  /// Feed select-mode touches (after the input layer accepted them).
  void onTouch(const TouchEvent& e, const TouchInput& input, const OrbitCamera& camera, const Viewport& viewport);
  /// Screen points (pixels) to depth-pick for the pending pinch; empty when nothing is pending.
  /// Taking them marks the request as sent.
  std::vector<glm::dvec2> takePickRequest();
  /// The picks answered for the request: world points (RAS mm) or nullopt for a miss.
  void onPicks(const std::vector<std::optional<glm::dvec3>>& worldPoints, const OrbitCamera& camera, const Viewport& viewport);

  State state() const { return state_; }
  double extentMm() const { return extent_; }
  /// Voxels of the live selection (linear indices), valid while Growing.
  std::vector<std::uint32_t> liveVoxels() const;
  /// Set when the selection ended with the lift of a finger: the final voxels (taken once).
  std::optional<std::vector<std::uint32_t>> takeFinished();
  /// A user-facing message about the last pinch ("" if none), e.g. a refusal.
  const std::string& feedback() const { return feedback_; }
  bool changed() { return std::exchange(changed_, false); }
  const RegionGrower* grower() const { return grower_.get(); }

 private:
  void updateExtent(const TouchInput& input);
  const QuantizedVolume& volume_;
  GrowParams params_;
  State state_ = State::Idle;
  std::int64_t fingerA_ = 0, fingerB_ = 0;
  glm::dvec2 pickA_{0.0}, pickB_{0.0};
  bool requestPending_ = false;
  double pixelMm_ = 0.0, extent_ = 0.0;
  std::unique_ptr<RegionGrower> grower_;
  std::optional<std::vector<std::uint32_t>> finished_;
  std::string feedback_;
  bool changed_ = false;
};

}  // namespace handson
