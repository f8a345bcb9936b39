#pragma once
// NRRD files (.nrrd, and .nhdr with detached data; 3D Slicer's .seg.nrrd label maps), read through
// Teem's nrrd library - the format's reference implementation, by its author - for every encoding
// (raw, gzip, bzip2, ASCII, hex), byte order and detached data file.
//
// The image's spatial axes are those with a space direction (all of them when the file gives no
// space); 3 of them make the volume, 2 a one-slice volume (in a 3D space, or in a 2D one: the plane
// z = 0). At most one further axis (a list, vector or time axis: a 4D file, or a segmentation's
// layers) counts volumes: `frame` picks one. Geometry:
// the space directions (spacing = their lengths) and the space origin (the first sample's centre),
// converted to RAS+: left-posterior-superior (DICOM's, Slicer's default) and scanner-xyz negate x and
// y, left-anterior-superior negates x; right-anterior-superior and unnamed 3D spaces are taken as is.
// Without space information: the axes' spacings (1 mm where absent), origin 0, identity directions.
// Values as the NIfTI reader keeps them: uint8 -> UInt8, int16 -> Int16, other integers -> Int16
// when every value fits, else Float32; float and double -> Float32.
//
// Throws handson::Error naming the file on anything it cannot read (Teem's own message included).
#include <cstdint>
#include <string>

#include "sim/volume.h"

namespace handson {

struct NrrdInfo {
  std::int64_t frames = 1;  ///< volumes along the non-spatial axis
  std::string space;        ///< the file's space, as Teem names it ("" when none)
};

Volume readNrrd(const std::string& path, std::int64_t frame = 0, NrrdInfo* info = nullptr);

/// Writes a gzip-encoded NRRD in left-posterior-superior space (3D Slicer's), with the volume's type,
/// space directions and origin, through a temporary file renamed into place (a failure leaves
/// nothing). Throws handson::Error.
void writeNrrd(const Volume& volume, const std::string& path);

}  // namespace handson
