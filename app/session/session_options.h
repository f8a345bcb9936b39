#pragma once
// The options of a running session, shared by the window (`handson view`, app/platform/viewer.h)
// and the headless replay (`handson replay`, app/session/replay.h): each mode's options derive from
// these and add their own few. Parsed once (app/cli/session_commands.cpp); every default is the
// field's initializer here.
#include <cstdint>
#include <string>

#include "app/session/deformation_controller.h"
#include "app/session/selection_backend.h"
#include "interaction/region_grow.h"
#include "interaction/selection_edit.h"

namespace handson {

struct SessionOptions {
  /// The volume (NIfTI, NRRD, MetaImage or a DICOM directory). Empty: the built-in phantom in the
  /// window; the script's own volume in a replay.
  std::string volume;
  std::int64_t volumeFrame = 0;  ///< the volume of a 4D NIfTI image
  std::string labels;            ///< organ labels for taps and label-handle actions (empty: none)
  SelectionBackend selectionBackend = SelectionBackend::Auto;  ///< where pinches grow (app/session/selection_backend.h)
  bool selectionRim = true;  ///< finished pinches end with their boundary rim (GrowParams::boundaryRim)
  GrowBound selectionBound = GrowParams{}.bound;  ///< how the fingers' extent bounds growth (GrowParams::bound)
  CorrectionRule selectionCorrections = CorrectionRule::Neck;  ///< handle-union and handle-difference (interaction/selection_edit.h)
  DeformationOptions sim;        ///< the simulation of moved handles
  std::string device;            ///< the Vulkan device by name (empty: the first suitable)
  bool validation = false;       ///< the Khronos validation layer on (any message fails the run)
  bool quiet = false;
  bool printCamera = false;      ///< print the final camera (tests, scripting)
  std::string timings;           ///< latency log CSV (empty: none)
  std::string exportDir = "handson-export";  ///< where export actions write (app/session/session_export.h)
  std::string exportExtension = ".nii.gz";   ///< the exported volumes' format: ".nii.gz", ".nrrd" or ".mha"
  int frames = 0;                ///< frames to render; 0: the mode's own end (the window closed, the script played)
};

/// Region growing's parameters as the options set them.
inline GrowParams growParams(const SessionOptions& o) {
  GrowParams grow;
  grow.boundaryRim = o.selectionRim;
  grow.bound = o.selectionBound;
  return grow;
}

}  // namespace handson
