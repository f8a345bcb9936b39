#pragma once
// The soak: a long interactive session replayed headless (`handson soak`, tests), watching for
// growth. The right kidney of the default phantom is pinch-selected once; then, cycle after cycle
// (4 s of script time), it is dragged with two fingers and the drag undone, redone and undone, dragged
// with one finger and undone (back at rest, exactly), tapped, the view orbited and zoomed and back —
// everything a session does many times, nothing that legitimately piles up (new handles, exports).
// Every frame the process's resident memory and the Vulkan device memory it holds (live
// vkAllocateMemory allocations and bytes) are measured; after a warm-up (the simulation built, the
// caches and the undo history filled) their largest values must stay within `tolerance` of the
// largest over the warm-up's last cycle, and no validation message may appear.
#include <string>

#include "app/session/deformation_controller.h"
#include "app/session/session_script.h"

namespace handson {

struct SoakOptions {
  int frames = 10000;
  int width = 256, height = 256;
  double fps = 20.0;          ///< script time per frame: 1 / fps (a cycle is 4 s: 80 frames)
  int sampleEvery = 100;
  double warmupFraction = 0.1;  ///< baseline at this fraction of the frames (at least two cycles)
  double tolerance = 0.05;      ///< allowed growth over the baseline
  std::string outDir = "soak-out";  ///< soak.csv and soak.png (with gnuplot)
  std::string device;
  bool validation = true;
  bool quiet = false;
  DeformationOptions sim;
};

/// The soak's gesture script, long enough for `frames` frames at `fps`.
SessionScript soakScript(int frames, double fps);

/// 0 when memory and device memory stayed flat, no validation message appeared and every state
/// stayed finite; 1 otherwise (the growth is named on stderr). Throws Error for bad options.
int runSoak(const SoakOptions& options);

}  // namespace handson
