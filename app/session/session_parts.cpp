#include "app/session/session_parts.h"

#include <iostream>

#include "interaction/label_map.h"

namespace handson {

SessionParts makeSessionParts(const SessionOptions& o, const Volume& volume, const QuantizedVolume& q, Session& session, VolumeRenderer& renderer,
                              const LabelMap* labels) {
  SessionParts p;
  p.selection = std::make_unique<SelectionController>(q, session, renderer, growParams(o), o.selectionBackend);
  p.selection->setCorrectionRule(o.selectionCorrections);
  if (!o.quiet) std::cerr << p.selection->backend().status << "\n";
  p.selection->setLabels(labels);
  if (labels) {
    renderer.setLabels(labels->labels);
    session.setLabelTint(true);
  }
  p.deform = std::make_unique<DeformationController>(volume, q, renderer, o.sim);
  p.exporter = std::make_unique<SessionExport>(o.exportDir, volume, o.exportExtension);
  SessionExport* exporter = p.exporter.get();
  session.addUiExtension([exporter](const ScriptEvent& e) { return exporter->onUi(e); });
  return p;
}

}  // namespace handson
