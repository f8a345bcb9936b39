#pragma once
// The "export" UI action ({"ui": "export"} in a session script; the Export button in the app):
// everything a user would keep from a session, into a directory, numbered per export:
//   session-NN.json     the session so far as a replayable script (every applied event)
//   handles-NN.json     the handles: voxels, status and pose of each (app/session/session_recovery.h)
//   deformed-NN.nii.gz  the volume as shown (the simulated deformation on the input's grid and
//                       value type; the input unchanged when nothing is simulated)
//   mesh-NN.vtu         the simulated fine mesh with its displacements (only when simulated)
//   forces-NN.json      each simulated handle's reaction force and torque (app/io/forces_json.h)
//   strain-NN.nii.gz    the strain as shown on the input's grid (sim/strain.h)
//   screenshot-NN.png   the rendered image of the frame after the request (no UI overlay)
// (deformed and strain are .nrrd or .mha instead when the export is made with that extension.)
// Every file is written atomically (a failure never leaves a partial file), numbering continues
// after the exports already in the directory (nothing is overwritten), and a failed export is
// reported without ending the session.
#include <filesystem>
#include <string>
#include <vector>

#include "app/session/deformation_controller.h"
#include "app/session/session.h"
#include "interaction/handles.h"
#include "render/volume_renderer.h"
#include "sim/volume.h"

namespace handson {

class SessionExport {
 public:
  /// `dir` is created at the first export. `input` must outlive this.
  /// `volumeExtension`: the volumes' format, told by it (writeVolume): ".nii.gz" (NIfTI, the
  /// default), ".nrrd" or ".mha".
  SessionExport(std::filesystem::path dir, const Volume& input, std::string volumeExtension = ".nii.gz")
      : dir_(std::move(dir)), input_(input), volumeExtension_(std::move(volumeExtension)) {}

  /// The session extension for the "export" action: marks an export as pending.
  bool onUi(const ScriptEvent& e);
  bool pending() const { return pending_; }
  /// Writes the pending export from a finished frame that carries its image (request readback for
  /// it); returns a one-line summary (or the failure). Clears the pending flag either way.
  std::string write(const Session& session, const HandleSet& handles, const std::vector<int>& picked,
                    const DeformationController& deform, const FrameResult& frame);
  int count() const { return count_; }
  const std::filesystem::path& dir() const { return dir_; }

 private:
  std::filesystem::path dir_;
  const Volume& input_;
  std::string volumeExtension_;
  bool pending_ = false;
  int count_ = 0;  ///< exports written by this session
  int next_ = 0;   ///< the number of the last export in the directory
};

}  // namespace handson
