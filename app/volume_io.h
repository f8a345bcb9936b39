#pragma once
// Opening a volume from a path: a DICOM series directory or a NIfTI file (.nii, .nii.gz).
#include <string>
#include <vector>

#include "sim/progress.h"
#include "sim/volume.h"

namespace handson {

struct LoadReport {
  std::string format;                 ///< "NIfTI" or "DICOM"
  std::vector<std::string> warnings;  ///< e.g. several series, slice gaps
};

/// Throws handson::Error with a clear message on a missing path or unreadable data.
Volume loadVolume(const std::string& path, LoadReport* report = nullptr, const ProgressFn& progress = {});

}  // namespace handson
