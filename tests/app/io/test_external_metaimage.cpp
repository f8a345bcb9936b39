// ITK's example images (Debian's insighttoolkit5-examples; `make test` downloads and unpacks the
// package into build/external-data without installing it), read by the MetaImage reader and checked
// against data read independently of it: the raw files the headers point to (read here as bytes),
// a compressed copy against its uncompressed twin, a two-channel complex image against ITK's own
// magnitude and phase images of it, and the grids the headers state (LPS converted to RAS).
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include "app/io/volume_io.h"
#include "sim/base/error.h"

namespace handson {
namespace {

namespace fs = std::filesystem;

fs::path itkData() {
  for (const fs::path& p : {fs::path(HANDSON_ITK_EXAMPLE_DATA_DIR), fs::path("/usr/share/doc/insighttoolkit5-examples/examples/Data")})
    if (fs::exists(p / "CorpusCallosumMeanShape.mha")) return p;
  return {};
}

#define REQUIRE_ITK_DATA()      \
  const fs::path root = itkData(); \
  if (root.empty()) GTEST_SKIP() << "ITK's example images not found (make test downloads them into build/external-data)"

std::vector<unsigned char> bytesOf(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

// Every MetaImage header among the examples is read (21 files: one-file and detached, raw and
// compressed, 2D and 3D, one to four channels).
TEST(ExternalMetaImage, EveryExampleIsRead) {
  REQUIRE_ITK_DATA();
  int files = 0;
  for (const auto& e : fs::directory_iterator(root)) {
    const std::string ext = e.path().extension().string();
    if (ext != ".mha" && ext != ".mhd") continue;
    SCOPED_TRACE(e.path().string());
    LoadReport rep;
    EXPECT_NO_THROW({
      const Volume v = loadVolume(e.path().string(), &rep);
      EXPECT_GT(v.voxelCount(), 0u);
      EXPECT_NE(rep.format.find("MetaImage"), std::string::npos) << rep.format;
    });
    ++files;
  }
  EXPECT_GE(files, 20);
}

// A detached raw volume and a compressed, turned slice: the values are the raw files' bytes (the
// compressed slice's .zraw inflated against the uncompressed .raw of the same image).
TEST(ExternalMetaImage, ValuesAreTheRawData) {
  REQUIRE_ITK_DATA();
  struct Case {
    const char* header;
    const char* raw;
  };
  for (const Case& c : {Case{"BrainProtonDensity3Slices.mha", "BrainProtonDensity3Slices.raw"},
                        Case{"BrainProtonDensitySliceBorder20DirectionPlus30.mhd", "BrainProtonDensitySliceBorder20.raw"},
                        Case{"RatLungSlice1.mha", "RatLungSlice1.raw"}}) {
    SCOPED_TRACE(c.header);
    const Volume v = loadVolume((root / c.header).string());
    const std::vector<unsigned char> raw = bytesOf(root / c.raw);
    ASSERT_EQ(v.voxelCount(), raw.size());
    EXPECT_EQ(v.type(), ScalarType::UInt8);
    for (std::size_t i = 0; i < raw.size(); ++i) ASSERT_EQ(v.value(i), float(raw[i])) << i;
  }
  // The turned slice's grid: TransformMatrix = 0.866 0.5 / -0.5 0.866 (rows: the axes, LPS).
  const Volume turned = loadVolume((root / "BrainProtonDensitySliceBorder20DirectionPlus30.mhd").string());
  EXPECT_EQ(turned.dims(), Eigen::Vector3i(221, 257, 1));
  EXPECT_LT((turned.geometry().direction.col(0) - Eigen::Vector3d(-0.8660254, -0.5, 0)).norm(), 1e-6);
  EXPECT_LT((turned.geometry().direction.col(1) - Eigen::Vector3d(0.5, -0.8660254, 0)).norm(), 1e-6);
  // A compressed float image's Offset -57.5 -30.5 (LPS) and spacing 2.
  const Volume shape = loadVolume((root / "CorpusCallosumMeanShape.mha").string());
  EXPECT_LT((shape.geometry().origin - Eigen::Vector3d(57.5, 30.5, 0)).norm(), 1e-9);
  EXPECT_LT((shape.geometry().spacing - Eigen::Vector3d(2, 2, 1)).norm(), 1e-9);
}

// ITK's NRRD twin of a turned slice (a 2D space, data in a raw file) read by Teem: the same values
// as the MetaImage (compressed data), the same axes up to the two files' conventions - MetaImage's
// space is LPS, an NRRD space without a name is taken as is.
TEST(ExternalMetaImage, NrrdTwinAgrees) {
  REQUIRE_ITK_DATA();
  const Volume mha = loadVolume((root / "BrainProtonDensitySliceBorder20DirectionPlus30.mhd").string());
  const Volume nrrd = loadVolume((root / "BrainProtonDensitySliceBorder20DirectionPlus30.nhdr").string());
  ASSERT_EQ(nrrd.dims(), mha.dims());
  for (std::size_t i = 0; i < mha.voxelCount(); ++i) ASSERT_EQ(nrrd.value(i), mha.value(i)) << i;
  const Eigen::Vector3d lps(-1, -1, 1);
  EXPECT_LT((nrrd.geometry().direction - lps.asDiagonal() * mha.geometry().direction).norm(), 1e-6);
  EXPECT_LT((nrrd.geometry().spacing - mha.geometry().spacing).norm(), 1e-6);  // the files give 6 and 7 digits
}

// A complex image stored as two float channels: frames 0 and 1 are its real and imaginary parts,
// whose magnitude and phase ITK wrote beside it (relative 1e-5: float32 storage).
TEST(ExternalMetaImage, ChannelsAreFramesInOrder) {
  REQUIRE_ITK_DATA();
  LoadReport rep;
  const Volume re = loadVolume((root / "itkBrainSliceComplex.mha").string(), &rep, {}, LoadOptions{0});
  const Volume im = loadVolume((root / "itkBrainSliceComplex.mha").string(), nullptr, {}, LoadOptions{1});
  EXPECT_EQ(rep.frames, 2);
  const Volume magnitude = loadVolume((root / "itkBrainSliceComplexMagnitude.mha").string());
  const Volume phase = loadVolume((root / "itkBrainSliceComplexPhase.mha").string());
  ASSERT_EQ(re.voxelCount(), magnitude.voxelCount());
  ASSERT_EQ(re.voxelCount(), phase.voxelCount());
  double largest = 0;
  for (std::size_t i = 0; i < re.voxelCount(); ++i) largest = std::max(largest, double(magnitude.value(i)));
  ASSERT_GT(largest, 0.0);
  for (std::size_t i = 0; i < re.voxelCount(); ++i) {
    const double a = re.value(i), b = im.value(i);
    ASSERT_NEAR(std::hypot(a, b), magnitude.value(i), 1e-5 * largest) << i;
    if (std::hypot(a, b) > 1e-3 * largest) {
      ASSERT_NEAR(std::atan2(b, a), phase.value(i), 1e-4) << i;
    }
  }
}

}  // namespace
}  // namespace handson
