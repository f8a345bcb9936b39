#pragma once
// Every pass the frame graph runs, by an id: callers find a pass's time by its id (the frame
// budget reads the raymarch's), and its name - the timing log's and the benchmarks' column - comes
// from the one table in pass_id.cpp.
#include <cstdint>

namespace handson {

enum class PassId : std::uint8_t {
  Unnamed,  ///< a pass added by name alone (tests, one-off tools)
  // The volume and its bricks.
  BrickMinmax,
  BrickReadback,
  MaskUpload,
  LiveMaskCopy,
  LiveMask,
  // The picture and the picks.
  Raymarch,
  StillFrame,  ///< the raymarch's output shown again (nothing changed): not timed as a raymarch
  Pick,
  PickReadback,
  ImageReadback,
  // Region growing.
  GrowClear,
  GrowSeed,
  GrowRelax,
  GrowResume,
  GrowCompact,
  GrowListReset,
  GrowActiveReadback,
  // The deformation: the fine mesh's positions, the region's resampling, the strain.
  DeformInterpolate,
  DeformReset,
  DeformBounds,
  DeformBricks,
  DeformArgs,
  DeformClear,
  DeformClaim,
  DeformResolve,
  DeformBoxReadback,
  DeformStrain,
  DeformStrainRaster,
  // The window.
  Blit,
  Ui,
  Screenshot,
  Count
};

/// The pass's name ("raymarch", "deform-claim"); "" for Unnamed.
const char* passName(PassId id);

}  // namespace handson
