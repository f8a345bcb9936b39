#include "viewer.h"

#include <SDL2/SDL.h>
#include <SDL2/SDL_vulkan.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <iomanip>
#include <iostream>
#include <memory>
#include <optional>

#include "app/io/png_io.h"
#include "app/io/volume_io.h"
#include "app/platform/sdl_input.h"
#include "app/platform/ui.h"
#include "app/session/console.h"
#include "app/session/frame_driver.h"
#include "app/session/latency_log.h"
#include "app/session/selection_controller.h"
#include "app/session/session.h"
#include "app/session/session_export.h"
#include "app/session/session_parts.h"
#include "app/session/session_recovery.h"
#include "render/compute_passes.h"
#include "render/transfer_function.h"
#include "render/vk_context.h"
#include "render/vk_swapchain.h"
#include "render/volume_renderer.h"
#include "sim/base/error.h"
#include "sim/phantom.h"

namespace handson {

namespace {

using Clock = std::chrono::steady_clock;
double seconds(Clock::time_point t, Clock::time_point t0) { return std::chrono::duration<double>(t - t0).count(); }

struct SdlVideo {
  SdlVideo() {
    SDL_SetHint(SDL_HINT_VIDEO_X11_NET_WM_BYPASS_COMPOSITOR, "0");
    // With a display, SDL must use it: if connecting fails for a moment (a busy X server), SDL
    // would quietly fall back to its window-less "offscreen" driver. Retry, then say so.
    for (int attempt = 0;; ++attempt) {
      if (SDL_Init(SDL_INIT_VIDEO | SDL_INIT_EVENTS) != 0) throw Error(std::string("cannot open a window: ") + SDL_GetError());
      const char* driver = SDL_GetCurrentVideoDriver();
      const bool windowless = driver && (std::strcmp(driver, "offscreen") == 0 || std::strcmp(driver, "dummy") == 0);
      if (!windowless || !displayAvailable()) break;
      std::cerr << "warning: SDL chose its '" << driver << "' video driver; retrying the display\n";
      SDL_Quit();
      if (attempt == 4) throw Error("cannot connect to the display (SDL fell back to its offscreen driver)");
      SDL_Delay(200);
    }
  }
  ~SdlVideo() { SDL_Quit(); }
};

struct WindowHandle {
  SDL_Window* w = nullptr;
  ~WindowHandle() {
    if (w) SDL_DestroyWindow(w);
  }
};

// Adds the window passes after the raymarch: blit to the swapchain image, the UI, an optional
// screenshot copy, and the hand-over to presentation.
class PresentExtension final : public FrameExtension {
 public:
  PresentExtension(const vk::Swapchain& sc, Ui& ui) : sc_(sc), ui_(ui) {}

  void prepare(const vk::Swapchain::Frame& f, vk::Buffer* screenshot) {
    frame_ = f;
    screenshot_ = screenshot;
    waitSemaphore = f.acquired;
    waitStage = VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT;
    signalSemaphore = f.rendered;
  }

  void addPasses(fg::FrameGraph& g, fg::ResourceHandle color) override {
    const VkExtent2D ext = sc_.extent();
    target_ = g.importImage("swapchain", {ext.width, ext.height, 1, fg::Format::Rgba8Unorm}, fg::Access::None);
    const fg::ImageDesc src = g.resource(color).image;
    g.addPass(
        PassId::Blit,
        [&](fg::PassBuilder& b) {
          b.read(color, fg::Access::TransferSrc);
          b.write(target_, fg::Access::TransferDst);
        },
        [this, color, src, ext](fg::Executor& e) {
          auto& x = vk::vulkanExecutor(e);
          VkImageBlit region{};
          region.srcSubresource = region.dstSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
          region.srcOffsets[1] = {int(src.width), int(src.height), 1};
          region.dstOffsets[1] = {int(ext.width), int(ext.height), 1};
          vkCmdBlitImage(x.cmd(), x.image(color).handle(), VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, sc_.image(frame_.image),
                         VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, 1, &region, VK_FILTER_LINEAR);
        });
    g.addPass(
        PassId::Ui, [&](fg::PassBuilder& b) { b.write(target_, fg::Access::ColorAttachmentWrite); },
        [this, ext](fg::Executor& e) { ui_.record(vk::vulkanExecutor(e).cmd(), sc_.framebuffer(frame_.image), ext); });
    if (screenshot_) {
      shot_ = vk::importBuffer(g, "screenshot", *screenshot_, fg::Access::None);
      g.addPass(
          PassId::Screenshot,
          [&](fg::PassBuilder& b) {
            b.read(target_, fg::Access::TransferSrc);
            b.write(shot_, fg::Access::TransferDst);
            b.sideEffect();
          },
          [this, ext](fg::Executor& e) {
            auto& x = vk::vulkanExecutor(e);
            VkBufferImageCopy r{};
            r.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
            r.imageExtent = {ext.width, ext.height, 1};
            vkCmdCopyImageToBuffer(x.cmd(), sc_.image(frame_.image), VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, x.buffer(shot_).handle(), 1, &r);
          });
      g.exportResource(shot_, fg::Access::HostRead);
    }
    g.exportResource(target_, fg::Access::Present);
  }

  void bind(vk::GraphExecutor& x) override {
    // The swapchain image is not a vk::Image; the passes above use its handle directly, and the
    // executor only needs it for barriers (the screenshot buffer was bound where it was imported).
    x.bindRawImage(target_, sc_.image(frame_.image));
  }

 private:
  const vk::Swapchain& sc_;
  Ui& ui_;
  vk::Swapchain::Frame frame_{};
  vk::Buffer* screenshot_ = nullptr;
  fg::ResourceHandle target_, shot_;
};

std::vector<std::uint8_t> swizzleToRgba(const void* data, VkFormat format, std::uint32_t w, std::uint32_t h) {
  std::vector<std::uint8_t> out(std::size_t(w) * h * 4);
  std::memcpy(out.data(), data, out.size());
  if (format == VK_FORMAT_B8G8R8A8_UNORM || format == VK_FORMAT_B8G8R8A8_SRGB)
    for (std::size_t i = 0; i < out.size(); i += 4) std::swap(out[i], out[i + 2]);
  for (std::size_t i = 3; i < out.size(); i += 4) out[i] = 255;
  return out;
}

}  // namespace

bool displayAvailable() {
  const char* x = std::getenv("DISPLAY");
  const char* wl = std::getenv("WAYLAND_DISPLAY");
  return (x && *x) || (wl && *wl);
}

struct Viewer::Impl {
  ViewerOptions o;
  SdlVideo video;
  WindowHandle window;
  std::unique_ptr<vk::Context> ctx;
  Volume volume;
  QuantizedVolume q;
  std::unique_ptr<VolumeRenderer> renderer;
  std::unique_ptr<vk::Swapchain> swapchain;
  std::unique_ptr<Ui> ui;
  std::unique_ptr<SdlInput> input;
  std::unique_ptr<Session> session;
  std::unique_ptr<PresentExtension> present;
  std::unique_ptr<SelectionController> selection;
  std::unique_ptr<LabelMap> labels;  // --labels: organ labels on the volume's grid
  std::unique_ptr<DeformationController> deform;
  std::unique_ptr<FrameDriver> driver;
  std::unique_ptr<SessionExport> exporter;
  std::uint64_t exportFrame = 0;  // the frame whose image the pending export waits for
  double scale = 1.0;
  LatencyLog log;
  Clock::time_point t0 = Clock::now();
  std::uint64_t frameNo = 0;
  std::string rescueNote;          // where the session was saved after the last one
  bool running = true, resized = false, minimized = false;
  std::unique_ptr<vk::Buffer> shot;
  UiStatus status;
  double lastFrameEnd = 0.0;
  int dw = 0, dh = 0;
  std::optional<SessionScript> play;  // --play: a script fed in as live input
  std::size_t playNext = 0;
  double playStart = 0.0;
  double playClock = 0.0;  // when the played script's clock was last read
  int playPollsSinceBuild = 2;  // input polls since one saw the simulation building
  int playRound = 0;

  explicit Impl(const ViewerOptions& opts);
  bool step();
  int finish();
  /// The window's events and the played script's due events, as touches and UI actions.
  void pollInput(const Viewport& vp, std::vector<TouchEvent>& touches, std::vector<ScriptEvent>& actions);
  /// The panel's status from the session, the controllers and the simulation's failures.
  void updateStatus();
  void frameInFreeArea(const Viewport& vp);
  /// A played script's start, as `replay` sets it: its preset, free area, camera and mode (applied
  /// at once, before the frame's touches).
  void startPlay(double t);
  void firstFrame(const Viewport& vp);
  FrameInput frameInput(const Viewport& vp, const std::vector<TouchEvent>& touches, std::vector<ScriptEvent> actions, const vk::Swapchain::Frame& image);
  void noteFrame(const FrameOutcome& out);
  void noteFailure();
  bool windowReady();
  void takeCompletedFrames();
  /// The display times of presented frames (VK_KHR_present_wait) into the timing log.
  void takeDisplayTimes() {
    for (const auto& shown : swapchain->takeShown())
      if (const double ms = log.setDisplayed(shown.tag, seconds(shown.at, t0)); ms >= 0.0) status.displayLatencyMs = ms;
  }
  std::string rescue() {
    if (!session || !selection) return "nothing to save yet";
    try {
      selection->finishEdits();  // the edits the user made, in the saved handles too
    } catch (const std::exception&) {  // an edit that failed: the handles as they are
    }
    return saveRecovery(*session, selection->handles(), selection->picked(), volume.dims(), o.exportDir);
  }
};

Viewer::Viewer(const ViewerOptions& o) : impl_(std::make_unique<Impl>(o)) {}
Viewer::~Viewer() = default;
bool Viewer::step() {
  // A failure under the session (a Vulkan allocation, a lost device, running out of memory) ends
  // it with what the user did so far saved beside the exports.
  try {
    return impl_->step();
  } catch (const std::bad_alloc&) {
    throw Error("out of memory; " + impl_->rescue());
  } catch (const std::exception& e) {
    throw Error(std::string(e.what()) + "; " + impl_->rescue());
  }
}
int Viewer::finish() { return impl_->finish(); }
Session& Viewer::session() { return *impl_->session; }
std::uint64_t Viewer::frames() const { return impl_->frameNo; }
std::vector<std::array<double, 4>> Viewer::uiPanels() const { return impl_->ui->panelRects(); }
const HandleSet& Viewer::handles() const { return impl_->selection->handles(); }
Viewport Viewer::drawableSize() const { return {std::max(impl_->dw, 1), std::max(impl_->dh, 1)}; }
SDL_Window* Viewer::window() const { return impl_->window.w; }

int runViewer(const ViewerOptions& o) {
  Viewer v(o);
  while (v.step()) {
  }
  return v.finish();
}

Viewer::Impl::Impl(const ViewerOptions& opts) : o(opts), log(opts.timings.empty() ? kSummaryFrames : 0) {
  window.w = SDL_CreateWindow("Handson", SDL_WINDOWPOS_CENTERED, SDL_WINDOWPOS_CENTERED, o.width, o.height,
                              SDL_WINDOW_VULKAN | SDL_WINDOW_RESIZABLE | SDL_WINDOW_ALLOW_HIGHDPI);
  if (!window.w) throw Error(std::string("cannot create a window: ") + SDL_GetError());

  unsigned extCount = 0;
  SDL_Vulkan_GetInstanceExtensions(window.w, &extCount, nullptr);
  std::vector<const char*> exts(extCount);
  SDL_Vulkan_GetInstanceExtensions(window.w, &extCount, exts.data());
  vk::ContextOptions co;
  co.validation = o.validation;
  co.device = o.device;
  co.verbose = !o.quiet;
  co.instanceExtensions.assign(exts.begin(), exts.end());
  co.deviceExtensions = {VK_KHR_SWAPCHAIN_EXTENSION_NAME};
  co.presentTiming = true;  // the timing log's display times, where the driver has them
  SDL_Window* w = window.w;
  co.makeSurface = [w](VkInstance inst) {
    VkSurfaceKHR surface = VK_NULL_HANDLE;
    return SDL_Vulkan_CreateSurface(w, inst, &surface) ? surface : VkSurfaceKHR(VK_NULL_HANDLE);
  };
  ctx = std::make_unique<vk::Context>(co);

  // The scene.
  const ProgressFn progress = o.quiet ? ProgressFn{} : consoleProgress();
  if (o.volume.empty()) {
    volume = makePhantom().ct;
  } else {
    LoadReport rep;
    volume = loadVolume(o.volume, &rep, progress, LoadOptions{o.volumeFrame});
    for (const auto& warning : rep.warnings) std::cerr << "warning: " << warning << "\n";
  }
  if (!o.labels.empty()) labels = std::make_unique<LabelMap>(loadLabelMap(o.labels, volume.geometry()));
  q = quantizeVolume(volume);
  renderer = std::make_unique<VolumeRenderer>(*ctx, std::uint32_t(o.framesInFlight));
  renderer->setVolume(q, progress);

  SDL_Vulkan_GetDrawableSize(window.w, &dw, &dh);
  const float hidpi = float(dw) / float(std::max(o.width, 1));
  swapchain = std::make_unique<vk::Swapchain>(*ctx, vk::parsePresentMode(o.presentMode), VkExtent2D{std::uint32_t(dw), std::uint32_t(dh)},
                                              std::uint32_t(o.framesInFlight));
  ui = std::make_unique<Ui>(window.w, *ctx, *swapchain, hidpi);
  input = std::make_unique<SdlInput>(window.w);
  scale = o.renderScale > 0.0 ? o.renderScale : (ctx->summary().type == VK_PHYSICAL_DEVICE_TYPE_CPU ? 0.5 : 1.0);

  session = std::make_unique<Session>(volume.geometry(), Viewport{std::max(dw, 1), std::max(dh, 1)},
                                      o.preset.empty() ? defaultPresetFor(volume) : o.preset);
  renderer->setTransferFunction(transferFunctionPreset(session->preset()).lookupTable(q));
  {  // always recorded: the Export button writes the session so far; --record writes it at the end
    SessionScript header;
    header.volumeSource = o.volume.empty() ? "phantom" : "file";
    header.volumePath = o.volume;
    session->startRecording(header);
  }
  if (!o.quiet)
    std::cerr << "window " << dw << "x" << dh << ", present mode " << vk::presentModeName(swapchain->presentMode()) << ", "
              << o.framesInFlight << " frame(s) in flight, raymarch at " << scale * 100 << " %, display times "
              << (swapchain->timesDisplay() ? "measured (VK_KHR_present_wait)" : "not measured (no VK_KHR_present_wait)") << "\n";
  present = std::make_unique<PresentExtension>(*swapchain, *ui);
  log.setNotes({"clock: seconds since the first frame on the steady clock",
                "input_first_s, input_last_s: when the app read the frame's events from SDL (SDL 2 gives touches no device timestamp)",
                swapchain->presentTimingNote()});
  SessionParts parts = makeSessionParts(o, volume, q, *session, *renderer, labels.get());
  selection = std::move(parts.selection);
  selection->setEditsInBackground(true);  // a liver-sized correction never holds a frame
  deform = std::move(parts.deform);
  exporter = std::move(parts.exporter);
  status.selectionBackend = selection->backend().status;
  driver = std::make_unique<FrameDriver>(volume, q, *session, *renderer, *selection, *deform);
  driver->setFrameBudget(o.frameBudgetMs);
  status.device = ctx->summary().name;
  if (!o.play.empty()) play = readSessionScript(o.play);
  t0 = Clock::now();
  driver->setClockStart(t0);
}

void Viewer::Impl::pollInput(const Viewport& vp, std::vector<TouchEvent>& touches, std::vector<ScriptEvent>& actions) {
  SDL_Event e;
  while (SDL_PollEvent(&e)) {
    const double t = seconds(Clock::now(), t0);
    ui->processEvent(e);
    if (e.type == SDL_QUIT) running = false;
    if (e.type == SDL_WINDOWEVENT) {
      if (e.window.event == SDL_WINDOWEVENT_SIZE_CHANGED) resized = true;
      if (e.window.event == SDL_WINDOWEVENT_MINIMIZED) minimized = true;
    }
    if (e.type == SDL_KEYDOWN && !ui->wantsKeyboard()) {
      const SDL_Keycode k = e.key.keysym.sym;
      ScriptEvent key = uiEvent(t, UiAction::None);
      if (k == SDLK_ESCAPE) running = false;
      if (k == SDLK_r) key.action = UiAction::ResetCamera;
      if (k >= SDLK_1 && k <= SDLK_5) {
        static const char* const kModes[] = {"navigate", "select", "manipulate", "clip", "window"};
        key.action = UiAction::SetMode;
        key.value = kModes[k - SDLK_1];
      }
      if (key.action != UiAction::None) actions.push_back(key);
    }
    input->translate(e, t, vp, [this](double x, double y) { return ui->covers(x, y); }, touches);
  }
  // A played script's events arrive as a user's would: at their time since the first frame, mapped
  // from the script's viewport to the window's so that they land on the same anatomy: the camera's
  // field of view is vertical, so a point keeps its place relative to the centre in units of the
  // view's height, whatever the window's size and aspect (scaled by the heights' ratio about the
  // centres; the gestures' own scales are per viewport height too).
  if (play) {
    const double now = seconds(Clock::now(), t0);
    // While the simulation of the script's handles builds, its clock stops (a user waits for
    // "building" to end before dragging; replay waits likewise), so the drags meet the model.
    // It stays stopped from the last frame (whose events may have started the build) until the
    // first frame drawn with the model has been shown (the user sees the end of the build then).
    const bool building = o.playWaitsForSimulation && deform->state() == DeformationController::State::Building;
    if (building || playPollsSinceBuild < 2) playStart += now - playClock;
    playClock = now;
    playPollsSinceBuild = building ? 0 : std::min(playPollsSinceBuild + 1, 2);
    const double k = double(vp.height) / play->viewport.height;
    const glm::dvec2 centre(0.5 * vp.width, 0.5 * vp.height), scriptCentre(0.5 * play->viewport.width, 0.5 * play->viewport.height);
    while (playNext < play->events.size() && playStart + play->events[playNext].t <= now) {
      ScriptEvent pe = play->events[playNext++];
      pe.t += playStart;
      if (pe.isTouch) {
        pe.touch.px = centre + (pe.touch.px - scriptCentre) * k;
        pe.touch.time = pe.t;
        touches.push_back(pe.touch);
      } else {
        actions.push_back(pe);
        break;  // the next events in a later frame: after this one's effects (a handle made active starts its build)
      }
    }
    if (playNext >= play->events.size() && now > playStart + play->duration() + 0.5 && !selection->editing()) {
      if (++playRound < o.playRepeat) {
        playNext = 0;  // play it again from here, from the script's start
        playStart = now;
        startPlay(now);
      } else if (o.frames <= 0) {
        running = false;
      }
    }
  }
}

void Viewer::Impl::updateStatus() {
  status.mode = modeName(session->gestures().mode());
  status.preset = session->preset();
  status.fingers = int(session->gestures().input().fingers().size());
  status.handles.clear();
  for (const auto& h : selection->handles().handles()) status.handles.push_back({h.id, handleStatusName(h.status), h.voxels.size(), {}});
  for (const auto& [id, r] : deform->shownReactions())
    for (auto& row : status.handles)
      if (row.id == id) row.reaction = formatReaction(r, deform->shownRefineStep() == 0);
  status.picked = selection->picked();
  status.locks = selection->locks();
  status.pinchOp = pinchOpName(selection->pinchOp());
  status.strainOverlay = session->strainOverlay();
  status.limitHighlight = session->limitHighlight();
  status.hasLabels = labels != nullptr;
  status.sliding = deform->interface() == SimSettings::Interface::Sliding;
  status.labelTint = session->labelTint();
  status.clipped = session->clip().box || session->clip().plane;
  status.canGoBack = session->canGoBack();
  status.window = session->window();
  status.strainFrom = RenderSettings{}.strainFrom;
  status.strainTo = RenderSettings{}.strainTo;
  status.canUndo = selection->handles().canUndo();
  status.canRedo = selection->handles().canRedo();
  status.feedback = !selection->pinch().feedback().empty() ? selection->pinch().feedback()
                    : selection->editing()                ? std::string("Editing the selection...")
                    : !selection->labelNote().empty()     ? selection->labelNote()
                    : !selection->correctionNote().empty() ? selection->correctionNote()
                                                          : selection->manipulationNote();
  status.simulation = deform->status();
  status.tissueLimits = deform->shownTissueLimits();
  if (driver->newFailure()) noteFailure();  // a failure that landed since the last frame: in this frame's panel
  if (!rescueNote.empty()) status.simulation += "; " + rescueNote;
  status.liveVoxels = selection->liveVoxelCount();
  status.liveOnGpuMm = selection->liveOnGpu() ? selection->pinch().extentMm() : -1.0;
}

void Viewer::Impl::startPlay(double t) {
  session->stopFraming();  // a repeat starts as the script did
  session->setFramingViewport(play->viewport);  // a reset-camera in the script frames as it did there
  if (play->freeArea) session->setFreeArea(*play->freeArea);  // reset-camera frames where the recording app did
  if (play->camera) play->camera->applyTo(session->camera());
  else session->resetCamera();
  if (!play->preset.empty()) session->apply(uiEvent(t, UiAction::SetPreset, play->preset));
  session->apply(uiEvent(t, UiAction::SetMode, play->mode));
  // Before anything is recorded the start is the recording's header (as the played script has it),
  // not events; a repeat's start is recorded as events.
  if (frameNo == 0) {
    const SessionScript header = session->script();
    session->startRecording(header);
  }
}

// The first frame's view: the volume framed in the part of the window the panels leave free (they
// are measured once the UI is laid out), recorded as the session's start and its reset-camera framing.
void Viewer::Impl::frameInFreeArea(const Viewport& vp) {
  const VolumeGeometry& g = volume.geometry();
  const OrbitCamera probe = OrbitCamera::framing(g, glm::radians(kDefaultAzimuthDeg), glm::radians(kDefaultElevationDeg), double(vp.width) / vp.height);
  const auto box = projectedVolumeBox(probe, g, vp.width, vp.height);
  const double aspect = box ? ((*box)[2] - (*box)[0]) / std::max((*box)[3] - (*box)[1], 1.0) : 1.0;
  session->setFreeArea(largestFreeArea(vp.width, vp.height, ui->panelRects(), aspect, 12.0 * ui->scale()));
  session->resetCamera();
}

// A minimized window waits; a resized one gets its swapchain anew. False: no frame this step.
bool Viewer::Impl::windowReady() {
  if (minimized) {
    SDL_WaitEventTimeout(nullptr, 100);
    SDL_Event e;
    while (SDL_PollEvent(&e))
      if (e.type == SDL_QUIT) running = false;
      else if (e.type == SDL_WINDOWEVENT && (e.window.event == SDL_WINDOWEVENT_RESTORED || e.window.event == SDL_WINDOWEVENT_SIZE_CHANGED))
        resized = true;
    SDL_Vulkan_GetDrawableSize(window.w, &dw, &dh);
    minimized = !swapchain->recreate({std::uint32_t(std::max(dw, 0)), std::uint32_t(std::max(dh, 0))});
    if (!minimized) ui->swapchainRecreated(*swapchain);
    return false;
  }
  if (resized) {
    SDL_Vulkan_GetDrawableSize(window.w, &dw, &dh);
    minimized = !swapchain->recreate({std::uint32_t(std::max(dw, 0)), std::uint32_t(std::max(dh, 0))});
    if (!minimized) ui->swapchainRecreated(*swapchain);
    session->setViewport({std::max(dw, 1), std::max(dh, 1)});
    resized = false;
    if (minimized) return false;
  }
  return true;
}

// Finished frames: the driver's bookkeeping, a pending export written once its frame is done, and
// the passes' GPU times into the log and the overlay.
void Viewer::Impl::takeCompletedFrames() {
  for (const auto& r : renderer->takeCompleted()) {
    driver->completed(r);
    if (exportFrame != 0 && r.frame == exportFrame) {
      renderer->waitLast();  // the frames after it are done too: the volume and mesh are read at rest
      status.exported = exporter->write(*session, selection->handles(), selection->picked(), *deform, r);
      if (!o.quiet) std::cerr << status.exported << "\n";
      exportFrame = 0;
    }
    std::vector<std::pair<std::string, double>> passes;
    for (const auto& p : r.timings) {
      passes.emplace_back(p.name, p.gpuMs);
      if (p.id == PassId::Raymarch) status.gpuRaymarchMs = p.gpuMs;
    }
    log.setGpuTimes(r.frame, passes);
  }
}

bool Viewer::Impl::step() {
  if (!running || (o.frames > 0 && int(frameNo) >= o.frames)) return false;
  if (frameNo == 0) playStart = playClock = seconds(Clock::now(), t0);
  FrameTiming ft;
  ft.frame = frameNo + 1;
  ft.cpuStart = seconds(Clock::now(), t0);
  if (!windowReady()) return true;
  // Acquire first, then sample input as late as possible before recording.
  const auto a0 = Clock::now();
  auto image = swapchain->acquire();
  double wait = seconds(Clock::now(), a0);
  if (!image) {
    resized = true;
    return true;
  }
  std::vector<TouchEvent> touches;
  std::vector<ScriptEvent> actions;
  const Viewport vp{int(swapchain->extent().width), int(swapchain->extent().height)};
  pollInput(vp, touches, actions);
  if (frameNo == 0) firstFrame(vp);
  const FrameOutcome out = driver->frame(frameInput(vp, touches, std::move(actions), *image), ft);
  if (out.exportImage) exportFrame = out.frame;
  noteFrame(out);
  wait += ft.submit - ft.cpuEnd;
  const auto p0 = Clock::now();
  if (!swapchain->present(*image, ft.frame)) resized = true;
  ft.present = seconds(Clock::now(), t0);
  wait += seconds(Clock::now(), p0);
  ft.waitMs = wait * 1e3;
  takeCompletedFrames();
  status.cpuFrameMs = (ft.cpuEnd - ft.cpuStart) * 1e3;
  status.fps = lastFrameEnd > 0 ? 1.0 / std::max(1e-6, ft.present - lastFrameEnd) : 0.0;
  status.latencyMs = ft.latencyMs() >= 0 ? ft.latencyMs() : status.latencyMs;
  lastFrameEnd = ft.present;
  log.add(ft);
  takeDisplayTimes();
  ++frameNo;
  return running && (o.frames <= 0 || int(frameNo) < o.frames);
}

// The first frame: a played script's start (recorded before its first event), or - before any
// touch is applied (a finger already down would be cancelled by the reframing) - the UI laid out
// twice (ImGui sizes an auto-resized panel from its content at the end of a frame; these passes'
// actions are dropped) so that the panels are measured at their size, and the view framed where
// they leave room.
void Viewer::Impl::firstFrame(const Viewport& vp) {
  if (play) {
    startPlay(playStart);
    return;
  }
  updateStatus();
  std::vector<ScriptEvent> layoutPass;
  for (int pass = 0; pass < 2; ++pass) ui->build(status, seconds(Clock::now(), t0), layoutPass);
  frameInFreeArea(vp);
}

// The frame's input for the driver: the touches, then the panels laid out on the state they left
// (with the keys' and a played script's actions); the raymarch at the render scale; the present
// and UI passes prepared (and the screenshot's buffer on the last frame) before the submission.
FrameInput Viewer::Impl::frameInput(const Viewport& vp, const std::vector<TouchEvent>& touches, std::vector<ScriptEvent> actions,
                                    const vk::Swapchain::Frame& image) {
  FrameInput in;
  for (const auto& t : touches) {
    ScriptEvent se;
    se.t = t.time;
    se.touch = t;
    in.events.push_back({se, t.time});
  }
  in.panels = [this, actions = std::move(actions)]() mutable {
    updateStatus();
    ui->build(status, seconds(Clock::now(), t0), actions);
    return actions;
  };
  // sessionClock left to the driver: read once the panels' actions are applied, so that a settled
  // clip's framing is stamped after them (a recorded script's times never decrease).
  in.followClip = !play;  // a played script carries its own framing and window
  in.view = vp;
  in.width = std::max(1, int(std::lround(vp.width * scale)));
  in.height = std::max(1, int(std::lround(vp.height * scale)));
  in.exportImage = [this] { return exporter->pending() && exportFrame == 0; };  // the export's image (without the UI)
  in.extension = present.get();
  const bool lastFrame = o.frames > 0 && int(frameNo) + 1 == o.frames;
  in.beforeSubmit = [this, lastFrame, &image, vp] {
    if (lastFrame && !o.screenshot.empty())
      shot = std::make_unique<vk::Buffer>(*ctx, VkDeviceSize(vp.width) * vp.height * 4, VK_BUFFER_USAGE_TRANSFER_DST_BIT, vk::Buffer::Memory::HostVisible);
    present->prepare(image, (lastFrame && shot) ? shot.get() : nullptr);
  };
  return in;
}

// What the frame drew into the panel's status; a new simulation failure saved and told (the
// session goes on, the last good state showing).
void Viewer::Impl::noteFrame(const FrameOutcome& out) {
  status.renderWidth = out.width;
  status.renderHeight = out.height;
  status.qualityScale = out.quality.scale;
  status.qualityStep = out.quality.stepScale;
  status.stillPhases = out.stillPhases;
  status.stillPhasesTotal = kStillJitterPhases;
  if (out.newFailure) noteFailure();
}

// The simulation refused a pose, stopped without converging or failed to build: the session goes
// on (the last good state shows), and what was done so far is saved and said.
void Viewer::Impl::noteFailure() {
  rescueNote = rescue();
  if (!o.quiet) std::cerr << "warning: " << deform->status() << "\n  " << rescueNote << "\n";
}

int Viewer::Impl::finish() {
  if (selection) selection->finishEdits();  // the session's handles, its exports and records with every edit in
  const FrameResult last = frameNo ? renderer->waitLast() : FrameResult{};
  swapchain->settleDisplayTimes(std::chrono::milliseconds(500));
  takeDisplayTimes();
  if (frameNo) {
    std::vector<std::pair<std::string, double>> passes;
    for (const auto& p : last.timings) passes.emplace_back(p.name, p.gpuMs);
    log.setGpuTimes(last.frame, passes);
  }
  // An export asked for on the last frames: its frame is the last one or among those just finished.
  if (exportFrame != 0) {
    std::vector<FrameResult> done = renderer->takeCompleted();
    done.push_back(last);
    for (const auto& r : done)
      if (r.frame == exportFrame) {
        std::cerr << exporter->write(*session, selection->handles(), selection->picked(), *deform, r) << "\n";
        exportFrame = 0;
      }
  }
  if (exporter && (exporter->pending() || exportFrame != 0)) std::cerr << "warning: an export was asked for as the session ended and was not written\n";
  if (shot && !o.screenshot.empty()) {
    shot->invalidate();
    const VkExtent2D ext = swapchain->extent();
    writePng(o.screenshot, int(ext.width), int(ext.height), swizzleToRgba(shot->mapped(), swapchain->format(), ext.width, ext.height));
    std::cout << "wrote " << o.screenshot << "\n";
  }
  if (!o.record.empty()) {
    writeSessionScript(session->script(), o.record);
    std::cout << "recorded " << session->script().events.size() << " events to " << o.record << "\n";
  }
  if (!o.timings.empty()) log.writeCsv(o.timings);
  if (!o.quiet && frameNo) std::cerr << log.summary() << "\n";
  if (o.printCamera) std::cout << describeCamera(session->camera()) << "\n";
  if (ctx->validationMessageCount() > 0) {
    std::cerr << "error: " << ctx->validationMessageCount() << " Vulkan validation message(s)\n";
    return 1;
  }
  return 0;
}

}  // namespace handson
