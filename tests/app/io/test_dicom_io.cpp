// Tests of the DICOM series reader against the real series in ../shared/data (skipped when absent).
#include <gtest/gtest.h>
#include <stdlib.h>
#include <zlib.h>

#include <Eigen/LU>
#include <algorithm>
#include <csignal>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <memory>
#include <set>
#include <string>
#include <vector>

#include "app/io/dicom_io.h"
#include "app/io/volume_io.h"
#include "sim/base/error.h"

#ifndef HANDSON_SHARED_DATA_DIR
#define HANDSON_SHARED_DATA_DIR "../shared/data"
#endif

namespace handson {
namespace {

namespace fs = std::filesystem;

const std::string kDataDir = HANDSON_SHARED_DATA_DIR;
const std::string kIrcadbDicom = kDataDir + "/ircadb1.1/dicom";
const std::string kIrcadbNifti = kDataDir + "/ircadb1.1/ct.nii.gz";
const std::string kJpeg2000Dicom = kDataDir + "/totalseg-small/dicom-jpeg2000";
constexpr int kIrcadbSlices = 129;

bool haveIrcadb() { return fs::is_directory(kIrcadbDicom) && fs::exists(kIrcadbDicom + "/image_0"); }
bool haveJpeg2000() { return fs::is_directory(kJpeg2000Dicom) && !fs::is_empty(kJpeg2000Dicom); }

#define REQUIRE_IRCADB() \
  if (!haveIrcadb()) GTEST_SKIP() << "test data not found: " << kIrcadbDicom
#define REQUIRE_JPEG2000() \
  if (!haveJpeg2000()) GTEST_SKIP() << "test data not found: " << kJpeg2000Dicom

std::string ircadbSlice(int k) { return kIrcadbDicom + "/image_" + std::to_string(k); }

std::vector<std::string> jpeg2000Files() {
  std::vector<std::string> files;
  for (const auto& e : fs::directory_iterator(kJpeg2000Dicom))
    if (e.is_regular_file()) files.push_back(e.path().string());
  std::sort(files.begin(), files.end());
  return files;
}

/// A fresh temporary directory, removed with its contents on destruction.
class TempDir {
 public:
  TempDir() {
    std::string tmpl = (fs::temp_directory_path() / "handson_dicom_XXXXXX").string();
    if (!mkdtemp(tmpl.data())) throw std::runtime_error("mkdtemp failed");
    path_ = tmpl;
  }
  ~TempDir() {
    std::error_code ec;
    fs::remove_all(path_, ec);
  }
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;
  const std::string& path() const { return path_; }
  std::string file(const std::string& name) const { return path_ + "/" + name; }
  void link(const std::string& target, const std::string& name) const {
    fs::create_symlink(fs::absolute(target), file(name));
  }

 private:
  std::string path_;
};

std::string readBytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

void writeBytes(const std::string& path, const std::string& bytes) {
  std::ofstream out(path, std::ios::binary);
  out.write(bytes.data(), std::streamsize(bytes.size()));
}

/// Runs readDicomSeries expecting handson::Error; returns its message.
std::string errorOf(const std::string& dir) {
  try {
    readDicomSeries(dir);
  } catch (const Error& e) {
    return e.what();
  } catch (const std::exception& e) {
    return std::string("UNEXPECTED EXCEPTION TYPE: ") + e.what();
  }
  return "NO ERROR";
}

bool contains(const std::string& text, const std::string& part) { return text.find(part) != std::string::npos; }

bool anyWarningContains(const DicomReadReport& r, const std::string& part) {
  return std::any_of(r.warnings.begin(), r.warnings.end(), [&](const std::string& w) { return contains(w, part); });
}

void expectSameVolume(const Volume& a, const Volume& b) {
  ASSERT_EQ(a.dims(), b.dims());
  ASSERT_EQ(a.type(), b.type());
  EXPECT_TRUE(a.geometry().spacing.isApprox(b.geometry().spacing, 1e-12));
  EXPECT_LT((a.geometry().origin - b.geometry().origin).norm(), 1e-9);
  EXPECT_TRUE(a.geometry().direction.isApprox(b.geometry().direction, 1e-12));
  ASSERT_EQ(a.byteSize(), b.byteSize());
  EXPECT_EQ(std::memcmp(a.bytes(), b.bytes(), a.byteSize()), 0);
}

/// The full ircadb series, read once for the whole test binary.
struct IrcadbRead {
  Volume volume;
  DicomReadReport report;
};
const IrcadbRead& ircadb() {
  static const std::unique_ptr<IrcadbRead> cached = [] {
    auto r = std::make_unique<IrcadbRead>();
    r->volume = readDicomSeries(kIrcadbDicom, &r->report);
    return r;
  }();
  return *cached;
}

/// Reads the ircadb slices `ks` (linked into a temporary directory) as a series of their own.
Volume readIrcadbSlices(const std::vector<int>& ks, DicomReadReport* report = nullptr) {
  TempDir dir;
  for (int k : ks) dir.link(ircadbSlice(k), "image_" + std::to_string(k));
  return readDicomSeries(dir.path(), report);
}

/// Minimal NIfTI-1 (.nii.gz) reader, independent of the project's own: int16 data and the sform.
struct NiftiInt16 {
  int nx = 0, ny = 0, nz = 0;
  Eigen::Matrix4d affine = Eigen::Matrix4d::Identity();
  float slope = 1.0f, inter = 0.0f;
  std::vector<std::int16_t> data;
  float value(int i, int j, int k) const {
    const float raw = float(data[std::size_t(i) + std::size_t(nx) * (std::size_t(j) + std::size_t(ny) * std::size_t(k))]);
    return slope != 0.0f ? raw * slope + inter : raw;
  }
};

NiftiInt16 readNiftiInt16(const std::string& path) {
  NiftiInt16 n;
  gzFile f = gzopen(path.c_str(), "rb");
  if (!f) throw std::runtime_error("cannot open " + path);
  unsigned char h[348];
  if (gzread(f, h, 348) != 348) throw std::runtime_error("short NIfTI header");
  std::int32_t sizeofHdr;
  std::memcpy(&sizeofHdr, h, 4);
  if (sizeofHdr != 348) throw std::runtime_error("not a little-endian NIfTI-1 file");
  std::int16_t dim[8], datatype;
  std::memcpy(dim, h + 40, 16);
  std::memcpy(&datatype, h + 70, 2);
  if (datatype != 4) throw std::runtime_error("NIfTI datatype is not int16");
  float voxOffset;
  std::memcpy(&voxOffset, h + 108, 4);
  std::memcpy(&n.slope, h + 112, 4);
  std::memcpy(&n.inter, h + 116, 4);
  for (int r = 0; r < 3; ++r) {
    float row[4];
    std::memcpy(row, h + 280 + 16 * r, 16);
    for (int c = 0; c < 4; ++c) n.affine(r, c) = row[c];
  }
  n.nx = dim[1];
  n.ny = dim[2];
  n.nz = dim[3];
  std::vector<char> skip(std::size_t(voxOffset) - 348);
  if (!skip.empty() && gzread(f, skip.data(), unsigned(skip.size())) != int(skip.size()))
    throw std::runtime_error("short NIfTI extension");
  n.data.resize(std::size_t(n.nx) * std::size_t(n.ny) * std::size_t(n.nz));
  const std::size_t bytes = n.data.size() * 2;
  if (gzread(f, n.data.data(), unsigned(bytes)) != int(bytes)) throw std::runtime_error("short NIfTI data");
  gzclose(f);
  return n;
}

// ---------------------------------------------------------------------------------------------
// Errors for unusable paths.

TEST(DicomIo, MissingPathThrows) {
  const std::string msg = errorOf("/nonexistent/handson/dicom");
  EXPECT_TRUE(contains(msg, "does not exist")) << msg;
}

TEST(DicomIo, FilePathIsNotADirectory) {
  REQUIRE_IRCADB();
  const std::string msg = errorOf(ircadbSlice(0));
  EXPECT_TRUE(contains(msg, "not a directory")) << msg;
  EXPECT_TRUE(contains(msg, "directory that holds")) << msg;
}

TEST(DicomIo, EmptyDirectoryThrows) {
  TempDir dir;
  const std::string msg = errorOf(dir.path());
  EXPECT_TRUE(contains(msg, "no DICOM images")) << msg;
}

TEST(DicomIo, DirectoryWithOnlySubdirectoriesSuggestsOne) {
  TempDir dir;
  fs::create_directory(dir.file("series1"));
  const std::string msg = errorOf(dir.path());
  EXPECT_TRUE(contains(msg, "no DICOM images")) << msg;
  EXPECT_TRUE(contains(msg, "series1")) << msg;
}

TEST(DicomIo, TextFileNamedDcmThrows) {
  TempDir dir;
  writeBytes(dir.file("x.dcm"), "This is not a DICOM file, only some text.\nSecond line.\n");
  const std::string msg = errorOf(dir.path());
  EXPECT_TRUE(contains(msg, "no DICOM images")) << msg;
}

TEST(DicomIo, ASliceThatIsNotOneGrayscaleSampleIsRefusedBeforeDecoding) {
  // Found by fuzz_dicom: an unknown photometric interpretation made GDCM's pixmap reader assert
  // (abort the process). The fuzzers' seed slice (tests/fuzz/make_seeds.py) reads; the same slice
  // with "MONOCHROME2" replaced by "PALETTE COL" is one clear error.
  const std::string seed = readBytes(std::string(HANDSON_SOURCE_DIR) + "/tests/fuzz/corpus/dicom/one-slice.dcm");
  {
    TempDir dir;
    writeBytes(dir.file("a.dcm"), seed);
    const Volume v = readDicomSeries(dir.path());
    EXPECT_EQ(v.dims(), Eigen::Vector3i(5, 6, 1));
  }
  std::string bad = seed;
  const auto at = bad.find("MONOCHROME2");
  ASSERT_NE(at, std::string::npos);
  bad.replace(at, 11, "PALETTE COL");
  TempDir dir;
  writeBytes(dir.file("a.dcm"), bad);
  const std::string msg = errorOf(dir.path());
  EXPECT_TRUE(contains(msg, "photometric interpretation 'PALETTE COL'")) << msg;
  EXPECT_TRUE(contains(msg, "a.dcm")) << msg;
  // Also found by fuzz_dicom: SamplesPerPixel over 4 made GDCM assert. Five samples: refused.
  std::string five = seed;
  const std::string spp("\x28\x00\x02\x00US\x02\x00\x01\x00", 10);
  const auto sppAt = five.find(spp);
  ASSERT_NE(sppAt, std::string::npos);
  five[sppAt + 8] = 5;
  TempDir dir5;
  writeBytes(dir5.file("b.dcm"), five);
  const std::string msg5 = errorOf(dir5.path());
  EXPECT_TRUE(contains(msg5, "pixel format")) << msg5;
  EXPECT_TRUE(contains(msg5, "samples per pixel 5")) << msg5;
  // And an ACR-NEMA recognition code GDCM does not know (it asserts): refused.
  std::string acr = seed;
  const std::string sopClass("\x08\x00\x16\x00UI", 6);
  const auto sopAt = acr.find(sopClass, 132 + 12);  // the dataset's first element, after the meta group
  ASSERT_NE(sopAt, std::string::npos);
  acr.insert(sopAt, std::string("\x08\x00\x10\x00SH\x08\x00XYZ-NEMA", 16));
  TempDir dirAcr;
  writeBytes(dirAcr.file("c.dcm"), acr);
  const std::string msgAcr = errorOf(dirAcr.path());
  EXPECT_TRUE(contains(msgAcr, "recognition code 'XYZ-NEMA'")) << msgAcr;
}

TEST(DicomIo, AnAssertionInsideGdcmRefusesTheSeriesAndLeavesTheCallerRunning) {
  // Debian's GDCM keeps its assertions: a pixel-module attribute with an incompatible VR makes its
  // Attribute<>::SetFromDataElement assert (gdcmAttribute.h:445, found by fuzz_dicom), in the header
  // scan or while decoding. GDCM runs in a child process: the abort is this one refused series.
  const std::string seed = readBytes(std::string(HANDSON_SOURCE_DIR) + "/tests/fuzz/corpus/dicom/one-slice.dcm");
  auto withVr = [&](const std::string& tag, const char* vr) {
    std::string s = seed;
    const auto at = s.find(tag + "US", 132);
    EXPECT_NE(at, std::string::npos);
    if (at != std::string::npos) s.replace(at + 4, 2, vr);
    return s;
  };
  // Planar configuration (0028,0006), absent from the seed: inserted before Rows, in tag order.
  auto withPlanar = [&](const std::string& element) {
    std::string s = seed;
    const auto at = s.find(std::string("\x28\x00\x10\x00US", 6), 132);
    EXPECT_NE(at, std::string::npos);
    if (at != std::string::npos) s.insert(at, element);
    return s;
  };
  const std::pair<const char*, std::string> cases[] = {
      {"HighBit as SS", withVr(std::string("\x28\x00\x02\x01", 4), "SS")},
      {"HighBit as FL", withVr(std::string("\x28\x00\x02\x01", 4), "FL")},
      {"Rows as SS", withVr(std::string("\x28\x00\x10\x00", 4), "SS")},
      {"PlanarConfiguration as DS", withPlanar(std::string("\x28\x00\x06\x00" "DS\x02\x00" "1 ", 10))},
      {"PlanarConfiguration as FL", withPlanar(std::string("\x28\x00\x06\x00" "FL\x04\x00\x00\x00\x80\x3f", 12))},
  };
  for (const auto& [name, bytes] : cases) {
    TempDir dir;
    writeBytes(dir.file("a.dcm"), bytes);
    try {
      readDicomSeries(dir.path());
      ADD_FAILURE() << name << ": read";
    } catch (const DicomParserAborted& e) {
      EXPECT_EQ(e.signal(), SIGABRT) << name;
      EXPECT_TRUE(contains(e.what(), "GDCM, the DICOM library, stopped on a malformed file")) << name << ": " << e.what();
      EXPECT_TRUE(contains(e.what(), dir.path())) << e.what();
    } catch (const std::exception& e) {
      ADD_FAILURE() << name << ": " << e.what();
    }
  }
  // This process is unharmed: the seed still reads, through the child and in process alike.
  TempDir dir;
  writeBytes(dir.file("a.dcm"), seed);
  const Volume a = readDicomSeries(dir.path());
  const Volume b = readDicomSeriesInProcess(dir.path());
  expectSameVolume(a, b);
}

TEST(DicomIo, TheChildProcessHandsBackTheSameVolumeReportAndProgress) {
  REQUIRE_IRCADB();
  DicomReadReport isolated, direct;
  std::vector<double> fractions;
  const Volume a = readDicomSeries(kIrcadbDicom, &isolated, [&](double f, const std::string&) { fractions.push_back(f); });
  const Volume b = readDicomSeriesInProcess(kIrcadbDicom, &direct);
  expectSameVolume(a, b);
  EXPECT_EQ(isolated.slices, direct.slices);
  EXPECT_EQ(isolated.sliceStepMm, direct.sliceStepMm);
  EXPECT_EQ(isolated.transferSyntax, direct.transferSyntax);
  EXPECT_EQ(isolated.warnings, direct.warnings);
  ASSERT_EQ(isolated.seriesFound.size(), direct.seriesFound.size());
  EXPECT_EQ(isolated.chosen.seriesInstanceUid, direct.chosen.seriesInstanceUid);
  EXPECT_EQ(isolated.chosen.fileCount, direct.chosen.fileCount);
  // Progress from the child arrives in the caller: one report a slice, ending at 1.
  ASSERT_GE(fractions.size(), std::size_t(kIrcadbSlices));
  EXPECT_TRUE(std::is_sorted(fractions.begin(), fractions.end()));
  EXPECT_DOUBLE_EQ(fractions.back(), 1.0);
}

// ---------------------------------------------------------------------------------------------
// The uncompressed ircadb series.

TEST(DicomIo, IrcadbGeometryAndType) {
  REQUIRE_IRCADB();
  const Volume& v = ircadb().volume;
  const DicomReadReport& r = ircadb().report;
  EXPECT_EQ(v.dims(), Eigen::Vector3i(512, 512, kIrcadbSlices));
  EXPECT_EQ(v.type(), ScalarType::Int16);
  EXPECT_NEAR(v.geometry().spacing.x(), 0.57, 1e-5);
  EXPECT_NEAR(v.geometry().spacing.y(), 0.57, 1e-5);
  EXPECT_NEAR(v.geometry().spacing.z(), 1.6, 1e-5);
  EXPECT_TRUE(v.geometry().origin.allFinite());
  EXPECT_TRUE(v.geometry().direction.allFinite());
  EXPECT_NEAR(v.geometry().direction.determinant(), 1.0, 1e-9);
  EXPECT_EQ(r.slices, kIrcadbSlices);
  EXPECT_NEAR(r.sliceStepMm, 1.6, 1e-5);
  EXPECT_FALSE(r.spacingGaps);
  EXPECT_NEAR(r.minStepMm, 1.6, 1e-5);
  EXPECT_NEAR(r.maxStepMm, 1.6, 1e-5);
  EXPECT_TRUE(contains(r.transferSyntax, "1.2.840.10008.1.2.1")) << r.transferSyntax;
  ASSERT_EQ(r.seriesFound.size(), 1u);
  EXPECT_EQ(r.chosen.fileCount, kIrcadbSlices);
  EXPECT_FALSE(r.chosen.seriesInstanceUid.empty());
  EXPECT_TRUE(r.warnings.empty()) << r.warnings.front();
  const auto [lo, hi] = v.valueRange();
  EXPECT_EQ(lo, -1024.0f);
  EXPECT_EQ(hi, 1023.0f);
}

// The key orientation cross-check: every sampled DICOM voxel, placed in the world, lands exactly on
// a NIfTI voxel centre holding the same value.
TEST(DicomIo, IrcadbMatchesNiftiCopyAtSamePhysicalPositions) {
  REQUIRE_IRCADB();
  if (!fs::exists(kIrcadbNifti)) GTEST_SKIP() << "test data not found: " << kIrcadbNifti;
  const Volume& v = ircadb().volume;
  const NiftiInt16 nii = readNiftiInt16(kIrcadbNifti);
  const Eigen::Matrix4d worldToNifti = nii.affine.inverse();
  const Eigen::Vector3i d = v.dims();

  std::vector<Eigen::Vector3i> samples;
  for (int c = 0; c < 8; ++c)
    samples.emplace_back((c & 1) ? d.x() - 1 : 0, (c & 2) ? d.y() - 1 : 0, (c & 4) ? d.z() - 1 : 0);
  std::uint64_t state = 0x9e3779b97f4a7c15ull;
  auto next = [&](int n) {
    state = state * 6364136223846793005ull + 1442695040888963407ull;
    return int((state >> 33) % std::uint64_t(n));
  };
  for (int s = 0; s < 30000; ++s) samples.emplace_back(next(d.x()), next(d.y()), next(d.z()));

  int offGrid = 0, outside = 0, mismatches = 0;
  std::string firstProblem;
  std::set<float> distinct;
  for (const Eigen::Vector3i& idx : samples) {
    const Eigen::Vector3d world = v.geometry().toWorld(idx.cast<double>());
    const Eigen::Vector4d f = worldToNifti * Eigen::Vector4d(world.x(), world.y(), world.z(), 1.0);
    const Eigen::Vector3d fi = f.head<3>();
    const Eigen::Vector3d rounded = fi.array().round().matrix();
    if ((fi - rounded).cwiseAbs().maxCoeff() > 0.01) {
      if (offGrid++ == 0)
        firstProblem = "voxel " + std::to_string(idx.x()) + "," + std::to_string(idx.y()) + "," +
                       std::to_string(idx.z()) + " maps between NIfTI voxels";
      continue;
    }
    const int i = int(rounded.x()), j = int(rounded.y()), k = int(rounded.z());
    if (i < 0 || j < 0 || k < 0 || i >= nii.nx || j >= nii.ny || k >= nii.nz) {
      if (outside++ == 0 && firstProblem.empty())
        firstProblem = "voxel " + std::to_string(idx.x()) + "," + std::to_string(idx.y()) + "," +
                       std::to_string(idx.z()) + " maps outside the NIfTI grid";
      continue;
    }
    const float dv = v.value(idx.x(), idx.y(), idx.z());
    distinct.insert(dv);
    if (dv != nii.value(i, j, k) && mismatches++ == 0 && firstProblem.empty())
      firstProblem = "voxel " + std::to_string(idx.x()) + "," + std::to_string(idx.y()) + "," + std::to_string(idx.z()) +
                     " = " + std::to_string(dv) + " but NIfTI " + std::to_string(i) + "," + std::to_string(j) + "," +
                     std::to_string(k) + " = " + std::to_string(nii.value(i, j, k));
  }
  EXPECT_EQ(offGrid, 0) << firstProblem;
  EXPECT_EQ(outside, 0) << firstProblem;
  EXPECT_EQ(mismatches, 0) << firstProblem;
  EXPECT_GT(distinct.size(), 200u) << "the sample should cover many different values";
}

TEST(DicomIo, ShuffledFileNamesGiveSameVolume) {
  REQUIRE_IRCADB();
  TempDir dir;
  // Reversed numbering, so neither name order nor "image_N" order follows the slice order.
  for (int k = 0; k < kIrcadbSlices; ++k) {
    char name[32];
    std::snprintf(name, sizeof name, "slice_%03d.dcm", kIrcadbSlices - 1 - k);
    dir.link(ircadbSlice(k), name);
  }
  DicomReadReport r;
  const Volume v = readDicomSeries(dir.path(), &r);
  expectSameVolume(v, ircadb().volume);
  EXPECT_EQ(r.slices, kIrcadbSlices);
  EXPECT_FALSE(r.spacingGaps);
}

TEST(DicomIo, MissingMiddleSliceReportsGapAndProgress) {
  REQUIRE_IRCADB();
  TempDir dir;
  constexpr int kCount = 30, kMissing = 15;
  for (int k = 0; k < kCount; ++k)
    if (k != kMissing) dir.link(ircadbSlice(k), "image_" + std::to_string(k));
  std::vector<double> fractions;
  DicomReadReport r;
  const Volume v = readDicomSeries(dir.path(), &r, [&](double f, const std::string& stage) {
    EXPECT_FALSE(stage.empty());
    fractions.push_back(f);
  });
  // Resampled onto the regular 1.6 mm grid: every slice where it was acquired, the missing one
  // interpolated from its neighbours.
  EXPECT_EQ(v.dims().z(), kCount);
  EXPECT_EQ(r.slices, kCount);
  EXPECT_TRUE(r.spacingGaps);
  EXPECT_NEAR(r.minStepMm, 1.6, 1e-5);
  EXPECT_NEAR(r.maxStepMm, 3.2, 1e-5);
  EXPECT_NEAR(r.sliceStepMm, 1.6, 1e-5);
  EXPECT_NEAR(v.geometry().spacing.z(), 1.6, 1e-5);
  EXPECT_TRUE(anyWarningContains(r, "uneven")) << (r.warnings.empty() ? "" : r.warnings.front());
  EXPECT_TRUE(anyWarningContains(r, "resampled onto a regular grid of 30 slices")) << (r.warnings.empty() ? "" : r.warnings.front());
  const Volume full = readIrcadbSlices([] {
    std::vector<int> all;
    for (int k = 0; k < kCount; ++k) all.push_back(k);
    return all;
  }());
  ASSERT_EQ(v.dims(), full.dims());
  EXPECT_TRUE(v.geometry().spacing.isApprox(full.geometry().spacing, 1e-9));
  EXPECT_LT((v.geometry().origin - full.geometry().origin).norm(), 1e-9);
  EXPECT_TRUE(v.geometry().direction.isApprox(full.geometry().direction, 1e-9));
  const std::size_t slice = 512 * 512;
  for (int k = 0; k < kCount; ++k) {
    if (k == kMissing) continue;
    EXPECT_EQ(std::memcmp(v.data<std::int16_t>() + k * slice, full.data<std::int16_t>() + k * slice, slice * 2), 0) << "slice " << k;
  }
  const std::int16_t* f = full.data<std::int16_t>();
  for (std::size_t p = 0; p < slice; p += 997) {
    const double mean = 0.5 * (double(f[(kMissing - 1) * slice + p]) + double(f[(kMissing + 1) * slice + p]));
    EXPECT_LE(std::abs(double(v.data<std::int16_t>()[kMissing * slice + p]) - mean), 0.5) << p;
  }
  // Progress: at least one call per slice, non-decreasing, ending at 1.
  ASSERT_GE(fractions.size(), std::size_t(kCount - 1));
  EXPECT_TRUE(std::is_sorted(fractions.begin(), fractions.end()));
  EXPECT_DOUBLE_EQ(fractions.back(), 1.0);
}

TEST(DicomIo, TruncatedSliceThrowsNamingFile) {
  REQUIRE_IRCADB();
  TempDir dir;
  for (int k = 0; k < 5; ++k) dir.link(ircadbSlice(k), "image_" + std::to_string(k));
  const std::string bytes = readBytes(ircadbSlice(5));
  ASSERT_GT(bytes.size(), 4000u);
  // Cut in half (inside the pixel data), inside the file meta information and the data set header
  // (where GDCM itself would abort on an assertion), and with only the last few bytes missing.
  const std::size_t cuts[] = {bytes.size() / 2, 140, 300, 1000, bytes.size() - 10};
  for (const std::size_t cut : cuts) {
    const std::string name = "cut_at_" + std::to_string(cut);
    writeBytes(dir.file(name), bytes.substr(0, cut));
    const std::string msg = errorOf(dir.path());
    EXPECT_TRUE(contains(msg, name)) << msg;
    EXPECT_TRUE(contains(msg, "truncated")) << msg;
    fs::remove(dir.file(name));
  }
}

TEST(DicomIo, TruncatedOrCorruptJpeg2000SliceThrowsNamingFile) {
  REQUIRE_JPEG2000();
  TempDir dir;
  const std::vector<std::string> files = jpeg2000Files();
  ASSERT_GE(files.size(), 6u);
  for (int k = 0; k < 5; ++k) dir.link(files[k], "j2k_" + std::to_string(k));
  const std::string bytes = readBytes(files[5]);
  writeBytes(dir.file("j2k_cut_in_half"), bytes.substr(0, bytes.size() / 2));
  const std::string msg = errorOf(dir.path());
  EXPECT_TRUE(contains(msg, "j2k_cut_in_half")) << msg;
  fs::remove(dir.file("j2k_cut_in_half"));
#ifndef __SANITIZE_ADDRESS__
  // Complete file structure, but the JPEG 2000 code stream's header (SOC + SIZ markers) destroyed:
  // the decoder itself must fail, and the reader report it. (Skipped under AddressSanitizer: GDCM's
  // JPEG 2000 codec leaks its OpenJPEG decoder on this error path, which LeakSanitizer reports.)
  std::string corrupt = bytes;
  const std::size_t soc = corrupt.find(std::string("\xff\x4f\xff\x51", 4));
  ASSERT_NE(soc, std::string::npos);
  std::fill_n(corrupt.begin() + std::ptrdiff_t(soc), 64, '\0');
  writeBytes(dir.file("j2k_bad_codestream"), corrupt);
  const std::string msg2 = errorOf(dir.path());
  EXPECT_TRUE(contains(msg2, "j2k_bad_codestream")) << msg2;
  EXPECT_TRUE(contains(msg2, "decode")) << msg2;
#endif
}

// Two series in one directory: ircadb's first 10 slices (image_0..9) and 3 JPEG 2000 slices
// (other_0..2).
void linkTwoSeries(const TempDir& dir) {
  for (int k = 0; k < 10; ++k) dir.link(ircadbSlice(k), "image_" + std::to_string(k));
  const std::vector<std::string> j2k = jpeg2000Files();
  for (int k = 0; k < 3; ++k) dir.link(j2k[k], "other_" + std::to_string(k));
}

TEST(DicomIo, TwoSeriesPicksLargerAndWarns) {
  REQUIRE_IRCADB();
  REQUIRE_JPEG2000();
  TempDir dir;
  linkTwoSeries(dir);
  DicomReadReport r;
  const Volume v = readDicomSeries(dir.path(), &r);
  ASSERT_EQ(r.seriesFound.size(), 2u);
  EXPECT_EQ(r.seriesFound[0].fileCount, 10);
  EXPECT_EQ(r.seriesFound[1].fileCount, 3);
  EXPECT_EQ(r.chosen.fileCount, 10);
  DicomReadReport alone;
  const Volume expected = readIrcadbSlices({0, 1, 2, 3, 4, 5, 6, 7, 8, 9}, &alone);
  EXPECT_EQ(r.chosen.seriesInstanceUid, alone.chosen.seriesInstanceUid);
  EXPECT_EQ(v.dims(), Eigen::Vector3i(512, 512, 10));
  EXPECT_NEAR(v.geometry().spacing.x(), 0.57, 1e-5);
  EXPECT_TRUE(anyWarningContains(r, "2 DICOM series")) << (r.warnings.empty() ? "" : r.warnings.front());
  expectSameVolume(v, expected);
}

// One file given as the path (what a viewer does with a dropped file): its directory's series with
// that file's SeriesInstanceUID, whichever series is larger; the format is told by the content.
TEST(DicomIo, OneFileGivenLoadsItsOwnSeries) {
  REQUIRE_IRCADB();
  REQUIRE_JPEG2000();
  TempDir dir;
  linkTwoSeries(dir);
  const std::vector<std::string> j2k = jpeg2000Files();
  EXPECT_EQ(sniffVolumeFormat(dir.file("image_4")), "dicom");
  EXPECT_EQ(sniffVolumeFormat(dir.file("other_1")), "dicom");

  LoadReport big, small;
  const Volume vb = loadVolume(dir.file("image_4"), &big);
  const Volume vs = loadVolume(dir.file("other_1"), &small);
  EXPECT_EQ(vb.dims(), Eigen::Vector3i(512, 512, 10));
  EXPECT_EQ(vs.dims().z(), 3);
  EXPECT_EQ(big.format.rfind("DICOM", 0), 0u) << big.format;
  // The same volumes as the series read on their own.
  DicomReadReport alone;
  expectSameVolume(vb, readIrcadbSlices({0, 1, 2, 3, 4, 5, 6, 7, 8, 9}, &alone));
  TempDir other;
  for (int k = 0; k < 3; ++k) other.link(j2k[k], "other_" + std::to_string(k));
  expectSameVolume(vs, readDicomSeries(other.path()));
  const auto said = [](const LoadReport& r, const char* what) {
    return std::any_of(r.warnings.begin(), r.warnings.end(), [&](const std::string& w) { return w.find(what) != std::string::npos; });
  };
  EXPECT_TRUE(said(small, "the one of 'other_1'"));
  EXPECT_TRUE(said(big, "the one of 'image_4'"));
  // A file of the directory that is not a DICOM image is refused, naming it.
  writeBytes(dir.file("notes.txt"), "DICM? no, some notes long enough to be looked at by the reader of headers");
  EXPECT_THROW(loadVolume(dir.file("notes.txt")), Error);
  EXPECT_THROW(loadVolume(dir.file("image_4"), nullptr, {}, LoadOptions{1}), Error);  // --frame is for 4D NIfTI
}

// A slice re-encoded in Deflated Explicit VR Little Endian (1.2.840.10008.1.2.1.99): the file meta
// information as before with the transfer syntax changed, the data set raw-deflated. Read as the
// original slices are.
std::string deflatedCopy(const std::string& file) {
  const std::string d = readBytes(file);
  std::string meta;
  std::size_t i = 132, groupLengthAt = std::string::npos;
  while (i + 8 <= d.size() && d[i] == 0x02 && d[i + 1] == 0x00) {
    const std::uint16_t element = std::uint16_t(std::uint8_t(d[i + 2]) | (std::uint8_t(d[i + 3]) << 8));
    const std::string vr = d.substr(i + 4, 2);
    const bool longForm = vr == "OB" || vr == "OW" || vr == "OF" || vr == "SQ" || vr == "UT" || vr == "UN";
    std::uint32_t length = 0;
    std::memcpy(&length, d.data() + i + (longForm ? 8 : 6), longForm ? 4 : 2);
    const std::size_t header = longForm ? 12 : 8;
    if (length > d.size() - i - header) throw std::runtime_error("bad meta element in " + file);
    if (element == 0x0000) groupLengthAt = meta.size() + header;
    if (element == 0x0010) {
      const std::string ts = "1.2.840.10008.1.2.1.99";  // even length: no padding
      std::string el = d.substr(i, 6);
      el.push_back(char(ts.size()));
      el.push_back(0);
      meta += el + ts;
    } else {
      meta += d.substr(i, header + length);
    }
    i += header + length;
  }
  if (groupLengthAt == std::string::npos) throw std::runtime_error("no group length in " + file);
  const std::uint32_t groupLength = std::uint32_t(meta.size() - groupLengthAt - 4);
  std::memcpy(meta.data() + groupLengthAt, &groupLength, 4);
  z_stream z{};
  if (deflateInit2(&z, 6, Z_DEFLATED, -15, 8, Z_DEFAULT_STRATEGY) != Z_OK) throw std::runtime_error("deflateInit2");
  std::string body(deflateBound(&z, uLong(d.size() - i)), '\0');
  z.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(d.data() + i));
  z.avail_in = uInt(d.size() - i);
  z.next_out = reinterpret_cast<Bytef*>(body.data());
  z.avail_out = uInt(body.size());
  if (deflate(&z, Z_FINISH) != Z_STREAM_END) throw std::runtime_error("deflate");
  body.resize(z.total_out);
  deflateEnd(&z);
  return d.substr(0, 132) + meta + body;
}

TEST(DicomIo, DeflatedExplicitVrLittleEndianIsRead) {
  REQUIRE_IRCADB();
  TempDir dir;
  for (int k = 0; k < 3; ++k) writeBytes(dir.file("deflated_" + std::to_string(k)), deflatedCopy(ircadbSlice(k)));
  DicomReadReport r;
  const Volume v = readDicomSeries(dir.path(), &r);
  EXPECT_NE(r.transferSyntax.find("1.2.840.10008.1.2.1.99"), std::string::npos) << r.transferSyntax;
  DicomReadReport alone;
  expectSameVolume(v, readIrcadbSlices({0, 1, 2}, &alone));
  // Cut short inside the deflated stream: refused with an error, never a short or made-up slice.
  const std::string full = deflatedCopy(ircadbSlice(1));
  writeBytes(dir.file("deflated_1"), full.substr(0, full.size() / 2));
  EXPECT_THROW(readDicomSeries(dir.path()), Error);
}

// The header is authoritative over the codestream's signedness: JPEG 2000 slices whose codestream
// stores 12-bit values as unsigned, under a header that says signed (PixelRepresentation 1), are
// read as 12-bit two's complement values - not as 0..4095 - with a warning.
TEST(DicomIo, HeaderSignednessWinsOverTheCodestream) {
  REQUIRE_JPEG2000();
  const std::vector<std::string> j2k = jpeg2000Files();
  TempDir plain, flipped;
  const std::string tag("\x28\x00\x03\x01US\x02\x00", 8);
  for (std::size_t k = 0; k < j2k.size(); ++k) {
    // Appended, not "s" + to_string(k): GCC 12 warns (-Wstringop-overflow) on the inlined insert.
    std::string name = "s";
    name += std::to_string(k);
    plain.link(j2k[k], name);
    std::string bytes = readBytes(j2k[k]);
    const std::size_t at = bytes.find(tag);
    ASSERT_NE(at, std::string::npos);
    ASSERT_EQ(bytes[at + 8], 0);  // unsigned in the original
    bytes[at + 8] = 1;
    writeBytes(flipped.file(name), bytes);
  }
  // Rescale of the series (the same on every slice here): from the original's text.
  const std::string first = readBytes(j2k.front());
  auto ds = [&](const char* t) {
    const std::size_t at = first.find(std::string(t, 6));
    EXPECT_NE(at, std::string::npos);
    const std::size_t len = std::uint8_t(first[at + 6]) | (std::uint8_t(first[at + 7]) << 8);
    return std::stod(first.substr(at + 8, len));
  };
  const double intercept = ds("\x28\x00\x52\x10" "DS"), slope = ds("\x28\x00\x53\x10" "DS");
  DicomReadReport ro, rf;
  const Volume a = readDicomSeries(plain.path(), &ro);
  const Volume b = readDicomSeries(flipped.path(), &rf);
  ASSERT_EQ(a.dims(), b.dims());
  std::size_t changed = 0;
  for (std::size_t i = 0; i < a.voxelCount(); ++i) {
    const double raw = std::round((double(a.value(i)) - intercept) / slope);
    const double expected = (raw >= 2048 ? raw - 4096 : raw) * slope + intercept;
    ASSERT_EQ(double(b.value(i)), expected) << "voxel " << i;
    changed += raw >= 2048;
  }
  EXPECT_GT(changed, 0u) << "no stored value above 2047: the test shows nothing";
  EXPECT_TRUE(std::any_of(rf.warnings.begin(), rf.warnings.end(), [](const std::string& w) { return w.find("PixelRepresentation") != std::string::npos; }));
  EXPECT_FALSE(std::any_of(ro.warnings.begin(), ro.warnings.end(), [](const std::string& w) { return w.find("PixelRepresentation") != std::string::npos; }));
}

// A JPEG 2000 fragment whose codestream holds the bytes of a sequence delimiter (FFFE,E0DD), here in
// a comment marker segment after SIZ: a delimiter only counts at an item boundary, so the slice reads
// like the original.
TEST(DicomIo, DelimiterBytesInsideAFragmentAreData) {
  REQUIRE_JPEG2000();
  const std::vector<std::string> j2k = jpeg2000Files();
  TempDir plain, tricky;
  for (std::size_t k = 0; k < 3; ++k) {
    plain.link(j2k[k], "s" + std::to_string(k));
    std::string d = readBytes(j2k[k]);
    const std::size_t pixel = d.find(std::string("\xe0\x7f\x10\x00OB", 6));
    ASSERT_NE(pixel, std::string::npos);
    auto u32 = [&](std::size_t at) { std::uint32_t v; std::memcpy(&v, d.data() + at, 4); return v; };
    std::size_t item = pixel + 12;                 // the basic offset table
    ASSERT_EQ(u32(item), 0xe000fffeu);
    item += 8 + u32(item + 4);                     // the first fragment
    ASSERT_EQ(u32(item), 0xe000fffeu);
    const std::size_t cs = item + 8;
    ASSERT_EQ(d.substr(cs, 4), std::string("\xff\x4f\xff\x51", 4));
    const std::size_t siz = (std::uint8_t(d[cs + 4]) << 8) | std::uint8_t(d[cs + 5]);
    ASSERT_LT(cs + 4 + siz, d.size());
    const std::string com("\xff\x64\x00\x0c\x00\x01\xfe\xff\xdd\xe0\x00\x00\x00\x00", 14);
    d.insert(cs + 4 + siz, com);
    const std::uint32_t length = u32(item + 4) + std::uint32_t(com.size());
    std::memcpy(d.data() + item + 4, &length, 4);
    writeBytes(tricky.file("s" + std::to_string(k)), d);
  }
  expectSameVolume(readDicomSeries(tricky.path()), readDicomSeries(plain.path()));
}

TEST(DicomIo, SingleSliceUsesSliceThickness) {
  REQUIRE_IRCADB();
  TempDir dir;
  dir.link(ircadbSlice(7), "only");
  DicomReadReport r;
  const Volume v = readDicomSeries(dir.path(), &r);
  EXPECT_EQ(v.dims(), Eigen::Vector3i(512, 512, 1));
  EXPECT_NEAR(v.geometry().spacing.z(), 1.6, 1e-5);
  EXPECT_NEAR(v.geometry().origin.z(), 7 * 1.6, 1e-4);
  EXPECT_TRUE(anyWarningContains(r, "single slice"));
  const Volume neighbours = readIrcadbSlices({6, 7, 8});
  EXPECT_EQ(std::memcmp(v.bytes(), neighbours.data<std::int16_t>() + 512 * 512, v.byteSize()), 0);
  EXPECT_LT((v.geometry().origin - neighbours.geometry().toWorld({0, 0, 1})).norm(), 1e-6);
}

TEST(DicomIo, ExactDuplicateFileIsDroppedWithWarning) {
  REQUIRE_IRCADB();
  TempDir dir;
  for (int k = 0; k < 5; ++k) dir.link(ircadbSlice(k), "image_" + std::to_string(k));
  writeBytes(dir.file("copy_of_2"), readBytes(ircadbSlice(2)));
  DicomReadReport r;
  const Volume v = readDicomSeries(dir.path(), &r);
  EXPECT_EQ(v.dims().z(), 5);
  EXPECT_FALSE(r.spacingGaps);
  EXPECT_TRUE(anyWarningContains(r, "copy")) << (r.warnings.empty() ? "" : r.warnings.front());
}

/// A copy of slice `k` with one byte sequence replaced (same length) at every occurrence.
std::string patchedSlice(int k, const std::string& from, const std::string& to) {
  std::string bytes = readBytes(ircadbSlice(k));
  EXPECT_EQ(from.size(), to.size());
  std::size_t at = 0;
  int count = 0;
  while ((at = bytes.find(from, at)) != std::string::npos) {
    bytes.replace(at, from.size(), to);
    at += to.size();
    ++count;
  }
  EXPECT_GT(count, 0) << "pattern not found in slice " << k;
  return bytes;
}

TEST(DicomIo, DifferentImagesAtSamePositionThrow) {
  REQUIRE_IRCADB();
  TempDir dir;
  for (int k = 0; k < 5; ++k) dir.link(ircadbSlice(k), "image_" + std::to_string(k));
  // A second instance at slice 2's position: same header but another SOP Instance UID (0008,0018).
  std::string bytes = readBytes(ircadbSlice(2));
  const std::size_t at = bytes.find(std::string("\x08\x00\x18\x00UI", 6));
  ASSERT_NE(at, std::string::npos);
  const std::size_t length = std::uint8_t(bytes[at + 6]) | (std::size_t(std::uint8_t(bytes[at + 7])) << 8);
  std::size_t last = at + 8 + length - 1;
  if (bytes[last] == '\0') --last;
  ASSERT_TRUE(bytes[last] >= '0' && bytes[last] <= '9');
  bytes[last] = bytes[last] == '9' ? '8' : char(bytes[last] + 1);
  writeBytes(dir.file("other_at_2"), bytes);
  const std::string msg = errorOf(dir.path());
  EXPECT_TRUE(contains(msg, "same slice position")) << msg;
}

TEST(DicomIo, InconsistentSliceSizeThrows) {
  REQUIRE_IRCADB();
  TempDir dir;
  for (int k = 0; k < 5; ++k) dir.link(ircadbSlice(k), "image_" + std::to_string(k));
  // Rows (0028,0010) US 512 -> 256, explicit VR little endian.
  const std::string rows512("\x28\x00\x10\x00US\x02\x00\x00\x02", 10);
  const std::string rows256("\x28\x00\x10\x00US\x02\x00\x00\x01", 10);
  writeBytes(dir.file("image_5"), patchedSlice(5, rows512, rows256));
  const std::string msg = errorOf(dir.path());
  EXPECT_TRUE(contains(msg, "differ in size")) << msg;
}

// ---------------------------------------------------------------------------------------------
// The JPEG 2000 lossless series.

TEST(DicomIo, Jpeg2000SeriesDecodes) {
  REQUIRE_JPEG2000();
  DicomReadReport r;
  const Volume v = readDicomSeries(kJpeg2000Dicom, &r);
  EXPECT_TRUE(contains(r.transferSyntax, "1.2.840.10008.1.2.4.90")) << r.transferSyntax;
  EXPECT_EQ(v.dims(), Eigen::Vector3i(512, 512, 20));
  EXPECT_EQ(v.type(), ScalarType::Int16);
  EXPECT_EQ(r.slices, 20);
  EXPECT_FALSE(r.spacingGaps);
  const VolumeGeometry& g = v.geometry();
  EXPECT_TRUE(g.origin.allFinite());
  EXPECT_TRUE(g.direction.allFinite());
  EXPECT_TRUE(g.spacing.allFinite());
  EXPECT_NO_THROW(g.validate());
  EXPECT_NEAR(g.spacing.x(), 0.9765625, 1e-6);
  EXPECT_NEAR(g.spacing.y(), 0.9765625, 1e-6);
  EXPECT_GT(g.spacing.z(), 0.0);

  const auto [lo, hi] = v.valueRange();
  EXPECT_GE(lo, -3024.0f);
  EXPECT_LE(hi, 4000.0f);
  std::size_t air = 0, soft = 0;
  for (std::size_t n = 0; n < v.voxelCount(); ++n) {
    const float x = v.value(n);
    air += (x >= -1100.0f && x <= -900.0f);
    soft += (x >= 0.0f && x <= 100.0f);
  }
  EXPECT_GT(air, v.voxelCount() / 20) << "expected air around the body";
  EXPECT_GT(soft, v.voxelCount() / 50) << "expected soft tissue";
  std::vector<float> central;
  for (int k = 0; k < v.dims().z(); ++k)
    for (int j = 256 - 64; j < 256 + 64; ++j)
      for (int i = 256 - 64; i < 256 + 64; ++i) central.push_back(v.value(i, j, k));
  std::nth_element(central.begin(), central.begin() + central.size() / 2, central.end());
  const float med = central[central.size() / 2];
  EXPECT_GT(med, -200.0f);
  EXPECT_LT(med, 200.0f);
}

}  // namespace
}  // namespace handson
