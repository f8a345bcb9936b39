#include "session_export.h"

#include <algorithm>
#include <cstdio>
#include <sstream>

#include "app/io/forces_json.h"
#include "app/io/png_io.h"
#include "app/io/volume_io.h"
#include "app/session/session_recovery.h"
#include "app/session/session_script.h"

namespace handson {

bool SessionExport::onUi(const ScriptEvent& e) {
  if (e.action != UiAction::Export) return false;
  pending_ = true;
  return true;
}

std::string SessionExport::write(const Session& session, const HandleSet& handles, const std::vector<int>& picked,
                                 const DeformationController& deform, const FrameResult& frame) {
  pending_ = false;
  if (count_ == 0) {
    // Continue after the exports already in the directory (an earlier session's, or the one this
    // replay is playing): never overwrite them.
    std::error_code ec;
    for (const auto& e : std::filesystem::directory_iterator(dir_, ec)) {
      const std::string n = e.path().filename().string();
      int k = 0;
      if (std::sscanf(n.c_str(), "session-%d.json", &k) == 1 || std::sscanf(n.c_str(), "deformed-%d.", &k) == 1 ||
          std::sscanf(n.c_str(), "screenshot-%d.png", &k) == 1 || std::sscanf(n.c_str(), "mesh-%d.vtu", &k) == 1 || std::sscanf(n.c_str(), "forces-%d.json", &k) == 1 ||
          std::sscanf(n.c_str(), "strain-%d.", &k) == 1 ||
          std::sscanf(n.c_str(), "handles-%d.json", &k) == 1)
        next_ = std::max(next_, k);
    }
  }
  ++next_;
  char tag[16];
  std::snprintf(tag, sizeof tag, "%02d", next_);
  auto path = [&](const char* stem, const char* ext) { return (dir_ / (std::string(stem) + "-" + tag + ext)).string(); };
  std::ostringstream summary;
  try {
    std::error_code ec;
    std::filesystem::create_directories(dir_, ec);
    if (!std::filesystem::is_directory(dir_)) return "export failed: cannot create the directory '" + dir_.string() + "'";
    writeSessionScript(session.script(), path("session", ".json"));
    writeHandles(handles, picked, input_.dims(), path("handles", ".json"));
    Volume shown;
    const bool simulated = deform.exportDeformed(shown);
    const char* volumeExt = volumeExtension_.c_str();
    writeVolume(simulated ? shown : input_, path("deformed", volumeExt));
    const bool mesh = simulated && deform.exportMeshAndStrain(path("mesh", ".vtu"), path("strain", volumeExt));
    const bool strain = mesh;
    const auto reactions = deform.shownReactions();
    const bool forces = simulated && !reactions.empty();
    if (forces) {
      std::vector<HandleReaction> r;
      std::vector<int> ids;
      for (const auto& [id, rr] : reactions) {
        ids.push_back(id);
        r.push_back(rr);
      }
      writeForcesJson(path("forces", ".json"), r, deform.modelState(), ids);
    }
    const bool image = !frame.rgba.empty();
    if (image) writePng(path("screenshot", ".png"), frame.width, frame.height, frame.rgba);
    ++count_;
    summary << "exported to " << dir_.string() << ": session-" << tag << ".json (" << session.script().events.size() << " events), handles-" << tag << ".json ("
            << handles.handles().size() << "), deformed-" << tag
            << volumeExt << (simulated ? "" : " (nothing simulated: the input)") << (mesh ? std::string(", mesh-") + tag + ".vtu" : "") << (forces ? std::string(", forces-") + tag + ".json" : "") << (strain ? std::string(", strain-") + tag + volumeExt : "")
            << (image ? std::string(", screenshot-") + tag + ".png" : "");
  } catch (const std::exception& e) {
    return std::string("export failed: ") + e.what();
  }
  return summary.str();
}

}  // namespace handson
