// `handson view`, `handson replay` and the default command.
#include <algorithm>
#include <filesystem>
#include <iostream>

#include "app/cli/args.h"
#include "app/cli/commands.h"
#include "app/io/nifti_io.h"
#include "app/session/replay.h"
#include "app/tools/contact_sheet.h"
#include "app/tools/scenario_retarget.h"
#include "sim/phantom.h"
#include "sim/scene_cache.h"
#include <unistd.h>

#include "app/io/volume_io.h"
#include "app/platform/viewer.h"
#include "app/tools/gesture_stress.h"
#include "app/tools/session_compose.h"
#include "app/tools/soak.h"
#include "render/transfer_function.h"
#include "sim/base/error.h"

namespace handson::cli {

namespace {

const char* const kViewHelp =
    "usage: handson view [PATH] [options]\n"
    "  Opens a volume (NIfTI, NRRD or MetaImage file, or a DICOM directory; omitted: the built-in phantom)\n"
    "  in the touch app.\n"
    "  Touch: one finger orbits; two fingers pinch to zoom, pan and twist to roll (navigate mode).\n"
    "  Mouse: left drag = one finger; Shift = two fingers moving together; Ctrl = two fingers\n"
    "  mirrored about the window centre (pinch, twist); Ctrl+Shift = three fingers; wheel zooms.\n"
    "  Keys: 1/2/3 navigate/select/manipulate, R reset view, Esc quit.\n"
    "  --size WxH              window size in points (default 1280x800)\n"
    "  --present-mode MODE     fifo (vsync, default), mailbox or immediate\n"
    "  --render-scale F        raymarch resolution relative to the window (default 1 on a GPU, 0.5 on a CPU)\n"
    "  --frame-budget-ms MS    GPU time a changing frame may take (default 33; 0: off, always full quality):\n"
    "                          while the picture changes the raymarch is drawn smaller and with a longer\n"
    "                          step to fit, refined back to full quality a level a frame when it stops\n"
    "  --frames-in-flight N    1 (lowest latency), 2 (default) or 3\n"
    "  --preset NAME           ct-abdomen, ct-bone or mri\n"
    "  --frames N              render N frames and exit\n"
    "  --screenshot OUT.png    with --frames: save the last presented frame (UI included)\n"
    "  --record SCRIPT.json    write what the user did as a session script\n"
    "  --play SCRIPT.json      feed a session script in as live input, in real time; exits after it\n"
    "  --play-repeat N         play it N times in a row, resetting the view in between (default 1)\n"
    "  --play-wait on|off      a played script's clock stops while the simulation builds (default on:\n"
    "                          as a user waits for 'building' to end; off: every event at its time)\n";

const char* const kReplayHelp =
    "usage: handson replay [SCRIPT] [--volume PATH] [--frames-out DIR] [--timings LOG.csv] [options]\n"
    "  Plays a session script headless (no window, any Vulkan device): frames at --fps of script\n"
    "  time (default 30) written as DIR/frame_NNNNN.png, and the per-frame timing log. SCRIPT\n"
    "  omitted: the built-in orbit-and-zoom demo. The same script on the same driver gives\n"
    "  bit-identical frames.\n"
    "  --volume PATH           replay on another volume than the script's\n"
    "  --frames-out DIR        the frames as PNGs\n"
    "  --frames N              frames to render (default: through the script's last event, plus one)\n"
    "  --frame-budget-ms MS    as in view, from the frames' measured times (default 0: off; on, frames\n"
    "                          depend on timing and are no longer bit-identical run to run)\n"
    "  --size WxH              output size (touches are scaled from the script's viewport)\n"
    "  --fps F                 frames per second of script time\n"
    "  --export OUT.nii.gz     the deformed volume at the end, on the input's grid\n"
    "  --print-handles         each handle's state and pose at the end\n";

// The options every session has, in view and in replay alike (app/session/session_options.h).
const char* const kSessionHelp =
    "  --frame N               the volume of a 4D NIfTI image to load (default 0)\n"
    "  --labels LABELS         organ labels (0 = background; another grid of the same space is resampled):\n"
    "                          in select mode a tap on an organ makes its labelled component a handle\n"
    "  --timings LOG.csv       per-frame latency log (input, CPU, GPU passes, submit, present)\n"
    "  --export-dir DIR        where export actions (the Export button) write the session, the deformed\n"
    "                          volume, the mesh and a screenshot (default handson-export)\n"
    "  --export-format F       nifti (default), nrrd or mha: the exported volumes' format\n"
    "  --selection-backend B   where a pinch's selection grows: auto (default: the GPU pass on a GPU,\n"
    "                          the CPU search on a CPU device such as lavapipe), gpu or cpu (the same voxels)\n"
    "  --selection-rim on|off  a finished pinch's selection ends with its partial-volume boundary rim\n"
    "                          (default on; docs/region-growing.md)\n"
    "  --selection-bound path|ball  how far the fingers' spread lets a selection grow: path (default:\n"
    "                          that far along paths through the organ) or ball (the earlier rule: inside\n"
    "                          the ball of that radius about the seed)\n"
    "  --selection-corrections neck|grown  what a pinch united with or subtracted from a handle adds or\n"
    "                          takes: neck (default: a difference the part beyond the handle's narrowest\n"
    "                          neck between the two seeds, a union the pinch's lobe its seed lies in) or\n"
    "                          grown (the earlier rule: all the pinch grew)\n"
    "  --device NAME, --validation, --quiet, --print-camera\n";

const char* const kSimHelp =
    "  --sim on|off            simulate moved handles (default on): the tissue around them deforms\n"
    "  --sim-coarse-tets N     coarse elements of the simulation (default 6000)\n"
    "  --sim-fine-tets N       fine elements (default 300000)\n"
    "  --sim-padding-mm D      simulated region: the handles' box plus D mm (default 40)\n"
    "  --sim-region box|handles  simulate the whole padded box, or only its cells within the padding\n"
    "                          of the handles themselves (the box's far corners held at rest)\n"
    "  --sim-coarse-element cell|tet  coarse model elements (default cell; see handson deform --help)\n"
    "  --sim-coarse-solver pcg|assembled  the coarse solve: matrix-free PCG (default) or the assembled\n"
    "                          warped stiffness refactorized every third frame (the old one, kept to compare)\n"
    "  --sim-graded-split CELLS  graded cells: halve the coarse cells within CELLS cell sizes of a\n"
    "                          handle (off by default; see handson deform --help)\n"
    "  --sim-fine-mesh regular|adapted  fine mesh (default regular; see handson deform --help)\n"
    "  --sim-cache DIR|off     preprocessing cache (scene + coarse model; a second open of the same\n"
    "                          volume, handles and settings skips it): default $HANDSON_CACHE_DIR,\n"
    "                          $XDG_CACHE_HOME/handson or ~/.cache/handson\n"
    "  --sim-handle-nodes inside|tets, --sim-bone anchored|by-value  what a handle holds and whether\n"
    "                          bone is anchored to the skeleton (see handson deform --help)\n"
    "  --sim-outer-boundary exterior|wall  the region's boundary (see handson deform --help)\n"
    "  --sim-interface sliding|glued  the handles' interface with the tissue (see handson deform --help)\n"
    "  --sim-refine-steps N    two-level refinement steps toward the fine answer while a pose is held\n"
    "                          (default 2 in view, 0 in replay)\n"
    "  --sim-iterations N      coarse solver iterations per new pose (default 3)\n"
    "  --sim-idle-iterations N more while a pose is held, until converged (default 300); a solve that\n"
    "                          has not converged when they are spent is reported and the session saved\n";
const std::vector<std::string> kSimOptions = {"--sim", "--sim-coarse-tets", "--sim-fine-tets", "--sim-padding-mm", "--sim-region", "--sim-refine-steps", "--sim-coarse-element", "--sim-coarse-solver", "--sim-graded-split", "--sim-fine-mesh",
                                                 "--sim-handle-nodes", "--sim-bone", "--sim-outer-boundary", "--sim-interface",
                                                 "--sim-adapt-contrast", "--sim-cache", "--sim-iterations", "--sim-idle-iterations"};

// The simulation's options over `d` (whose fields are the defaults).
DeformationOptions simOptions(const Args& args, DeformationOptions d = {}) {
  d.enabled = onOffOption(args, "--sim", true);
  d.sim.coarseTets = int(args.integer("--sim-coarse-tets", d.sim.coarseTets, 6, 2000000));
  d.sim.fineTets = int(args.integer("--sim-fine-tets", d.sim.fineTets, 6, 20000000));
  if (d.sim.fineTets < d.sim.coarseTets) throw UsageError("--sim-fine-tets must be at least --sim-coarse-tets");
  d.sim.paddingMm = args.number("--sim-padding-mm", d.sim.paddingMm, 0.0, 1e4);
  regionOption(args, "--sim-region", d.sim);
  coarseModelOptions(args, "--sim-", d.sim);
  fineMeshOptions(args, "--sim-fine-mesh", "--sim-adapt-contrast", d.sim);
  d.refineSteps = int(args.integer("--sim-refine-steps", d.refineSteps, 0, 100));
  d.coarseIterations = int(args.integer("--sim-iterations", d.coarseIterations, 1, 1000));
  d.idleIterations = int(args.integer("--sim-idle-iterations", d.idleIterations, 0, 100000));
  const std::string cache = args.valueOr("--sim-cache", defaultSimulationCacheDir().string());
  d.cacheDir = cache == "off" ? "" : cache;
  return d;
}

SelectionBackend selectionBackendOption(const Args& args) {
  SelectionBackend b = SelectionBackend::Auto;
  if (!parseSelectionBackend(args.valueOr("--selection-backend", "auto"), b)) throw UsageError("--selection-backend must be auto, gpu or cpu");
  return b;
}

CorrectionRule selectionCorrectionsOption(const Args& args) {
  CorrectionRule r = CorrectionRule::Neck;
  if (!parseCorrectionRule(args.valueOr("--selection-corrections", correctionRuleName(r)), r)) throw UsageError("--selection-corrections must be neck or grown");
  return r;
}

GrowBound selectionBoundOption(const Args& args) {
  GrowBound b = GrowParams{}.bound;
  if (!parseGrowBound(args.valueOr("--selection-bound", growBoundName(b)), b)) throw UsageError("--selection-bound must be path or ball");
  return b;
}

const std::vector<std::string> kSessionOptions = {"--frame", "--labels", "--timings", "--export-dir", "--export-format", "--selection-backend", "--selection-rim",
                                                  "--selection-bound", "--selection-corrections", "--device", "--frames"};
const std::vector<std::string> kSessionFlags = {"--validation", "--quiet", "--print-camera"};

// The options every session has into `o`, whose fields hold the defaults (the mode's own struct).
void readSessionOptions(const Args& args, SessionOptions& o) {
  o.volumeFrame = loadOptions(args).frame;
  o.labels = args.valueOr("--labels", o.labels);
  o.timings = args.valueOr("--timings", o.timings);
  o.exportDir = args.valueOr("--export-dir", o.exportDir);
  o.exportExtension = exportVolumeExtension(args);
  o.selectionBackend = selectionBackendOption(args);
  o.selectionRim = onOffOption(args, "--selection-rim", o.selectionRim);
  o.selectionBound = selectionBoundOption(args);
  o.selectionCorrections = selectionCorrectionsOption(args);
  o.device = args.valueOr("--device", o.device);
  o.frames = int(args.integer("--frames", o.frames, 1, 100000000));
  o.validation = args.flag("--validation");
  o.quiet = args.flag("--quiet");
  o.printCamera = args.flag("--print-camera");
  o.sim = simOptions(args, o.sim);
}

std::vector<std::string> with(std::vector<std::string> a, const std::vector<std::string>& b) {
  a.insert(a.end(), b.begin(), b.end());
  return a;
}

}  // namespace

int cmdView(const Words& words) {
  Args args(words,
            with(with({"--size", "--present-mode", "--render-scale", "--frame-budget-ms", "--preset", "--screenshot", "--record", "--play", "--frames-in-flight",
                       "--play-repeat", "--play-wait"},
                      kSessionOptions),
                 kSimOptions),
            kSessionFlags);
  if (args.help() || args.positional().size() > 1) {
    usageStream(args) << kViewHelp << kSessionHelp << kSimHelp;
    return args.help() ? 0 : 2;
  }
  ViewerOptions o;
  if (!args.positional().empty()) o.volume = args.positional()[0];
  readSessionOptions(args, o);
  if (auto s = args.value("--size")) parseSize(*s, o.width, o.height);
  o.presentMode = args.valueOr("--present-mode", o.presentMode);
  if (o.presentMode != "fifo" && o.presentMode != "mailbox" && o.presentMode != "immediate")
    throw UsageError("--present-mode must be fifo, mailbox or immediate");
  o.renderScale = args.number("--render-scale", o.renderScale, 0.05, 4.0);
  o.frameBudgetMs = args.number("--frame-budget-ms", o.frameBudgetMs, 0.0, 10000.0);
  o.preset = args.valueOr("--preset", o.preset);
  if (!o.preset.empty()) transferFunctionPreset(o.preset);  // validates the name
  o.screenshot = args.valueOr("--screenshot", "");
  if (!o.screenshot.empty() && o.frames <= 0) throw UsageError("--screenshot needs --frames N");
  o.record = args.valueOr("--record", "");
  o.play = args.valueOr("--play", "");
  o.framesInFlight = int(args.integer("--frames-in-flight", o.framesInFlight, 1, 3));
  o.playRepeat = int(args.integer("--play-repeat", o.playRepeat, 1, 100000));
  o.playWaitsForSimulation = onOffOption(args, "--play-wait", o.playWaitsForSimulation);
  if (!displayAvailable()) throw Error("no display available (DISPLAY and WAYLAND_DISPLAY are unset): use 'handson replay' to run headless");
  return runViewer(o);
}

int cmdReplay(const Words& words) {
  Args args(words, with(with({"--volume", "--frames-out", "--fps", "--frame-budget-ms", "--size", "--export"}, kSessionOptions), kSimOptions),
            with(kSessionFlags, {"--print-handles"}));
  if (args.help() || args.positional().size() > 1) {
    usageStream(args) << kReplayHelp << kSessionHelp << kSimHelp << "  (replay waits each frame for the simulation to settle: frames do not depend on timing)\n";
    return args.help() ? 0 : 2;
  }
  ReplayOptions o;
  if (!args.positional().empty()) o.script = args.positional()[0];
  readSessionOptions(args, o);
  o.volume = args.valueOr("--volume", o.volume);
  o.framesOut = args.valueOr("--frames-out", o.framesOut);
  o.fps = args.number("--fps", o.fps, 0.01, 1000.0);
  o.frameBudgetMs = args.number("--frame-budget-ms", o.frameBudgetMs, 0.0, 10000.0);
  if (auto s = args.value("--size")) parseSize(*s, o.width, o.height);
  o.printHandles = args.flag("--print-handles");
  o.exportPath = args.valueOr("--export", "");
  return runReplay(o);
}

int cmdRetarget(const Words& words) {
  Args args(words, {"--volume", "--labels", "--label", "-o"}, {});
  if (args.help() || args.positional().size() != 1 || !args.value("--volume") || !args.value("--labels") || !args.value("--label") ||
      !args.value("-o")) {
    usageStream(args) << "usage: handson retarget SCRIPT --volume CT --labels LABELS.nii.gz --label N -o OUT.json\n"
                         "  Re-aims a gesture script at an organ of another volume: the touches stay where they are on the\n"
                         "  screen; the camera (same distance and field of view; azimuth every 30 degrees, elevation 0 or\n"
                         "  +-25) puts the organ (label N, on the CT's grid) under the script's first pinch, and the\n"
                         "  direction whose depth picks land on the organ most often wins. Then 'handson replay OUT.json'\n"
                         "  plays it there. Fails when no direction puts both of the pinch's fingers on the organ.\n";
    return args.help() ? 0 : 2;
  }
  const int label = int(args.integer("--label", 0, 1, 65535));
  const SessionScript script = readSessionScript(args.positional()[0]);
  const std::string volumePath = *args.value("--volume");
  const Volume ct = loadVolume(volumePath);
  const Volume labels = readNifti(*args.value("--labels"));
  const RetargetedScript r = retargetScript(script, ct, labels, label, std::filesystem::weakly_canonical(std::filesystem::absolute(volumePath)).string());
  writeSessionScript(r.script, *args.value("-o"));
  std::cout << "camera azimuth " << r.azimuthDeg << " deg, elevation " << r.elevationDeg << " deg: " << r.pinchOnOrgan << " of "
            << r.pinchTouches << " pinch fingers and " << r.onOrgan << " of " << r.touchDowns << " touch-downs on label " << label << "\nwrote "
            << *args.value("-o") << "\n";
  return 0;
}

int cmdCompose(const Words& words) {
  Args args(words, {"--volume", "--labels", "--organ", "--anchor", "--size", "--preset", "-o"}, {});
  if (args.help() || !args.positional().empty() || !args.value("--volume") || !args.value("--labels") || !args.value("--organ") ||
      !args.value("--anchor") || !args.value("-o")) {
    usageStream(args) << "usage: handson compose --volume CT --labels LABELS.nii.gz --organ N --anchor M -o OUT.json [--size WxH] [--preset P]\n"
                         "  Writes the whole touch workflow of a session for that volume, every touch placed on its anatomy\n"
                         "  (label N: the organ selected and moved; label M: a structure fixed and pulled against): orbit\n"
                         "  into the view with one finger, pinch-select both, tilt the organ with three fingers, drag it\n"
                         "  with one and with two, idle the anchor, tap the organ, union/difference with undo and redo,\n"
                         "  orbit, reset the view, export. The view is chosen among directions every 30 degrees (elevation\n"
                         "  0, +-25) by CPU depth picks, so that both structures are visible with room for the fingers.\n"
                         "  Then 'handson replay OUT.json' plays it. Default size 512x512.\n";
    return args.help() ? 0 : 2;
  }
  ComposeOptions o;
  o.organ = int(args.integer("--organ", 0, 0, 65535));
  o.anchor = int(args.integer("--anchor", 0, 0, 65535));
  o.preset = args.valueOr("--preset", "");
  if (auto s = args.value("--size")) parseSize(*s, o.viewport.width, o.viewport.height);
  const std::string volumePath = *args.value("--volume");
  const Volume ct = loadVolume(volumePath);
  const Volume labels = readNifti(*args.value("--labels"));
  const ComposedSession c = composeFullSession(ct, labels, o, std::filesystem::weakly_canonical(std::filesystem::absolute(volumePath)).string());
  writeSessionScript(c.script, *args.value("-o"));
  std::cout << "view azimuth " << c.azimuthDeg << " deg, elevation " << c.elevationDeg << " deg, " << c.mmPerPx << " mm per px at the organ; organ at ("
            << c.organPx.x << ", " << c.organPx.y << ") px with " << c.organRadiusPx << " px of room, anchor at (" << c.anchorPx.x << ", "
            << c.anchorPx.y << ") px with " << c.anchorRadiusPx << " px; " << c.handleRadiusPx << " px of room on the organ's selection\n"
            << (c.clipPlane.empty() ? "" : "exposed by the " + c.script.preset + " -> " + c.preset + " presets and the clip plane " + c.clipPlane + "\n")
            << c.script.events.size() << " events, " << c.script.duration() << " s\nwrote " << *args.value("-o") << "\n";
  return 0;
}

int cmdStressGestures(const Words& words) {
  Args args(words, with({"--sequences", "--seed", "--size", "--volume", "--device", "--script-out"}, kSimOptions), {"--validation", "--quiet"});
  if (args.help() || !args.positional().empty()) {
    usageStream(args) << "usage: handson stress-gestures [--sequences N] [--seed S] [--size WxH] [--volume PATH] [--sim on|off]\n"
                         "                               [--validation] [--script-out FILE.json]\n"
                         "  Plays a random stream of N gesture sequences (default 1000) through the whole headless pipeline,\n"
                         "  four frames each: 1-3 and up to 20 fingers, NaN and out-of-window coordinates, lost lifts, taps\n"
                         "  during drags, mode switches and handle edits mid-gesture (app/tools/gesture_stress.h). Fails (exit 1)\n"
                         "  if any handle's pose or the camera ends non-finite, or on a validation message. Default: the\n"
                         "  phantom at 4 mm, 96x96, simulation off. --script-out writes the stream (NaN becomes null there).\n";
    return args.help() ? 0 : 2;
  }
  GestureStreamOptions g;
  g.sequences = int(args.integer("--sequences", 1000, 0, 10'000'000));
  g.seed = std::uint32_t(args.integer("--seed", 1, 0, 4294967295L));
  if (auto s = args.value("--size")) parseSize(*s, g.viewport.width, g.viewport.height);
  ReplayOptions o;
  o.scriptData = randomGestureStream(g);
  if (auto out = args.value("--script-out")) writeSessionScript(*o.scriptData, *out);
  // Default scene: the phantom at 4 mm (fast on lavapipe), written to a temporary file.
  const std::filesystem::path scratch = std::filesystem::temp_directory_path() / ("handson_stress_" + std::to_string(::getpid()));
  std::filesystem::create_directories(scratch);
  o.volume = args.valueOr("--volume", "");
  if (o.volume.empty()) {
    PhantomOptions po;
    po.spacingMm = 4.0;
    o.volume = (scratch / "phantom-4mm.nii.gz").string();
    writeNifti(makePhantom(po).ct, o.volume);
  }
  // Four frames a sequence: the touch-downs' picks are answered before the moves and lifts.
  o.fps = 4.0 / g.secondsPerSequence;
  o.device = args.valueOr("--device", "");
  o.validation = args.flag("--validation");
  o.quiet = args.flag("--quiet");
  o.printHandles = true;
  o.printCamera = true;
  o.exportDir = (scratch / "exports").string();
  o.sim = simOptions(args);
  o.sim.enabled = args.valueOr("--sim", "off") == "on";  // off unless asked for
  std::cout << g.sequences << " sequences, " << o.scriptData->events.size() << " events\n";
  int rc = 1;
  try {
    rc = runReplay(o);
  } catch (...) {
    std::error_code ec;
    std::filesystem::remove_all(scratch, ec);
    throw;
  }
  std::error_code ec;
  std::filesystem::remove_all(scratch, ec);
  if (rc == 0) std::cout << "every handle and the camera finite\n";
  return rc;
}

int cmdSoak(const Words& words) {
  Args args(words, with({"--frames", "--size", "--fps", "--sample-every", "--tolerance", "--out", "--device", "--script-out"}, kSimOptions),
            {"--no-validation", "--quiet"});
  if (args.help() || !args.positional().empty()) {
    usageStream(args) << "usage: handson soak [--frames N] [--size WxH] [--fps F] [--sample-every K] [--tolerance T] [--out DIR]\n"
                         "                   [--sim on|off] [--no-validation] [--quiet] [--script-out FILE.json]\n"
                         "  Replays a long session on the default phantom (app/tools/soak.h): the kidney pinch-selected, then\n"
                         "  dragged and the drag undone, redone and undone, tapped, the view orbited and zoomed and back,\n"
                         "  cycle after cycle, for N frames (default 10000, 256x256, 20 fps of script time, simulation on,\n"
                         "  validation on). Measures resident memory and the live Vulkan device memory every frame; writes\n"
                         "  a row every K frames (default 100; the largest values since the last) to DIR/soak.csv and\n"
                         "  DIR/soak.png (default soak-out). Fails (exit 1) if the largest after the warm-up (a tenth of the\n"
                         "  frames) exceed by more than T (default 0.05) the largest over the warm-up's last cycle, or on a\n"
                         "  validation message. --script-out writes the gesture script (replayable with handson replay).\n";
    return args.help() ? 0 : 2;
  }
  SoakOptions o;
  o.frames = int(args.integer("--frames", 10000, 10, 10'000'000));
  if (auto s = args.value("--size")) parseSize(*s, o.width, o.height);
  o.fps = args.number("--fps", 20.0, 1.0, 1000.0);
  o.sampleEvery = int(args.integer("--sample-every", 100, 1, 1'000'000));
  o.tolerance = args.number("--tolerance", 0.05, 0.0, 10.0);
  o.outDir = args.valueOr("--out", "soak-out");
  o.device = args.valueOr("--device", "");
  o.validation = !args.flag("--no-validation");
  o.quiet = args.flag("--quiet");
  o.sim = simOptions(args);
  if (auto out = args.value("--script-out")) writeSessionScript(soakScript(o.frames, o.fps), *out);
  return runSoak(o);
}

// Without a display: the product, headless - the full session on the phantom (the kidney pinched,
// tilted and dragged with the tissue deforming around it, handle edits, an orbit, an export),
// written as frames, a contact sheet, the timing log and the exported session and volume.
int cmdDefault(const Words& words) {
  if (displayAvailable()) return cmdView(words);
  Args args(words, with({"--frames-out", "--timings", "--fps", "--size", "--device"}, kSimOptions), {"--validation", "--quiet"});
  if (args.help()) {
    std::cout << "usage: handson [--frames-out DIR] [--size WxH (256x256)] [--fps F (4)] [--timings LOG.csv] [--sim ...as view] [--device NAME]\n"
                 "  With a display: the touch app on the phantom (handson view --help). Without one: the headless\n"
                 "  demo - the built-in full session (assets/gestures/full-session.json) replayed with the\n"
                 "  simulation on; DIR (default handson-demo) gets its frames, contact-sheet.png, timings.csv and\n"
                 "  export/ (the session, the deformed volume, the mesh and a screenshot).\n"
              << kSimHelp;
    return 0;
  }
  if (!args.positional().empty()) throw UsageError("unexpected argument '" + args.positional()[0] + "'");
  std::cerr << "no display available: running the headless demo - the full session on the built-in phantom (the right kidney\n"
               "pinched, tilted and dragged with the tissue deforming around it, handle edits, an orbit, an export)\n";
  ReplayOptions o;
  o.scriptData = builtInFullSessionScript();
  o.framesOut = args.valueOr("--frames-out", "handson-demo");
  o.timings = args.valueOr("--timings", o.framesOut + "/timings.csv");
  // 4 frames a second of the 6.4 s session at 256x256: under 2 minutes on a 2-core machine without
  // a GPU (lavapipe raymarches the 2 mm phantom in 1-2 s a frame), simulation included.
  o.fps = args.number("--fps", 4.0, 0.01, 1000.0);
  o.width = o.height = 256;
  if (auto s = args.value("--size")) parseSize(*s, o.width, o.height);
  o.device = args.valueOr("--device", "");
  o.validation = args.flag("--validation");
  o.quiet = args.flag("--quiet");
  o.exportDir = (std::filesystem::path(o.framesOut) / "export").string();
  o.sim = simOptions(args);
  const int rc = runReplay(o);
  if (rc != 0) return rc;
  std::vector<std::string> frames;
  for (const auto& e : std::filesystem::directory_iterator(o.framesOut))
    if (e.path().extension() == ".png" && e.path().filename().string().rfind("frame_", 0) == 0) frames.push_back(e.path().string());
  std::sort(frames.begin(), frames.end());
  const std::string sheet = (std::filesystem::path(o.framesOut) / "contact-sheet.png").string();
  writeContactSheet(frames, sheet);
  std::cout << "open " << sheet << " (the session at a glance); the frames, timings.csv and export/ (session, deformed volume,\n"
            << "mesh, screenshot) are in " << o.framesOut << "/\n";
  return 0;
}

}  // namespace handson::cli
