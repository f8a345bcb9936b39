#pragma once
// What a running session is made of beside its Session and renderer: the selection, the simulation
// and the exporter, set up from the session's options in the one order the window and the replay
// share (labels before the controllers use them, the exporter as the session's "export" action).
#include <memory>

#include "app/session/deformation_controller.h"
#include "app/session/selection_controller.h"
#include "app/session/session_export.h"
#include "app/session/session_options.h"

namespace handson {

struct LabelMap;

struct SessionParts {
  std::unique_ptr<SelectionController> selection;
  std::unique_ptr<DeformationController> deform;
  std::unique_ptr<SessionExport> exporter;
};

/// The parts of a session over `volume` (its quantized copy `q` on `renderer`); `labels` (may be
/// null) tints the organs and answers taps. Everything passed must outlive the parts.
SessionParts makeSessionParts(const SessionOptions& o, const Volume& volume, const QuantizedVolume& q, Session& session, VolumeRenderer& renderer,
                              const LabelMap* labels);

}  // namespace handson
