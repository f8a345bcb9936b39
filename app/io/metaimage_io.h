#pragma once
// MetaImage files (.mha with the data in the same file, .mhd with a detached .raw / .zraw file),
// ITK's and its tools' exchange format. The header is parsed by MetaIO (ITK's own reader of the
// format, Debian's libinsighttoolkit5-dev); the data block is read here, because MetaIO 5.2 reports
// success on a truncated data file and on a compressed block that does not inflate (both measured),
// which would be silently wrong values.
//
// Layout: NDims 2 or 3 make the volume (2 a one-slice volume); NDims 4 counts volumes along the
// fourth axis, and several channels per element (ElementNumberOfChannels) count volumes too: `frame`
// picks one. Geometry as ITK reads it: TransformMatrix's rows are the axes' direction cosines,
// ElementSpacing their lengths, Offset (or Position, Origin) the first sample's centre, all in
// ITK's left-posterior-superior space, converted here to RAS+ (x and y negated); AnatomicalOrientation
// is informational (ITK ignores it too). The data: LOCAL (after the header), or one named file
// beside the header, with HeaderSize bytes skipped (-1: the data are the file's last bytes), raw or
// zlib/gzip-compressed, either byte order. Slice lists (ElementDataFile = LIST or a printf pattern)
// are refused. Values as the NIfTI reader keeps them: uint8 -> UInt8, other integers -> Int16 when
// every value fits, else Float32; float and double -> Float32.
//
// Throws handson::Error naming the file on anything it cannot read (MetaIO's own message included).
#include <cstdint>
#include <string>

#include "sim/volume.h"

namespace handson {

struct MetaImageInfo {
  std::int64_t frames = 1;  ///< volumes: the fourth axis's length times the channels
  std::string dataFile;     ///< "LOCAL" or the detached data file's name, as the header gives it
  bool compressed = false;
};

Volume readMetaImage(const std::string& path, std::int64_t frame = 0, MetaImageInfo* info = nullptr);

/// Writes a one-file MetaImage (.mha) with zlib-compressed data, in ITK's left-posterior-superior
/// space, with the volume's type, spacing, directions and origin, through a temporary file renamed
/// into place (a failure leaves nothing). Throws handson::Error.
void writeMetaImage(const Volume& volume, const std::string& path);

}  // namespace handson
