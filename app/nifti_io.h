#pragma once
// NIfTI file input and output.
//
// readNifti() reads single-file NIfTI-1 ("n+1") and NIfTI-2 ("n+2") images, plain (.nii) or gzip
// compressed (.nii.gz; recognised by the gzip magic bytes, not by the file name), in either byte
// order. The image must be a single 3D volume. Geometry comes from the sform when sform_code > 0,
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
#include <string>

#include "sim/volume.h"

namespace handson {

Volume readNifti(const std::string& path);
void writeNifti(const Volume& volume, const std::string& path);

}  // namespace handson
