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
#include "app/session/session_parts.h"
#include "app/session/session_recovery.h"
#include "interaction/camera.h"
#include "render/render_params.h"
#include "render/transfer_function.h"
#include "render/vk_context.h"
#include "render/volume_renderer.h"
#include "scripts/demo_script.h"
#include "scripts/scenario_full_session.h"
#include "sim/base/error.h"
#include "sim/phantom.h"

namespace handson {

namespace {

// Through the last event, plus one; a camera still moving then (a framing) adds the frames it
// takes to settle, so that the replay ends where the session comes to rest.
int framesToRest(const SessionScript& script, double fps) {
  double end = script.duration();
  for (const ScriptEvent& e : script.events)
    if (!e.isTouch && (e.action == UiAction::FrameClip || e.action == UiAction::CameraBack)) end = std::max(end, e.t + Session::kFramingSeconds);
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
    volume = loadVolume(source, &rep, progress, LoadOptions{o.volumeFrame});
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

namespace {

// One headless replay: the volume, the GPU, the session and its controllers, set up in the order
// the window's are; then a frame per script step.
class ReplayRun {
 public:
  explicit ReplayRun(const ReplayOptions& o);
  /// Plays the frames; the exit status (non-zero: a non-finite state or a validation message).
  int run();

 private:
  void setUpSession();
  void setUpControllers();
  /// The script's events due by `frameTime` (touches scaled to the output).
  std::vector<FrameInput::Event> dueEvents(double frameTime);
  /// Refused events counted and told.
  void tellRefused(const std::vector<ScriptEvent>& refused);
  /// Frame k: events, the request with the simulation, selection and budget, submitted and waited for.
  void frame(int k);
  /// Records the frame's GPU results and writes what was asked of it.
  void finishFrame(int k, const FrameResult& r, FrameTiming& ft);
  int report() const;
  std::string rescue() { return saveRecovery(*session_, selection_->handles(), selection_->picked(), volume_.dims(), o_.exportDir); }

  const ReplayOptions& o_;
  SessionScript script_;
  ProgressFn progress_;
  Volume volume_;
  std::optional<LabelMap> labels_;
  Viewport vp_;
  glm::dvec2 touchScale_{1.0, 1.0};
  std::unique_ptr<vk::Context> ctx_;
  std::unique_ptr<QuantizedVolume> q_;
  std::unique_ptr<VolumeRenderer> renderer_;
  std::unique_ptr<Session> session_;
  std::unique_ptr<SelectionController> selection_;
  std::unique_ptr<DeformationController> deform_;
  std::unique_ptr<FrameDriver> driver_;
  std::unique_ptr<SessionExport> exporter_;
  std::string simStatus_;
  int frames_ = 0;
  std::size_t next_ = 0, refused_ = 0;
  LatencyLog log_;
};

ReplayRun::ReplayRun(const ReplayOptions& o)
    : o_(o),
      script_((checkReplayOptions(o), o.scriptData ? *o.scriptData : o.script.empty() ? builtInDemoScript() : readSessionScript(o.script))),
      progress_(o.quiet ? ProgressFn{} : consoleProgress()),
      log_(o.timings.empty() ? kSummaryFrames : 0) {  // bounded unless the whole log is to be written
  volume_ = loadReplayVolume(o, script_, progress_);
  if (!o.labels.empty()) labels_ = loadLabelMap(o.labels, volume_.geometry());
  // Output size; touches recorded in the script's viewport are scaled to it.
  vp_ = script_.viewport;
  if (o.width > 0 && o.height > 0) vp_ = {o.width, o.height};
  touchScale_ = glm::dvec2(double(vp_.width) / script_.viewport.width, double(vp_.height) / script_.viewport.height);
  vk::ContextOptions co;
  co.validation = o.validation;
  co.device = o.device;
  co.verbose = !o.quiet;
  ctx_ = std::make_unique<vk::Context>(co);
  q_ = std::make_unique<QuantizedVolume>(quantizeVolume(volume_));
  renderer_ = std::make_unique<VolumeRenderer>(*ctx_);
  renderer_->setVolume(*q_, progress_);
  setUpSession();
  setUpControllers();
  if (!o.framesOut.empty()) {
    std::error_code ec;
    std::filesystem::create_directories(o.framesOut, ec);
    if (ec || !std::filesystem::is_directory(o.framesOut)) throw Error("cannot create the frames directory '" + o.framesOut + "'");
  }
  if (o.frames < 0) throw Error("the number of frames must not be negative");
  frames_ = o.frames > 0 ? o.frames : framesToRest(script_, o.fps);
  log_.setNotes(kReplayLogNotes);
}

void ReplayRun::setUpSession() {
  session_ = std::make_unique<Session>(volume_.geometry(), vp_, script_.preset.empty() ? defaultPresetFor(volume_) : script_.preset);
  Session& session = *session_;
  if (script_.freeArea) {
    session.setFreeArea(*script_.freeArea);  // reset-camera frames where the recording app did
    if (!script_.camera) session.resetCamera();
  }
  if (script_.camera) script_.camera->applyTo(session.camera());
  session.apply(uiEvent(0.0, UiAction::SetMode, script_.mode));
  renderer_->setTransferFunction(transferFunctionPreset(session.preset()).lookupTable(*q_));
}

void ReplayRun::setUpControllers() {
  SessionParts parts = makeSessionParts(o_, volume_, *q_, *session_, *renderer_, labels_ ? &*labels_ : nullptr);
  selection_ = std::move(parts.selection);
  deform_ = std::move(parts.deform);
  exporter_ = std::move(parts.exporter);
  driver_ = std::make_unique<FrameDriver>(volume_, *q_, *session_, *renderer_, *selection_, *deform_);
  driver_->setFrameBudget(o_.frameBudgetMs);
  // Everything applied is recorded: an "export" action writes the session so far as a script.
  SessionScript header = script_;
  if (!o_.volume.empty()) {
    header.volumeSource = o_.volume == "phantom" ? "phantom" : "file";
    header.volumePath = o_.volume == "phantom" ? "" : o_.volume;
  }
  session_->startRecording(header);
}

std::vector<FrameInput::Event> ReplayRun::dueEvents(double frameTime) {
  std::vector<FrameInput::Event> due;
  while (next_ < script_.events.size() && script_.events[next_].t <= frameTime) {
    ScriptEvent e = script_.events[next_++];
    e.touch.px *= touchScale_;
    due.push_back({e, -1.0});  // stamped as it is applied
  }
  return due;
}

void ReplayRun::tellRefused(const std::vector<ScriptEvent>& refused) {
  refused_ += refused.size();
  if (o_.quiet) return;
  for (const ScriptEvent& e : refused)
    std::cerr << "refused at t=" << e.t << " s: "
              << (e.isTouch ? "touch " + std::string(touchPhaseName(e.touch.phase)) + " id " + std::to_string(e.touch.id) : std::string(uiActionName(e.action)) + " " + e.value)
              << "\n";
}

void ReplayRun::frame(int k) {
  const double frameTime = k / o_.fps;
  FrameTiming ft;
  ft.cpuStart = driver_->now();
  FrameInput in;
  in.events = dueEvents(frameTime);
  in.sessionClock = frameTime;  // a framing's camera move, on the script's clock
  in.view = vp_;
  in.width = vp_.width;
  in.height = vp_.height;
  in.settled = true;
  in.readbackImage = !o_.framesOut.empty();
  in.exportImage = [this] { return exporter_->pending(); };
  const FrameOutcome out = driver_->frame(in, ft);
  tellRefused(out.refused);
  if (const std::string st = deform_->status(); !o_.quiet && st != simStatus_) {
    simStatus_ = st;
    if (!st.empty()) std::cerr << st << "\n";
  }
  // The simulation refused a pose, stopped without converging or failed to build: the
  // session goes on (the last good state shows), and what was done so far is saved.
  if (out.newFailure) std::cerr << "warning: " << deform_->status() << "\n  " << rescue() << "\n";
  const auto w0 = Clock::now();
  const FrameResult r = renderer_->waitLast();
  ft.waitMs = seconds(Clock::now(), w0) * 1e3;
  finishFrame(k, r, ft);
}

void ReplayRun::finishFrame(int k, const FrameResult& r, FrameTiming& ft) {
  const auto w0 = Clock::now();
  for (const auto& older : renderer_->takeCompleted()) driver_->completed(older);
  driver_->completed(r);
  if (exporter_->pending()) std::cout << exporter_->write(*session_, selection_->handles(), selection_->picked(), *deform_, r) << "\n";
  ft.present = driver_->now();
  ft.waitMs += seconds(Clock::now(), w0) * 1e3;
  ft.frame = r.frame;
  for (const auto& p : r.timings) ft.gpuMs.emplace_back(p.name, p.gpuMs);
  if (!o_.framesOut.empty()) writeFrame(o_.framesOut, k, r, vp_);
  log_.add(ft);
  if (o_.afterFrame) o_.afterFrame(k, frames_, ctx_->validationMessageCount());
  reportProgress(progress_, double(k + 1) / frames_, "replaying");
}

int ReplayRun::run() {
  // A failure under the session (a Vulkan allocation, a lost device, running out of memory) ends
  // the replay with the session so far saved beside the exports.
  try {
    driver_->setClockStart(Clock::now());
    for (int k = 0; k < frames_; ++k) frame(k);
    if (!o_.timings.empty()) log_.writeCsv(o_.timings);
    if (!o_.exportPath.empty()) writeDeformedVolume(*deform_, volume_, o_.exportPath);  // every frame was waited for above
  } catch (const std::bad_alloc&) {
    throw Error("out of memory during the replay; " + rescue());
  } catch (const std::exception& e) {
    throw Error(std::string(e.what()) + "; " + rescue());
  }
  return report();
}

int ReplayRun::report() const {
  if (!o_.quiet) {
    std::cerr << "replayed " << script_.events.size() << " events";
    if (refused_) std::cerr << " (" << refused_ << " refused)";
    std::cerr << " in " << frames_ << " frames at " << o_.fps << " fps on " << ctx_->summary().name << "\n" << log_.summary() << "\n";
  }
  if (!o_.framesOut.empty()) std::cout << "wrote " << frames_ << " frames to " << o_.framesOut << "\n";
  if (o_.printCamera) std::cout << describeCamera(session_->camera()) << "\n";
  if (o_.printHandles) printSessionState(*selection_, *session_, volume_);
  // Whatever came in, no state may hold a non-finite number.
  if (!stateIsFinite(*session_, *selection_)) return 1;
  if (ctx_->validationMessageCount() > 0) {
    std::cerr << "error: " << ctx_->validationMessageCount() << " Vulkan validation message(s)\n";
    return 1;
  }
  return 0;
}

}  // namespace

int runReplay(const ReplayOptions& o) { return ReplayRun(o).run(); }

}  // namespace handson
