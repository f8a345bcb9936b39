#pragma once
// What the headless commands share: open a volume (or the built-in phantom), create the Vulkan
// context and renderer, choose the transfer function and the camera from command-line options.
#include <memory>
#include <optional>
#include <string>

#include "app/cli/args.h"
#include "interaction/camera.h"
#include "render/render_params.h"
#include "render/transfer_function.h"
#include "render/vk_context.h"
#include "render/volume_renderer.h"
#include "sim/volume.h"

namespace handson {

/// Options every rendering command accepts.
inline const std::vector<std::string> kRenderValueOptions = {"--frame", "--size", "--preset", "--tf", "--camera", "--device", "--step", "--voxels",
                                                             "--clip-box", "--clip-plane", "--jitter-phases"};
inline const std::vector<std::string> kRenderFlagOptions = {"--validation", "--no-skip", "--no-early-termination", "--no-shading", "--no-jitter", "--quiet",
                                                           "--no-auto-window"};
extern const char* const kRenderOptionsHelp;

struct HeadlessScene {
  Volume volume;
  std::string source;  ///< path, or "built-in phantom"
  QuantizedVolume quantized;
  TransferFunction tf;
  TfTable lut;
  RenderSettings settings;
  int jitterPhases = kStillJitterPhases;  ///< --jitter-phases: a still image averages this many jitter phases
  OrbitCamera camera;
  double windowShift = 0.0;  ///< the automatic window's level shift (render/auto_window.h; 0: none)
  std::unique_ptr<vk::Context> context;
  std::unique_ptr<VolumeRenderer> renderer;

  gpu::RenderParams params(std::uint32_t pickCount = 0) const;
};

/// --clip-box and --clip-plane into the settings. Throws cli::UsageError on a malformed value.
void parseClipOptions(const cli::Args& args, RenderSettings& rs);

/// path empty: the built-in phantom. Reads --size, --preset, --tf, --camera, --device, --step,
/// --voxels (resample first), --validation, --no-skip, --no-early-termination, --no-shading.
HeadlessScene openHeadlessScene(const std::string& path, const cli::Args& args);

}  // namespace handson
