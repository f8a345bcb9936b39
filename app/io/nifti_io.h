#pragma once
// NIfTI file input and output.
//
// readNifti() reads NIfTI-1 and NIfTI-2 images, single-file ("n+1", "n+2": .nii) or two-file ("ni1",
// "ni2": a .hdr with its data in the .img beside it; either file may be given), each plain or gzip
// compressed (recognised by the gzip magic bytes, not by the file name), in either byte order. A 4D
// (to 7D) image is read one 3D volume at a time (NiftiReadOptions::frame; dims 4 to 7 count the
// volumes in file order); a 1D or 2D image is a volume one voxel thick (a missing axis takes 1 mm and
// the direction completing a right-handed frame). Geometry comes from the sform when sform_code > 0,
// else from the qform when qform_code > 0, else from pixdim alone (origin 0, identity direction).
// Values keep the file's type where Volume can hold it: uint8 -> UInt8, int16 and int8 -> Int16,
// other integer types -> Int16 when every (scaled) value is an integer that fits, else Float32;
// float32/float64 -> Float32. scl_slope / scl_inter are applied (and can turn an integer image into
// Float32).
//
// writeNifti() writes a NIfTI-1 file (gzip compressed if the path ends in ".gz") with the same
// scalar type as the volume, sform_code and qform_code 1 (scanner anatomical), units mm. The file
// is written to a temporary name in the destination directory and renamed into place, so a failed
// export never leaves a partial file behind.
//
// Both throw handson::Error, naming the file and the problem, on any failure.
#include <cstdint>
#include <string>

#include "sim/volume.h"

namespace handson {

struct NiftiReadOptions {
  std::int64_t frame = 0;  ///< the 3D volume of a 4D (or higher) image to read, from 0
};
struct NiftiInfo {
  std::int64_t frames = 1;  ///< 3D volumes in the file
  int rank = 3;             ///< dim[0]
  bool twoFile = false;     ///< a .hdr/.img pair
  std::string dataPath;     ///< the file the values came from
};

/// Throws handson::Error naming the file (a volume beyond the last one included).
Volume readNifti(const std::string& path, const NiftiReadOptions& options = {}, NiftiInfo* info = nullptr);
void writeNifti(const Volume& volume, const std::string& path);

}  // namespace handson
