#pragma once
// A pinch's selection grown on the GPU through the renderer's live selection
// (render/live_selection.h), for PinchSelection (interaction/selection.h: GrowthEngine).
#include <cstdint>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "interaction/selection.h"
#include "render/volume_renderer.h"

namespace handson {

/// Grows pinches on the GPU through the renderer's live selection. Its box is what a selection can
/// reach (growReach) at twice the extent (at least kMinBoxExtentMm), clipped to the volume; when the
/// fingers spread past it, growth begins again from the seed in the box for twice the new extent
/// (the keys are recomputed, so the selection is the same; the frames keep showing the selection
/// as it was until the new box has grown that far, then show it growing on). A call
/// that fails (handson::Error) stops the engine: later calls of this pinch throw the same error.
class GpuGrowthEngine : public GrowthEngine {
 public:
  static constexpr double kMinBoxExtentMm = 20.0;
  GpuGrowthEngine(VolumeRenderer& renderer, const QuantizedVolume& volume, const std::vector<std::uint8_t>& mask);

  void start(const RegionGrower& reference) override;
  void show(std::uint32_t bound, double extentMm) override;
  std::vector<std::uint32_t> finish() override;

  /// The handles under the pinch changed (the mask given at construction): the box's ids anew.
  /// Throws (and stops) as the calls above do.
  void rebase();
  /// Ends a pinch growing now without a result (the controller going away).
  void cancel();
  bool growing() const { return growing_; }
  /// The box the live selection painted since the last call (first voxel, dims), for the caller to
  /// repaint with its own ids once the pinch ended; nullopt when none.
  std::optional<std::pair<Eigen::Vector3i, Eigen::Vector3i>> takePaintedBox() { return std::exchange(painted_, std::nullopt); }

 private:
  void beginBox(double extentMm);
  /// Runs `call`; if it throws, the engine stops (growing() false, the renderer's live selection
  /// ended) and the error goes on to the pinch, which grows on the CPU from there.
  template <class Call> auto orStop(Call&& call);
  void checkGrowing() const;
  std::vector<std::uint8_t> baseIds() const;

  VolumeRenderer& renderer_;
  const QuantizedVolume& volume_;
  const std::vector<std::uint8_t>& mask_;  // the caller's CPU copy of the handle-id mask
  GrowSetup setup_{};
  Eigen::Vector3i boxMin_{0, 0, 0}, boxDims_{0, 0, 0};
  double boxExtent_ = 0.0;  // the largest extent the box holds (infinite once it is the volume)
  std::uint32_t shown_ = 0;  // the last bound shown in the box (0: none yet)
  bool growing_ = false;
  std::string failure_;  // why the engine stopped ("" if it did not)
  std::optional<std::pair<Eigen::Vector3i, Eigen::Vector3i>> painted_;
};

}  // namespace handson
