#include "volume_io.h"

#include <filesystem>
#include <system_error>

#include "app/dicom_io.h"
#include "app/nifti_io.h"
#include "sim/error.h"

namespace handson {

Volume loadVolume(const std::string& path, LoadReport* report, const ProgressFn& progress) {
  std::error_code ec;
  const auto status = std::filesystem::status(path, ec);
  if (ec || !std::filesystem::exists(status)) throw Error("'" + path + "' does not exist");
  if (std::filesystem::is_directory(status)) {
    DicomReadReport dr;
    Volume v = readDicomSeries(path, &dr, progress);
    if (report) {
      report->format = "DICOM (" + dr.transferSyntax + ")";
      report->warnings = dr.warnings;
    }
    return v;
  }
  reportProgress(progress, 0.0, "reading NIfTI");
  Volume v = readNifti(path);
  reportProgress(progress, 1.0, "reading NIfTI");
  if (report) report->format = "NIfTI";
  return v;
}

}  // namespace handson
