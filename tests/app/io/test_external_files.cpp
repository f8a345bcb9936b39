// Real files from other projects' test suites, read from the packages Debian ships them in
// (python3-nibabel's and python3-pydicom's test data; `make test` downloads and unpacks the two
// packages into build/external-data without installing them), against the values nibabel and
// pydicom read from the same files (tests/app/external/reference.json, written by
// tests/app/external/make_reference.py): size, RAS affine, and the sum, sum of squares, minimum
// and maximum of the values. Files pydicom cannot decode without plugins (JPEG 2000, JPEG-LS) are
// compared with the uncompressed file they were made from. Each file is read alone from a
// directory of its own, and one in place among pydicom's damaged and colour siblings.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>

#include "app/io/volume_io.h"
#include "sim/base/error.h"

namespace handson {
namespace {

namespace fs = std::filesystem;

// Where the packages' files are: the unpacked download, else installed packages.
fs::path dataRoot() {
  for (const fs::path& p : {fs::path(HANDSON_EXTERNAL_DATA_DIR), fs::path("/usr/lib/python3/dist-packages")})
    if (fs::exists(p / "pydicom/data/test_files/CT_small.dcm") && fs::exists(p / "nibabel/tests/data/anatomical.nii")) return p;
  return {};
}

#define REQUIRE_EXTERNAL()      \
  const fs::path root = dataRoot(); \
  if (root.empty()) GTEST_SKIP() << "nibabel's and pydicom's test data not found (make test downloads them into build/external-data)"

// The file alone in a fresh directory (a DICOM file's directory is its series).
class Isolated {
 public:
  explicit Isolated(const fs::path& file) {
    dir_ = fs::temp_directory_path() / ("handson_external_" + std::to_string(getpid()) + "_" + std::to_string(counter_++));
    fs::create_directories(dir_);
    path_ = dir_ / file.filename();
    fs::copy_file(file, path_);
  }
  ~Isolated() {
    std::error_code ec;
    fs::remove_all(dir_, ec);
  }
  std::string path() const { return path_.string(); }

 private:
  static inline int counter_ = 0;
  fs::path dir_, path_;
};

double sumOf(const Volume& v, bool squares) {
  double s = 0;
  for (std::size_t i = 0; i < v.voxelCount(); ++i) s += squares ? double(v.value(i)) * v.value(i) : double(v.value(i));
  return s;
}

TEST(ExternalFiles, ReadAsNibabelAndPydicomReadThem) {
  REQUIRE_EXTERNAL();
  std::ifstream in(std::string(HANDSON_SOURCE_DIR) + "/tests/app/external/reference.json");
  ASSERT_TRUE(in) << "reference.json missing";
  const nlohmann::json refs = nlohmann::json::parse(in);
  ASSERT_GE(refs.size(), 14u);
  for (const auto& r : refs) {
    const std::string file = r["file"];
    SCOPED_TRACE(file + " frame " + std::to_string(int(r["frame"])));
    const Isolated copy(root / file);
    LoadReport rep;
    const Volume v = loadVolume(copy.path(), &rep, {}, LoadOptions{r["frame"].get<std::int64_t>()});
    EXPECT_EQ(rep.frames, r["frames"].get<std::int64_t>());
    ASSERT_EQ(v.dims(), Eigen::Vector3i(r["dims"][0], r["dims"][1], r["dims"][2]));
    // Values: float32 sums against double ones (relative 1e-6: float rounding of the stored values).
    const double sum = r["sum"], sumsq = r["sumsq"];
    EXPECT_NEAR(sumOf(v, false), sum, 1e-6 * std::max(1.0, std::abs(sumsq) / std::max(1.0, std::abs(sum))) + 1e-6 * std::abs(sum)) << "sum";
    EXPECT_NEAR(sumOf(v, true), sumsq, 1e-6 * sumsq) << "sum of squares";
    const auto [mn, mx] = v.valueRange();
    EXPECT_NEAR(mn, r["min"].get<double>(), 1e-4 * std::max(1.0, std::abs(r["min"].get<double>())));
    EXPECT_NEAR(mx, r["max"].get<double>(), 1e-4 * std::max(1.0, std::abs(r["max"].get<double>())));
    // Geometry: the RAS affine of voxel indices (columns 0-2 for volumes; a single DICOM slice's
    // third column is its normal at an assumed thickness, so only its direction is compared).
    if (r["affine"].is_null()) continue;
    Eigen::Matrix4d A;
    for (int i = 0; i < 4; ++i)
      for (int j = 0; j < 4; ++j) A(i, j) = r["affine"][i][j];
    const VolumeGeometry& g = v.geometry();
    Eigen::Matrix3d M = g.direction * g.spacing.asDiagonal();
    const bool slice = file.rfind(".dcm") == file.size() - 4;
    for (int c = 0; c < 3; ++c) {
      if (slice && c == 2) {
        EXPECT_LT((g.direction.col(2) - A.block<3, 1>(0, 2).normalized()).norm(), 1e-5);
        continue;
      }
      EXPECT_LT((M.col(c) - A.block<3, 1>(0, c)).norm(), 1e-4 * std::max(1.0, A.block<3, 1>(0, c).norm())) << "column " << c << "\n" << M << "\n" << A;
    }
    EXPECT_LT((g.origin - A.block<3, 1>(0, 3)).norm(), 1e-3) << g.origin.transpose() << " vs " << A.block<3, 1>(0, 3).transpose();
  }
}

// Lossless JPEG 2000 and JPEG-LS copies of MR_small decode to MR_small exactly; the JPEG 2000
// slice whose codestream calls signed values unsigned reads as the header says (-2000..1896, as
// pydicom documents for this file); the crafted one whose codestream width is overwritten by
// delimiter bytes is refused, naming the mismatch; a .hdr without its .img and Analyze 7.5 are
// refused clearly.
TEST(ExternalFiles, CompressedCopiesSignednessAndRefusals) {
  REQUIRE_EXTERNAL();
  const fs::path dcm = root / "pydicom/data/test_files";
  const Volume plain = loadVolume(Isolated(dcm / "MR_small.dcm").path());
  for (const char* f : {"MR_small_jp2klossless.dcm", "MR_small_jpeg_ls_lossless.dcm"}) {
    SCOPED_TRACE(f);
    const Volume v = loadVolume(Isolated(dcm / f).path());
    ASSERT_EQ(v.dims(), plain.dims());
    for (std::size_t i = 0; i < v.voxelCount(); ++i) ASSERT_EQ(v.value(i), plain.value(i)) << i;
  }
  LoadReport rep;
  const Volume mismatch = loadVolume(Isolated(dcm / "J2K_pixelrep_mismatch.dcm").path(), &rep);
  const auto [mn, mx] = mismatch.valueRange();
  EXPECT_EQ(mn, -2000.0f);
  EXPECT_EQ(mx, 1896.0f);
  EXPECT_TRUE(std::any_of(rep.warnings.begin(), rep.warnings.end(), [](const std::string& w) { return w.find("PixelRepresentation") != std::string::npos; }));
  try {
    (void)loadVolume(Isolated(dcm / "JPEG2000-embedded-sequence-delimiter.dcm").path());
    ADD_FAILURE() << "a codestream 3722445056 pixels wide was decoded";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("codestream describes a 3722445056x1024 image, the header 256x1024"), std::string::npos) << e.what();
  }
  for (const char* f : {"nibabel/tests/data/nifti1.hdr", "nibabel/tests/data/analyze.hdr"}) {
    SCOPED_TRACE(f);
    try {
      (void)loadVolume(Isolated(root / f).path());
      ADD_FAILURE() << "accepted";
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find(fs::path(f).filename().string()), std::string::npos) << e.what();
    }
  }
}

// One file in place among pydicom's 80 test files (damaged ones, RGB, multi-frame, reports): its
// own series loads, the unreadable siblings of other series are left out with warnings.
TEST(ExternalFiles, OneFileAmongDamagedSiblings) {
  REQUIRE_EXTERNAL();
  LoadReport rep;
  const Volume v = loadVolume((root / "pydicom/data/test_files/CT_small.dcm").string(), &rep);
  EXPECT_EQ(v.dims(), Eigen::Vector3i(128, 128, 1));
  EXPECT_EQ(v.valueRange().first, -896.0f);
  EXPECT_TRUE(std::any_of(rep.warnings.begin(), rep.warnings.end(), [](const std::string& w) { return w.find("left out") != std::string::npos; }));
}

}  // namespace
}  // namespace handson
