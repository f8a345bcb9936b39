#pragma once
// Resampling a volume onto a coarser or finer regular grid covering the same physical box.
#include <cstddef>

#include "sim/base/progress.h"
#include "volume.h"

namespace handson {

/// Grid with about `targetVoxels` voxels covering the same box (voxel edges) as `g`, with the same
/// direction and per-axis scale factor cbrt(target / current) (each axis at least 1 voxel).
VolumeGeometry resampledGeometry(const VolumeGeometry& g, std::size_t targetVoxels);

/// Resamples `v` onto `target` (any grid in the same world space): when shrinking, each output
/// voxel averages the input over its footprint (box filter, so no aliasing), else trilinear.
/// Output keeps the input's scalar type. Points outside the input take its nearest edge value.
Volume resample(const Volume& v, const VolumeGeometry& target, const ProgressFn& progress = {});

/// Convenience: resample to about `targetVoxels` voxels.
Volume resampleToVoxelCount(const Volume& v, std::size_t targetVoxels, const ProgressFn& progress = {});

}  // namespace handson
