#pragma once
// MetaImage files (.mha with the data inside, .mhd with a separate .raw/.zraw), the format ITK and
// 3D Slicer exchange, read through ITK's MetaImageIO (Debian's ITK 5.2) - the format's own library.
//
// A scalar image of 2 or 3 dimensions (2: a one-slice volume), or 4 where the 4th counts volumes
// (`frame` picks one). ITK gives the geometry in its physical space, LPS: x and y are negated into
// RAS+. Values as the NIfTI reader keeps them: uint8 -> UInt8, int16 -> Int16, other integers ->
// Int16 when every value fits, else Float32; float and double -> Float32.
//
// Throws handson::Error naming the file (MetaIO's own messages included) on anything it cannot
// read; the image's size is checked before its data are read.
#include <cstdint>
#include <string>

#include "sim/volume.h"

namespace handson {

struct MetaImageInfo {
  std::int64_t frames = 1;  ///< volumes along a 4th dimension
};

Volume readMetaImage(const std::string& path, std::int64_t frame = 0, MetaImageInfo* info = nullptr);

}  // namespace handson
