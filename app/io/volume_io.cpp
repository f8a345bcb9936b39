#include "volume_io.h"

#include <algorithm>
#include <cctype>
#include <array>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <system_error>

#include "app/io/dicom_io.h"
#include "app/io/metaimage_io.h"
#include "app/io/nifti_io.h"
#include "app/io/nrrd_io.h"
#include "app/io/volume_import.h"
#include "sim/base/error.h"
#include "sim/phantom.h"

namespace handson {

void writeVolume(const Volume& volume, const std::string& path) {
  std::string lower = path;
  std::transform(lower.begin(), lower.end(), lower.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  const auto ends = [&](const char* suffix) {
    const std::size_t n = std::strlen(suffix);
    return lower.size() >= n && lower.compare(lower.size() - n, n, suffix) == 0;
  };
  if (ends(".nrrd")) writeNrrd(volume, path);
  else if (ends(".mha")) writeMetaImage(volume, path);
  else if (ends(".mhd"))
    throw Error("Cannot write '" + path + "': MetaImage is written as one file (.mha); a .mhd header with a detached data file is not written");
  else writeNifti(volume, path);
}

namespace {

// A MetaImage header's first line is "Key = value" with one of the format's leading keys.
bool isMetaImageHeader(const unsigned char* b, std::size_t n) {
  const std::string head(reinterpret_cast<const char*>(b), n);
  const std::size_t eq = head.find('=');
  if (eq == std::string::npos || head.find('\n') < eq) return false;
  std::string key = head.substr(0, eq);
  while (!key.empty() && (key.back() == ' ' || key.back() == '\t')) key.pop_back();
  for (const char* k : {"ObjectType", "ObjectSubType", "Comment", "NDims", "Name", "ID", "ParentID", "AcquisitionDate", "FormatVersion"})
    if (key == k) return true;
  return false;
}

}  // namespace

LabelMap loadLabelMap(const std::string& path, const VolumeGeometry& grid) {
  try {
    LabelMap m = labelsOnGrid(loadVolume(path), grid);
    if (!m.note.empty()) std::cerr << "warning: " << path << ": " << m.note << "\n";
    return m;
  } catch (const Error& e) {
    const std::string what = e.what();
    throw Error(what.find(path) == std::string::npos ? "labels '" + path + "': " + what : what);
  }
}

std::string sniffVolumeFormat(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::array<unsigned char, 132> b{};
  in.read(reinterpret_cast<char*>(b.data()), std::streamsize(b.size()));
  const std::size_t got = std::size_t(std::max<std::streamsize>(0, in.gcount()));
  const auto starts = [&](const char* magic) { return got >= std::strlen(magic) && std::memcmp(b.data(), magic, std::strlen(magic)) == 0; };
  if (got >= 132 && std::memcmp(b.data() + 128, "DICM", 4) == 0) return "dicom";
  if (got >= 2 && b[0] == 0x1f && b[1] == 0x8b) return "nifti";  // gzip: .nii.gz, .hdr.gz
  if (got >= 4) {
    std::int32_t size = 0;
    std::memcpy(&size, b.data(), 4);
    const std::int32_t swapped = std::int32_t(__builtin_bswap32(std::uint32_t(size)));
    if (size == 348 || size == 540 || swapped == 348 || swapped == 540) return "nifti";
  }
  if (starts("NRRD000")) return "nrrd";
  if (isMetaImageHeader(b.data(), got)) return "metaimage";
  // DICOM without the preamble (ACR-NEMA style, or stripped): a little-endian group 0x0002 or
  // 0x0008 tag first.
  if (got >= 8 && (b[0] == 0x02 || b[0] == 0x08) && b[1] == 0x00 && b[3] == 0x00) return "dicom";
  return {};
}

Volume loadVolume(const std::string& path, LoadReport* report, const ProgressFn& progress, const LoadOptions& options) {
  std::error_code ec;
  const auto status = std::filesystem::status(path, ec);
  if (ec || !std::filesystem::exists(status)) throw Error("'" + path + "' does not exist");
  const std::string kind = std::filesystem::is_directory(status) ? std::string("dicom") : sniffVolumeFormat(path);
  if (kind == "dicom") {
    // A directory, or one of its files: that file's series.
    const bool file = !std::filesystem::is_directory(status);
    const std::string directory = file ? std::filesystem::absolute(path).parent_path().string() : path;
    if (options.frame != 0) throw Error("--frame selects a volume of a 4D NIfTI image; '" + path + "' is a DICOM series");
    DicomReadReport dr;
    Volume v = readDicomSeries(directory, &dr, progress, file ? path : std::string());
    if (report) {
      report->format = "DICOM (" + dr.transferSyntax + ")";
      report->warnings = dr.warnings;
    }
    return v;
  }
  if (kind == "metaimage") {
    reportProgress(progress, 0.0, "reading MetaImage");
    MetaImageInfo info;
    Volume v = readMetaImage(path, options.frame, &info);
    reportProgress(progress, 1.0, "reading MetaImage");
    if (report) {
      report->format = std::string("MetaImage (") + (info.dataFile == "LOCAL" ? "one file" : "data in " + info.dataFile) +
                       (info.compressed ? ", compressed)" : ")");
      reportFrames(*report, path, info.frames, options.frame);
    }
    return v;
  }
  if (kind == "nrrd") {
    reportProgress(progress, 0.0, "reading NRRD");
    NrrdInfo info;
    Volume v = readNrrd(path, options.frame, &info);
    reportProgress(progress, 1.0, "reading NRRD");
    if (report) {
      report->format = "NRRD" + (info.space.empty() ? std::string() : " (" + info.space + " space)");
      reportFrames(*report, path, info.frames, options.frame);
    }
    return v;
  }
  reportProgress(progress, 0.0, "reading NIfTI");
  NiftiInfo info;
  Volume v;
  try {
    v = readNifti(path, NiftiReadOptions{options.frame}, &info);
  } catch (const Error& e) {
    if (!kind.empty()) throw;
    throw Error(std::string(e.what()) + "; nor is it DICOM, NRRD or MetaImage (its first bytes match none of them)");
  }
  reportProgress(progress, 1.0, "reading NIfTI");
  if (report) {
    report->format = info.twoFile ? "NIfTI (.hdr/.img pair)" : "NIfTI";
    report->frames = info.frames;
    report->frame = options.frame;
    if (info.frames > 1)
      report->warnings.push_back("'" + path + "' holds " + std::to_string(info.frames) + " volumes (a " + std::to_string(info.rank) +
                                 "D image); volume " + std::to_string(options.frame) + " is loaded (choose another with --frame N)");
    if (info.rank < 3) report->warnings.push_back("'" + path + "' is a " + std::to_string(info.rank) + "D image: loaded as one slice");
  }
  return v;
}

std::vector<std::uint32_t> maskVoxels(const std::string& path, const Volume& image, const char* what, std::optional<long> label) {
  const Volume m = loadVolume(path);  // NIfTI, NRRD (.seg.nrrd), ... told by the content
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
