#include "replay.h"

#include <algorithm>
#include <Eigen/Geometry>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iomanip>
#include <iostream>
#include <optional>

#include "app/io/nifti_io.h"
#include "app/io/png_io.h"
#include "app/io/volume_io.h"
#include "app/session/console.h"
#include "app/session/frame_driver.h"
#include "app/session/latency_log.h"
#include "app/session/selection_controller.h"
#include "app/session/session.h"
#include "app/session/session_export.h"
#include "app/session/session_recovery.h"
#include "interaction/camera.h"
#include "render/render_params.h"
#include "render/transfer_function.h"
#include "render/vk_context.h"
#include "render/volume_renderer.h"
#include "scripts/demo_script.h"
#include "scripts/scenario_full_session.h"
#include "sim/error.h"
#include "sim/phantom.h"

namespace handson {

namespace {

// Through the last event, plus one; a camera still moving then (a framing) adds the frames it
// takes to settle, so that the replay ends where the session comes to rest.
int framesToRest(const SessionScript& script, double fps) {
  double end = script.duration();
  for (const ScriptEvent& e : script.events)
    if (!e.isTouch && (e.action == "frame-clip" || e.action == "camera-back")) end = std::max(end, e.t + Session::kFramingSeconds);
  return int(std::floor(end * fps)) + 2;
}
using Clock = std::chrono::steady_clock;
double seconds(Clock::time_point t, Clock::time_point t0) { return std::chrono::duration<double>(t - t0).count(); }

// Options refused before the replay's work, not after it.
void checkReplayOptions(const ReplayOptions& o) {
  if (!(o.fps > 0.0 && o.fps <= 1000.0)) throw Error("--fps must be in (0, 1000]");
  if (!o.exportPath.empty()) {
    const std::filesystem::path dir = std::filesystem::absolute(o.exportPath).parent_path();
    std::error_code ec;
    if (!std::filesystem::is_directory(dir, ec)) throw Error("--export: the directory '" + dir.string() + "' does not exist");
  }
}

// --export: the deformed volume (the input where nothing was simulated, with a note).
void writeDeformedVolume(const DeformationController& deform, const Volume& volume, const std::string& path) {
  Volume deformed;
  if (!deform.exportDeformed(deformed)) {
    std::cerr << "note: no simulated deformation to export (no moved active handle, or --sim off): writing the input unchanged\n";
    deformed = volume;
  }
  writeNifti(deformed, path);
  std::cout << "wrote " << path << "\n";
}

// The volume: --volume, else the script's (a relative path is tried as given, then beside the script).
Volume loadReplayVolume(const ReplayOptions& o, const SessionScript& script, const ProgressFn& progress) {
  Volume volume;
  std::string source = o.volume;
  if (source.empty() && script.volumeSource == "file") {
    source = script.volumePath;
    if (!std::filesystem::exists(source) && !o.script.empty()) {
      const auto beside = std::filesystem::path(o.script).parent_path() / script.volumePath;
      if (std::filesystem::exists(beside)) source = beside.string();
    }
  }
  if (source.empty() || source == "phantom") {
    volume = makePhantom().ct;
  } else {
    LoadReport rep;
    volume = loadVolume(source, &rep, progress);
    for (const auto& w : rep.warnings) std::cerr << "warning: " << w << "\n";
  }
  return volume;
}

// --print-handles: each handle's state, pose and how far its centre moved.
void printHandlePoses(const SelectionController& selection, const Volume& volume) {
  for (const auto& h : selection.handles().handles()) {
    const Eigen::AngleAxisd aa(h.pose.R);
    std::cout << "handle " << h.id << " " << handleStatusName(h.status) << " " << h.voxels.size() << " voxels"
              << (std::find(selection.picked().begin(), selection.picked().end(), h.id) != selection.picked().end() ? " picked" : "")
              << " translation " << h.pose.t.x() << "," << h.pose.t.y() << "," << h.pose.t.z() << " rotation_deg "
              << aa.angle() * 180.0 / M_PI << " axis " << aa.axis().x() << "," << aa.axis().y() << "," << aa.axis().z();
    // How far the handle's centre moved (the pose's translation also holds the rotation's lever).
    Eigen::Vector3d c = Eigen::Vector3d::Zero();
    const Eigen::Vector3i d = volume.dims();
    for (std::uint32_t v : h.voxels)
      c += volume.geometry().toWorld(Eigen::Vector3d(double(v % std::uint32_t(d.x())), double(v / std::uint32_t(d.x()) % std::uint32_t(d.y())),
                                                     double(v / (std::uint32_t(d.x()) * std::uint32_t(d.y())))));
    if (!h.voxels.empty()) c /= double(h.voxels.size());
    std::cout << " centre_moved_mm " << (h.pose.apply(c) - c).norm() << "\n";
  }
}

// --print-handles: the handles, then the clip and the window where they are set.
void printSessionState(const SelectionController& selection, const Session& session, const Volume& volume) {
  printHandlePoses(selection, volume);
  const ClipRegion& clip = session.clip();
  if (clip.box) std::cout << "clip box " << formatClipBox(clip) << "\n";
  if (clip.plane) std::cout << "clip plane " << formatClipPlane(clip) << "\n";
  const WindowLevel& w = session.window();
  if (!w.identity()) std::cout << "window " << session.preset() << " scale " << w.scale << " shift " << w.shift << " opacity " << w.opacity << "\n";
}

// False (with a message) where the camera, the clip region, the window or a handle's pose holds a
// non-finite number.
bool stateIsFinite(const Session& session, const SelectionController& selection) {
  bool finite = true;
  const OrbitCamera& c = session.camera();
  if (!std::isfinite(c.distance) || !std::isfinite(c.azimuth) || !std::isfinite(c.elevation) || !std::isfinite(c.roll) ||
      !std::isfinite(c.fovY) || !std::isfinite(c.target.x) || !std::isfinite(c.target.y) || !std::isfinite(c.target.z)) {
    std::cerr << "error: the camera holds a non-finite number: " << describeCamera(c) << "\n";
    finite = false;
  }
  const ClipRegion& clip = session.clip();
  const WindowLevel& w = session.window();
  auto finite3 = [](const glm::vec3& v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); };
  if (!finite3(clip.lo) || !finite3(clip.hi) || !finite3(clip.normal) || !std::isfinite(clip.offset) || !std::isfinite(w.scale) ||
      !std::isfinite(w.shift) || !std::isfinite(w.opacity)) {
    std::cerr << "error: the clip region or the window holds a non-finite number\n";
    finite = false;
  }
  for (const auto& h : selection.handles().handles())
    if (!h.pose.R.allFinite() || !h.pose.t.allFinite()) {
      std::cerr << "error: handle " << h.id << "'s pose holds a non-finite number\n";
      finite = false;
    }
  return finite;
}

// DIR/frame_NNNNN.png; a frame the budget drew smaller is written at the full size, as the window
// shows it.
void writeFrame(const std::string& dir, int k, const FrameResult& r, const Viewport& vp) {
  char name[32];
  std::snprintf(name, sizeof(name), "frame_%05d.png", k);
  const std::string path = (std::filesystem::path(dir) / name).string();
  if (r.width == vp.width && r.height == vp.height) writePng(path, r.width, r.height, r.rgba);
  else writePng(path, vp.width, vp.height, upscaleRgba(r.rgba, r.width, r.height, vp.width, vp.height));
}

}  // namespace

SessionScript builtInDemoScript() { return parseSessionScript(kOrbitAndZoomScript, "built-in orbit-and-zoom script"); }
SessionScript builtInFullSessionScript() { return parseSessionScript(kScenario_full_session, "built-in full-session script"); }

// The timing log's header: where a headless replay's times come from.
const std::vector<std::string> kReplayLogNotes = {
    "clock: seconds since the replay started on the steady clock",
    "headless replay: input times are when each scripted event was applied; no window, so present_s is when the frame's results were "
    "read back and displayed_s is -1"};

int runReplay(const ReplayOptions& o) {
  checkReplayOptions(o);
  SessionScript script = o.scriptData ? *o.scriptData : o.script.empty() ? builtInDemoScript() : readSessionScript(o.script);
  const ProgressFn progress = o.quiet ? ProgressFn{} : consoleProgress();

  Volume volume = loadReplayVolume(o, script, progress);
  const std::optional<LabelMap> labels = o.labels.empty() ? std::nullopt : std::optional<LabelMap>(loadLabelMap(o.labels, volume.geometry()));

  // Output size; touches recorded in the script's viewport are scaled to it.
  Viewport vp = script.viewport;
  if (o.width > 0 && o.height > 0) vp = {o.width, o.height};
  const glm::dvec2 touchScale(double(vp.width) / script.viewport.width, double(vp.height) / script.viewport.height);

  vk::ContextOptions co;
  co.validation = o.validation;
  co.device = o.device;
  co.verbose = !o.quiet;
  vk::Context ctx(co);
  const QuantizedVolume q = quantizeVolume(volume);
  VolumeRenderer renderer(ctx);
  renderer.setVolume(q, progress);

  Session session(volume.geometry(), vp, script.preset.empty() ? defaultPresetFor(volume) : script.preset);
  if (script.freeArea) {
    session.setFreeArea(*script.freeArea);  // reset-camera frames where the recording app did
    if (!script.camera) session.resetCamera();
  }
  if (script.camera) script.camera->applyTo(session.camera());
  session.apply(ScriptEvent{0.0, false, {}, "set-mode", script.mode});
  renderer.setTransferFunction(transferFunctionPreset(session.preset()).lookupTable(q));
  GrowParams grow;
  grow.boundaryRim = o.selectionRim;
  grow.bound = o.selectionBound;
  SelectionController selection(q, session, renderer, grow, o.selectionBackend);
  selection.setCorrectionRule(o.selectionCorrections);
  if (!o.quiet) std::cerr << selection.backend().status << "\n";
  if (labels) {
    selection.setLabels(&*labels);
    renderer.setLabels(labels->labels);
    session.setLabelTint(true);
  }
  DeformationController deform(volume, q, renderer, o.sim);
  FrameDriver driver(volume, q, session, renderer, selection, deform);
  driver.setFrameBudget(o.frameBudgetMs);
  // Everything applied is recorded: an "export" action writes the session so far as a script.
  {
    SessionScript header = script;
    if (!o.volume.empty()) {
      header.volumeSource = o.volume == "phantom" ? "phantom" : "file";
      header.volumePath = o.volume == "phantom" ? "" : o.volume;
    }
    session.startRecording(header);
  }
  SessionExport exporter(o.exportDir, volume, o.exportExtension);
  session.addUiExtension([&](const ScriptEvent& e) { return exporter.onUi(e); });
  std::string simStatus;
  if (!o.framesOut.empty()) {
    std::error_code ec;
    std::filesystem::create_directories(o.framesOut, ec);
    if (ec || !std::filesystem::is_directory(o.framesOut)) throw Error("cannot create the frames directory '" + o.framesOut + "'");
  }

  if (o.frames < 0) throw Error("the number of frames must not be negative");
  const int frames = o.frames > 0 ? o.frames : framesToRest(script, o.fps);
  std::size_t next = 0, refused = 0;
  LatencyLog log(o.timings.empty() ? kSummaryFrames : 0);  // bounded unless the whole log is to be written
  log.setNotes(kReplayLogNotes);
  // A failure under the session (a Vulkan allocation, a lost device, running out of memory) ends
  // the replay with the session so far saved beside the exports.
  auto rescue = [&] { return saveRecovery(session, selection.handles(), selection.picked(), volume.dims(), o.exportDir); };
  try {
    const auto t0 = Clock::now();
    for (int k = 0; k < frames; ++k) {
      const double frameTime = k / o.fps;
      FrameTiming ft;
      ft.cpuStart = seconds(Clock::now(), t0);
      while (next < script.events.size() && script.events[next].t <= frameTime) {
        ScriptEvent e = script.events[next++];
        e.touch.px *= touchScale;
        const double now = seconds(Clock::now(), t0);
        if (!session.apply(e)) {
          ++refused;
          if (!o.quiet)
            std::cerr << "refused at t=" << e.t << " s: "
                      << (e.isTouch ? "touch " + std::string(touchPhaseName(e.touch.phase)) + " id " + std::to_string(e.touch.id) : e.action + " " + e.value)
                      << "\n";
        }
        if (ft.inputFirst < 0) ft.inputFirst = now;
        ft.inputLast = now;
        ++ft.inputCount;
      }
      session.advance(frameTime);  // a framing's camera move, on the script's clock
      driver.refreshTransferFunction();
      FrameRequest req = driver.request(vp, vp.width, vp.height);
      req.readbackImage = !o.framesOut.empty() || exporter.pending();
      driver.attachSimulation(req, true);
      if (const std::string st = deform.status(); !o.quiet && st != simStatus) {
        simStatus = st;
        if (!st.empty()) std::cerr << st << "\n";
      }
      // The simulation refused a pose, stopped without converging or failed to build: the
      // session goes on (the last good state shows), and what was done so far is saved.
      if (driver.newFailure()) std::cerr << "warning: " << deform.status() << "\n  " << rescue() << "\n";
      driver.attachSelection(req, vp, ft);
      const FrameQuality quality = driver.applyFrameBudget(req, ft.inputCount > 0, exporter.pending());
      ft.qualityScale = quality.scale;
      ft.qualityStep = quality.stepScale;
      ft.cpuEnd = seconds(Clock::now(), t0);
      driver.submit(req);
      ft.stillPhases = driver.stillPhases();
      ft.submit = seconds(Clock::now(), t0);
      const auto w0 = Clock::now();
      const FrameResult r = renderer.waitLast();
      for (const auto& older : renderer.takeCompleted()) driver.completed(older);
      driver.completed(r);
      if (exporter.pending()) std::cout << exporter.write(session, selection.handles(), selection.picked(), deform, r) << "\n";
      ft.present = seconds(Clock::now(), t0);
      ft.waitMs = seconds(Clock::now(), w0) * 1e3;
      ft.frame = r.frame;
      for (const auto& p : r.timings) ft.gpuMs.emplace_back(p.name, p.gpuMs);
      driver.recordSimulation(ft);
      if (!o.framesOut.empty()) writeFrame(o.framesOut, k, r, vp);
      log.add(ft);
      if (o.afterFrame) o.afterFrame(k, frames, ctx.validationMessageCount());
      reportProgress(progress, double(k + 1) / frames, "replaying");
    }
    if (!o.timings.empty()) log.writeCsv(o.timings);
    if (!o.exportPath.empty()) writeDeformedVolume(deform, volume, o.exportPath);  // every frame was waited for above
  } catch (const std::bad_alloc&) {
    throw Error("out of memory during the replay; " + rescue());
  } catch (const std::exception& e) {
    throw Error(std::string(e.what()) + "; " + rescue());
  }
  if (!o.quiet) {
    std::cerr << "replayed " << script.events.size() << " events";
    if (refused) std::cerr << " (" << refused << " refused)";
    std::cerr << " in " << frames << " frames at " << o.fps << " fps on " << ctx.summary().name << "\n" << log.summary() << "\n";
  }
  if (!o.framesOut.empty()) std::cout << "wrote " << frames << " frames to " << o.framesOut << "\n";
  if (o.printCamera) std::cout << describeCamera(session.camera()) << "\n";
  if (o.printHandles) printSessionState(selection, session, volume);
  // Whatever came in, no state may hold a non-finite number.
  if (!stateIsFinite(session, selection)) return 1;
  if (ctx.validationMessageCount() > 0) {
    std::cerr << "error: " << ctx.validationMessageCount() << " Vulkan validation message(s)\n";
    return 1;
  }
  return 0;
}

}  // namespace handson
