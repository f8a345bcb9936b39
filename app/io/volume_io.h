#pragma once
#include <cstdint>
#include <optional>
#include <vector>
// Opening a volume from a path: a DICOM series directory, one DICOM file (its directory's series
// with that file's SeriesInstanceUID), or a NIfTI file (.nii, .nii.gz, a .hdr/.img pair). A file's
// format is told by its content (DICOM preamble "DICM" or a leading DICOM group, NIfTI header size,
// gzip, NRRD and MetaImage signatures), not by its name.
#include <string>
#include <vector>

#include "interaction/label_map.h"
#include "sim/base/progress.h"
#include "sim/volume.h"

namespace handson {

struct LoadReport {
  std::string format;                 ///< "NIfTI" or "DICOM (transfer syntax)"
  std::vector<std::string> warnings;  ///< e.g. several series, slice gaps, a 4D image
  std::int64_t frames = 1;            ///< 3D volumes in the file (4D NIfTI)
  std::int64_t frame = 0;             ///< the one loaded
};

struct LoadOptions {
  std::int64_t frame = 0;  ///< which 3D volume of a 4D NIfTI image (`--frame N`)
};

/// Throws handson::Error with a clear message on a missing path or unreadable data.
Volume loadVolume(const std::string& path, LoadReport* report = nullptr, const ProgressFn& progress = {}, const LoadOptions& options = {});

/// Writes the volume as NRRD when the path ends in ".nrrd" (any case), else as NIfTI (gzipped when
/// it ends in ".gz"). Throws handson::Error.
void writeVolume(const Volume& volume, const std::string& path);

/// A label map file (any format loadVolume reads) on `grid` (interaction/label_map.h); when it had
/// to be resampled, a warning saying so goes to stderr. Throws handson::Error, naming the path.
LabelMap loadLabelMap(const std::string& path, const VolumeGeometry& grid);

/// What a file holds, from its first bytes: "dicom", "nifti" (or gzip, read as NIfTI), "nrrd",
/// "metaimage", or "" when it is none of them (or cannot be read).
std::string sniffVolumeFormat(const std::string& path);

/// Linear indices of a NIfTI mask's voxels that are non-zero (or equal to `label`), on the image's
/// grid. Throws handson::Error, naming `what` and the path, if the grids differ or nothing is selected.
std::vector<std::uint32_t> maskVoxels(const std::string& path, const Volume& image, const char* what, std::optional<long> label);

/// An image and one handle's voxels, for the simulation benchmarks: `path` empty, the built-in
/// phantom at `phantomSpacingMm` with its right kidney; else the file and the mask's voxels (equal to
/// `label` when given). Throws handson::Error when the handle selects no voxel.
struct HandleScene {
  Volume image;
  std::vector<std::uint32_t> handle;
};
HandleScene loadHandleScene(const std::string& path, const std::string& mask, std::optional<long> label, double phantomSpacingMm,
                            const ProgressFn& progress);

}  // namespace handson
