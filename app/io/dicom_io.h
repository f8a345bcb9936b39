#pragma once
// Reading a DICOM image series (one file per slice) into a handson::Volume, through GDCM.
//
// readDicomSeries() scans one directory (not its subdirectories), groups the DICOM image files by
// SeriesInstanceUID and loads the series with the most files. Slices are ordered by their position
// along the slice normal (ImagePositionPatient projected on ImageOrientationPatient's row x column
// cosine), never by file name or instance number. Pixel data may be uncompressed or compressed in
// any transfer syntax GDCM decodes (JPEG 2000 through OpenJPEG, JPEG, JPEG-LS, RLE...).
// RescaleSlope / RescaleIntercept are applied per slice; the result is int16 when every rescaled
// value is an integer in int16 range (typical CT Hounsfield units), float32 otherwise.
//
// Geometry: DICOM patient coordinates are LPS; the volume is in NIfTI RAS+ millimetres (x and y
// negated). The i axis runs along a row (increasing column index, DICOM row cosine), the j axis
// down the columns (column cosine), the k axis from the first to the last sorted slice. The origin
// is the centre of the first pixel of the first sorted slice. Unevenly spaced slices (steps more than
// 10 % from the median: missing slices, mixed spacing) are resampled onto a regular grid at the
// smallest step, linearly between neighbouring slices, with a warning.
#include <string>
#include <vector>

#include "sim/base/error.h"
#include "sim/base/progress.h"
#include "sim/volume.h"

namespace handson {

struct DicomSeriesInfo {
  std::string seriesInstanceUid;  ///< may be empty when the files carry none
  std::string description;        ///< SeriesDescription (0008,103E), may be empty
  int fileCount = 0;              ///< number of image files of this series in the directory
};

struct DicomReadReport {
  std::vector<DicomSeriesInfo> seriesFound;  ///< every image series in the directory, largest first
  DicomSeriesInfo chosen;                    ///< the series that was loaded
  int slices = 0;                            ///< slices in the volume (after dropping duplicates; resampled if uneven)
  double sliceStepMm = 0.0;                  ///< step along the normal: the median one, or the regular grid's when resampled
  bool spacingGaps = false;                  ///< some step differs from the median by more than 10 %
  double minStepMm = 0.0, maxStepMm = 0.0;   ///< smallest / largest step between adjacent slices
  std::string transferSyntax;                ///< "UID (name)" of the first slice's transfer syntax
  std::vector<std::string> warnings;         ///< things the caller should show the user
};

/// Reads the largest DICOM image series in `directory`. Throws handson::Error with a user-facing
/// message for a missing path, a path that is not a directory, a directory without DICOM images,
/// unreadable or truncated pixel data (naming the file), slices that do not share size, pixel
/// spacing and orientation, or two different images at the same position. `report`, when given,
/// receives what was found and any warnings. `progress` is called once per slice.
///
/// GDCM parses the files in a child process (fork): Debian's GDCM is built with assertions, and some
/// malformed files make it abort. Such an abort, or any other death of the child, ends this call
/// with DicomParserAborted and leaves the calling process (and the user's session) untouched.
/// The volume comes back through a pipe: while it is handed over, it is in memory twice.
/// `seriesOf`: a file in `directory` (its name is enough); its series is loaded instead of the largest.
Volume readDicomSeries(const std::string& directory, DicomReadReport* report = nullptr,
                       const ProgressFn& progress = {}, const std::string& seriesOf = {});

/// GDCM stopped the child process reading a series (an assertion in the library, a signal).
class DicomParserAborted : public Error {
 public:
  DicomParserAborted(const std::string& what, int signal) : Error(what), signal_(signal) {}
  int signal() const { return signal_; }  ///< the signal that ended the child, 0 if it exited
 private:
  int signal_;
};

/// The same reader in this process, without the child: a malformed file may abort the process.
/// For the fuzzer (which needs the coverage of the parsing) and for tests that compare the two.
Volume readDicomSeriesInProcess(const std::string& directory, DicomReadReport* report = nullptr,
                                const ProgressFn& progress = {}, const std::string& seriesOf = {});

}  // namespace handson
