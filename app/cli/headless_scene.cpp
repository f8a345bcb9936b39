#include "headless_scene.h"

#include <cmath>
#include <iostream>

#include "app/io/volume_io.h"
#include "app/session/clip_framing.h"
#include "render/auto_window.h"
#include "app/session/console.h"
#include "sim/base/error.h"
#include "sim/phantom.h"
#include "sim/resample.h"

namespace handson {

const char* const kRenderOptionsHelp =
    "  --frame N                the volume of a 4D NIfTI image to load (default 0)\n"
    "  --size WxH               output size in pixels (default 512x512)\n"
    "  --preset NAME            transfer function: ct-abdomen, ct-soft-tissue, ct-organs (over value and gradient\n"
    "                           magnitude), ct-bone, mri (default: by value range)\n"
    "  --tf FILE                transfer function file: lines 'value r g b a' (opacity per mm), optionally lines\n"
    "                           'gradient G opacity r g b w' (G in value units per mm, or range fractions per mm\n"
    "                           with 'relative': opacity factor, tint)\n"
    "  --camera AZ,EL[,DIST[,ROLL]]  orbit camera in degrees around the volume centre; DIST in mm\n"
    "                           (0 or omitted: fit the volume, or what a clip leaves of it);\n"
    "                           azimuth 0 = anterior view\n"
    "  --step F                 ray step as a fraction of the smallest voxel spacing (default 0.5)\n"
    "  --clip-box X0,Y0,Z0,X1,Y1,Z1   draw and pick only inside this box (RAS mm)\n"
    "  --clip-plane NX,NY,NZ,D  draw and pick only where NX*x + NY*y + NZ*z >= D (RAS mm); with a clip\n"
    "                           the preset's window follows the clipped region's soft tissue\n"
    "  --no-auto-window         keep the preset's own window with a clip\n"
    "  --voxels N               resample the volume to about N voxels first\n"
    "  --device NAME            Vulkan device: gpu, cpu, an index or a name substring\n"
    "                           (default: discrete > integrated > CPU; env HANDSON_DEVICE)\n"
    "  --validation             enable the Khronos validation layer (env HANDSON_VALIDATION=1)\n"
    "  --jitter-phases N        blue-noise ray-start jitter phases the image averages (default 8, 1..64)\n"
    "  --no-jitter              every ray's samples at the middle of each step (no jitter, one pass)\n"
    "  --no-skip, --no-early-termination, --no-shading   switch off empty-space skipping,\n"
    "                           early ray termination, gradient shading\n";

void parseClipOptions(const cli::Args& args, RenderSettings& rs) {
  if (auto b = args.value("--clip-box"))
    if (const std::string why = parseClipBox(*b, rs.clip); !why.empty()) throw cli::UsageError("--clip-box: " + why);
  if (auto p = args.value("--clip-plane"))
    if (const std::string why = parseClipPlane(*p, rs.clip); !why.empty()) throw cli::UsageError("--clip-plane: " + why);
}

gpu::RenderParams HeadlessScene::params(std::uint32_t pickCount) const {
  const double aspect = double(settings.width) / double(settings.height);
  const glm::dvec3 eye = camera.eye();
  return makeRenderParams(volume.geometry(), camera.view(), camera.projection(aspect), glm::vec3(eye), settings, pickCount);
}

namespace {

/// A clipped view's preset windowed onto the clipped region's soft tissue (render/auto_window.h).
void applyAutoWindow(HeadlessScene& s, bool quiet) {
  const auto w = autoWindowFor(s.volume, s.tf, s.settings.clip);
  if (!w) return;
  s.tf = s.tf.windowed(1.0, w->shift, 1.0);
  s.windowShift = w->shift;
  if (!quiet)
    std::cerr << "automatic window: the clipped region's soft tissue peaks at " << w->peak.value << " +- " << w->peak.halfWidth << " (" << s.tf.name
              << ": level " << (w->shift >= 0 ? "+" : "") << w->shift << ")\n";
}

}  // namespace

HeadlessScene openHeadlessScene(const std::string& path, const cli::Args& args) {
  HeadlessScene s;
  const bool quiet = args.flag("--quiet");
  const ProgressFn progress = quiet ? ProgressFn{} : consoleProgress();
  if (path.empty()) {
    s.volume = makePhantom().ct;
    s.source = "built-in phantom";
  } else {
    LoadReport rep;
    s.volume = loadVolume(path, &rep, progress, cli::loadOptions(args));
    for (const auto& w : rep.warnings) std::cerr << "warning: " << w << "\n";
    s.source = path;
  }
  if (auto n = args.value("--voxels")) {
    const long voxels = args.integer("--voxels", 0, 1, long(kMaxVoxels));
    s.volume = resampleToVoxelCount(s.volume, std::size_t(voxels), progress);
  }
  if (auto size = args.value("--size")) cli::parseSize(*size, s.settings.width, s.settings.height);
  s.settings.stepFactor = float(args.number("--step", 0.5, 0.01, 10.0));
  s.settings.emptySpaceSkipping = !args.flag("--no-skip");
  s.settings.earlyTermination = !args.flag("--no-early-termination");
  s.settings.shading = !args.flag("--no-shading");
  s.settings.jitter = !args.flag("--no-jitter");
  s.jitterPhases = int(args.integer("--jitter-phases", kStillJitterPhases, 1, 64));
  parseClipOptions(args, s.settings);

  if (auto tfPath = args.value("--tf")) {
    s.tf = loadTransferFunction(*tfPath);
  } else {
    s.tf = transferFunctionPreset(args.valueOr("--preset", defaultPresetFor(s.volume)));
    if ((s.settings.clip.box || s.settings.clip.plane) && !args.flag("--no-auto-window")) applyAutoWindow(s, quiet);
  }

  const double aspect = double(s.settings.width) / double(s.settings.height);
  double az = kDefaultAzimuthDeg, el = kDefaultElevationDeg, dist = 0.0, roll = 0.0;
  if (auto cam = args.value("--camera")) {
    const auto v = cli::parseNumberList(*cam, "--camera");
    if (v.size() < 2 || v.size() > 4) throw cli::UsageError("--camera takes AZ,EL[,DIST[,ROLL]]");
    az = v[0];
    el = v[1];
    if (v.size() > 2) dist = v[2];
    if (v.size() > 3) roll = v[3];
    if (dist < 0.0) throw cli::UsageError("--camera: distance must be >= 0");
  }
  s.camera = OrbitCamera::framing(s.volume.geometry(), glm::radians(az), glm::radians(el), aspect);
  if (dist > 0.0) {
    s.camera.distance = dist;
    s.camera.nearPlane = std::max(1e-3, 0.01 * dist);
    s.camera.farPlane = dist + 2.0 * s.volume.geometry().diagonalMm();
  }
  s.camera.roll = glm::radians(roll);
  // A clip without a camera distance frames what it leaves: the clipped part of the volume fills
  // the view (OrbitCamera's direction and roll kept).
  if (dist <= 0.0)
    if (const auto framed = frameClip(s.camera, s.volume.geometry(), s.settings.clip, FramingView{s.settings.width, s.settings.height}))
      s.camera = *framed;

  vk::ContextOptions opts;
  opts.validation = args.flag("--validation");
  opts.device = args.valueOr("--device", "");
  opts.verbose = !quiet;
  s.context = std::make_unique<vk::Context>(opts);
  s.quantized = quantizeVolume(s.volume);
  s.lut = s.tf.lookupTable(s.quantized);
  s.renderer = std::make_unique<VolumeRenderer>(*s.context);
  s.renderer->setVolume(s.quantized, progress);
  s.renderer->setTransferFunction(s.lut);
  return s;
}

}  // namespace handson
