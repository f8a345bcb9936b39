#include "gpu_growth.h"

#include <algorithm>
#include <limits>

#include "sim/base/error.h"

namespace handson {

GpuGrowthEngine::GpuGrowthEngine(VolumeRenderer& renderer, const QuantizedVolume& volume, const std::vector<std::uint8_t>& mask)
    : renderer_(renderer), volume_(volume), mask_(mask) {}

std::vector<std::uint8_t> GpuGrowthEngine::baseIds() const {
  return maskBox(mask_, volume_.geometry.dims, boxMin_, boxDims_).ids;
}

void GpuGrowthEngine::beginBox(double extentMm) {
  const Eigen::Vector3d spacing = volume_.geometry.spacing;
  const Eigen::Vector3i& dims = volume_.geometry.dims;
  const double e = std::max(2.0 * extentMm, kMinBoxExtentMm);
  const Eigen::Vector3i reach = growReach(setup_.criterion, setup_.bound, e, spacing) + Eigen::Vector3i::Ones();
  const Eigen::Vector3i lo = (setup_.seed - reach).cwiseMax(Eigen::Vector3i::Zero());
  const Eigen::Vector3i hi = (setup_.seed + reach).cwiseMin(dims - Eigen::Vector3i::Ones());
  boxMin_ = lo;
  boxDims_ = hi - lo + Eigen::Vector3i::Ones();
  boxExtent_ = boxDims_ == dims ? std::numeric_limits<double>::infinity() : e;
  renderer_.beginLiveSelection(setup_, boxMin_, boxDims_, baseIds(), shown_);  // the new box holds what was shown
  painted_ = std::make_pair(boxMin_, boxDims_);  // a larger box (same seed) holds the smaller one it replaces
}

template <class Call> auto GpuGrowthEngine::orStop(Call&& call) {
  try {
    return call();
  } catch (const Error& e) {
    // The pinch goes on with the CPU reference (interaction/selection.h): no live selection left
    // on the GPU, and the box it painted is repainted by the controller (takePaintedBox).
    growing_ = false;
    failure_ = e.what();
    try {
      renderer_.endLiveSelection();
    } catch (const Error&) {  // nothing left to end on a lost device
    }
    throw;
  }
}

void GpuGrowthEngine::start(const RegionGrower& reference) {
  setup_ = reference.setup();
  growing_ = true;
  failure_.clear();
  boxExtent_ = -1.0;  // the first show() begins the box, sized for its extent
  shown_ = 0;
}

void GpuGrowthEngine::checkGrowing() const {
  if (!growing_) throw Error(failure_.empty() ? "GPU selection: no pinch is growing (start() first)" : failure_);
}

void GpuGrowthEngine::show(std::uint32_t bound, double extentMm) {
  checkGrowing();
  orStop([&] {
    if (!(extentMm <= boxExtent_)) beginBox(extentMm);  // NaN never reaches here (the pinch drops it)
    renderer_.setLiveSelectionBound(bound);
    shown_ = bound;
  });
}

std::vector<std::uint32_t> GpuGrowthEngine::finish() {
  checkGrowing();
  std::vector<std::uint32_t> voxels = orStop([&] { return renderer_.finishLiveSelection(); });
  growing_ = false;
  return voxels;
}

void GpuGrowthEngine::rebase() {
  if (growing_ && boxExtent_ >= 0.0) orStop([&] { renderer_.setLiveSelectionBase(baseIds()); });
}

void GpuGrowthEngine::cancel() {
  if (!growing_) return;
  growing_ = false;
  renderer_.endLiveSelection();
}

}  // namespace handson
