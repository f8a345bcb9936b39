#include "volume_io.h"

#include <filesystem>
#include <system_error>

#include "app/dicom_io.h"
#include "app/nifti_io.h"
#include "sim/error.h"
#include "sim/phantom.h"

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

std::vector<std::uint32_t> maskVoxels(const std::string& path, const Volume& image, const char* what, std::optional<long> label) {
  const Volume m = readNifti(path);
  const auto& a = m.geometry();
  const auto& b = image.geometry();
  if (a.dims != b.dims) throw Error(std::string(what) + " " + path + ": its grid is not the image's (dimensions differ)");
  if (!a.sameGrid(b))
    throw Error(std::string(what) + " " + path + ": its grid is not the image's (spacing, origin or orientation differ)");
  std::vector<std::uint32_t> v;
  for (std::size_t i = 0; i < m.voxelCount(); ++i)
    if (label ? m.value(i) == float(*label) : (m.value(i) != 0.0f && !std::isnan(m.value(i)))) v.push_back(std::uint32_t(i));
  if (v.empty()) throw Error(std::string(what) + " " + path + " selects no voxel");
  return v;
}

HandleScene loadHandleScene(const std::string& path, const std::string& mask, std::optional<long> label, double phantomSpacingMm,
                            const ProgressFn& progress) {
  HandleScene sc;
  if (path.empty()) {
    PhantomOptions po;
    po.spacingMm = phantomSpacingMm;
    Phantom ph = makePhantom(po);
    for (std::size_t i = 0; i < ph.labels.voxelCount(); ++i)
      if (ph.labels.value(i) == label::kKidneyRight) sc.handle.push_back(std::uint32_t(i));
    sc.image = std::move(ph.ct);
  } else {
    sc.image = loadVolume(path, nullptr, progress);
    sc.handle = maskVoxels(mask, sc.image, "handle mask", label);
  }
  if (sc.handle.empty()) throw Error("the handle selects no voxel");
  return sc;
}

}  // namespace handson
