#pragma once
// What the readers built on other libraries (NRRD through Teem) share with the loader: the
// grid from a file's axes, and the values kept the way the NIfTI reader keeps them.
#include <Eigen/Core>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <string>

#include "sim/volume.h"

namespace handson {

/// The grid whose columns of `axes` (RAS, world millimetres per voxel step) and first voxel's
/// centre `origin` are given; `dims` voxels. Throws handson::Error (without a file name) on a zero
/// or non-finite axis or an invalid grid.
VolumeGeometry geometryFromAxes(const Eigen::Matrix3d& axes, const Eigen::Vector3d& origin, const Eigen::Vector3i& dims);

/// The values `value(i)` (i in voxel order) as a volume: UInt8 when the file's type is uint8
/// (`uint8`), Int16 when `integral` and every value fits, else Float32 (infinities clamped to the
/// float range).
Volume volumeFromValues(const VolumeGeometry& g, bool uint8, bool integral, const std::function<double(std::size_t)>& value);

/// The part of a LoadReport a reader of several volumes fills: the count, the one loaded, and a
/// warning naming both when there are several.
struct LoadReport;
void reportFrames(LoadReport& report, const std::string& path, std::int64_t frames, std::int64_t frame);

}  // namespace handson
