#pragma once
// The simulated user of interactive segmentation (the protocol of the CVPR 2025 3D interactive
// segmentation challenge and of the NoC metrics): a first pinch at the organ's deepest voxel spread
// to its radius, then each correction at the deepest voxel of the largest error region - missed
// organ: a pinch united with the selection; leaked tissue: a pinch subtracted from it - spread to
// that region's radius. Every pinch runs the app's own PinchSelection (its seed snapping, its extent
// from the fingers' spread, its boundary rim) and every correction the app's Add or Remove pinch
// (interaction/selection_edit.h: applyPinch), so the figures are the app's. Design:
// docs/selection-corrections.md.
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "app/tools/selection_eval.h"
#include "interaction/region_grow.h"
#include "interaction/selection_edit.h"
#include "sim/quantized_volume.h"
#include "sim/volume.h"

namespace handson {

/// A connected region of voxels (26-connected), its deepest voxel (the farthest, in mm, from any
/// voxel outside it: the maximum of its exact Euclidean distance transform; the lowest index on
/// ties) and its spread (the 95th percentile of its voxels' distances in mm from that voxel, at
/// least the grid's smallest spacing).
struct GestureTarget {
  std::vector<std::uint32_t> voxels;  ///< linear indices on the volume's grid, ascending
  Eigen::Vector3i deepest{-1, -1, -1};
  double depthMm = 0.0, spreadMm = 0.0;
};

/// The largest 26-connected region of organ voxels not selected (missed) or selected voxels not of
/// the organ (leaked); `missed` says which. Empty voxels when the selection is the organ.
/// `organ` and `selected` are masks on `g` (x-fastest, nonzero = in).
struct ErrorRegion {
  bool missed = true;
  GestureTarget target;
};
ErrorRegion largestErrorRegion(const std::vector<std::uint8_t>& organ, const std::vector<std::uint8_t>& selected, const VolumeGeometry& g);

/// Deepest voxel and spread of a set of voxels (any shape; one region is expected).
GestureTarget gestureTarget(std::vector<std::uint32_t> voxels, const VolumeGeometry& g);

enum class GestureKind : std::uint8_t { First, Add, Remove };
const char* gestureKindName(GestureKind k);

/// One gesture of the protocol and the selection after it.
struct GestureStep {
  int gesture = 0;  ///< 1-based
  GestureKind kind = GestureKind::First;
  Eigen::Vector3i target{-1, -1, -1};  ///< where the pinch was placed (before the app's seed snapping)
  double spreadMm = 0.0;
  std::size_t regionVoxels = 0;  ///< the error region it corrects (the organ for the first)
  std::size_t pinchVoxels = 0;   ///< what the pinch grew
  bool refused = false;          ///< the app refused the edit (a difference that would leave nothing)
  std::size_t selected = 0;
  double dice = 0.0, precision = 0.0, recall = 0.0;
  double milliseconds = 0.0;  ///< the gesture: the pinch's growth and the handle edit
  double editMs = 0.0;        ///< a correction's edit: the pinch's voxels sorted and rimmed, the union or difference
  std::size_t uploadVoxels = 0;  ///< the mask's box the edit uploads (the box of the voxels whose id changed)
  double liftMs = 0.0;        ///< the pinch's fingers lifted (the frame's thread; its voxels are finished in the edit)
  double editFrameMs = 0.0;   ///< of it, the window's frame thread's part: the handles copied, the edit taken in and painted
};

struct OrganGestures {
  std::string dataset, organ;
  std::size_t organVoxels = 0;
  std::vector<GestureStep> steps;  ///< at most `gestures`; fewer when the selection became the organ
};

struct GestureProtocol {
  int gestures = 10;  ///< the first pinch and up to gestures - 1 corrections
  GrowParams params;  ///< the app's pinch rules
  CorrectionRule corrections = CorrectionRule::Neck;  ///< the app's rule for handle-union and handle-difference
};

/// Runs the protocol on one labelled organ (labels on the CT's grid; `q` the CT quantized as the
/// app holds it). An organ missing from the label map gives no steps.
OrganGestures runGestureProtocol(const std::string& dataset, const Volume& ct, const QuantizedVolume& q, const Volume& labels,
                                 const OrganLabel& organ, const GestureProtocol& protocol);

}  // namespace handson
