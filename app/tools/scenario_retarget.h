#pragma once
// Re-aims a gesture script recorded on one volume at an organ of another, so that the paper's
// scenarios (assets/gestures) run on any labelled CT: the touches stay where they were on the
// screen; the camera is chosen so that they land on the organ there. Among view directions around
// the organ (azimuth every 30 degrees, elevation 0 and +-25), the camera keeps the script's distance
// and field of view (its target in the plane through the volume's centre) and puts the organ's
// deepest voxel (app/tools/selection_eval.h) under the script's
// first pinch; each touch-down is depth-picked with the CPU reference of the pick pass (the
// script's transfer-function preset) and the direction whose picks land on the organ most often
// wins (ties: the one nearest the script's own direction). Used by the benchmark suite's real-CT
// scenes and by `handson retarget`.
#include <string>
#include <vector>

#include "app/session/session_script.h"
#include "render/raymarch_reference.h"
#include "render/render_params.h"
#include "sim/quantized_volume.h"
#include "sim/volume.h"

namespace handson {

/// Depth picks on the CPU (the pick pass's reference, render/raymarch_reference.h) of one volume
/// under a transfer-function preset ("" : the volume's default), with the label under each pick.
class CpuPicker {
 public:
  CpuPicker(const Volume& ct, const std::string& preset);
  /// One result per pixel (viewport pixels, y down) seen through `cam`; with a handle-id mask on the
  /// CT's grid, each hit's voxel.w is the handle there (as the app's picks), else 0; `moving`: handles
  /// drawn moved rigidly (as the app draws them while they are being dragged).
  std::vector<gpu::PickResult> pick(const OrbitCamera& cam, const Viewport& viewport, const std::vector<glm::dvec2>& pixels,
                                    const std::vector<std::uint8_t>* handleMask = nullptr,
                                    const std::vector<MovingHandlePose>& moving = {}) const;
  /// Picks from here on respect this clip region (as the app's picks respect the session's clip).
  void setClip(const ClipRegion& clip) { clip_ = clip; }
  const ClipRegion& clip() const { return clip_; }
  /// The label map's value at a pick (labels on the CT's grid); -1 for a miss, NaN or a voxel outside.
  int labelAt(const gpu::PickResult& hit, const Volume& labels) const;
  const std::string& preset() const { return preset_; }
  const QuantizedVolume& volume() const { return q_; }

 private:
  const Volume& ct_;
  std::string preset_;
  QuantizedVolume q_;
  TfTable lut_;
  std::vector<std::uint32_t> occupancy_;
  ClipRegion clip_;
};

struct RetargetedScript {
  SessionScript script;  ///< the input with its camera (and volume) replaced
  int touchDowns = 0;    ///< touch-downs in the script (distinct positions)
  int onOrgan = 0;       ///< of which land on the organ under the chosen camera
  int pinchTouches = 0, pinchOnOrgan = 0;  ///< the same for the first pinch's two fingers
  double azimuthDeg = 0.0, elevationDeg = 0.0;
};

/// `labels` on any grid in the same world space as `ct` (voxels of `label` mark the organ).
/// `volumePath`: what the new script names as its volume ("" keeps the script's).
/// Throws Error when the label is absent, the script has no two-finger pinch, or no direction
/// puts both of the pinch's fingers on the organ.
RetargetedScript retargetScript(const SessionScript& script, const Volume& ct, const Volume& labels, int label, const std::string& volumePath);

}  // namespace handson
