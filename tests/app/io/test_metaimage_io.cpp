// Tests for app/io/metaimage_io (MetaImage through MetaIO): hand-written headers (independent of
// MetaIO's writer) with an oblique LPS grid, a detached big-endian data file with a skipped header,
// zlib and gzip data, 4D and multi-channel images, 2D, every number type, a label map used as a
// mask, our writer's round trip, and broken files - among them the two MetaIO itself reports as read
// (a truncated data block, a compressed block that does not inflate).
#include "app/io/metaimage_io.h"

#include <gtest/gtest.h>
#include <zlib.h>

#include <Eigen/Geometry>
#include <cstdint>
#include <sstream>
#include <string>
#include <vector>

#include "app/io/volume_io.h"
#include "file_test_fixture.h"
#include "sim/base/error.h"

namespace handson {
namespace {

using MetaImageIo = test::FileTest;
using test::compressed;
using test::ramp;
using test::raw;


std::string header(const std::string& fields, const std::string& dataFile = "LOCAL") {
  return "ObjectType = Image\n" + fields + "ElementDataFile = " + dataFile + "\n";
}

void expectRefused(const std::string& path, const std::string& needle = {}) {
  try {
    (void)loadVolume(path);
    ADD_FAILURE() << path << " accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
    if (!needle.empty()) {
      EXPECT_NE(std::string(e.what()).find(needle), std::string::npos) << e.what();
    }
  }
}

// An oblique grid in ITK's LPS space: TransformMatrix's rows are the axes' directions; they and
// the Offset come back in RAS (x and y negated); values in index order; the loader tells the
// format by content, whatever the name.
TEST_F(MetaImageIo, LpsGridIsConvertedToRas) {
  const auto values = ramp(4 * 3 * 5);
  const Eigen::Matrix3d R = Eigen::AngleAxisd(0.3, Eigen::Vector3d(1, -2, 0.5).normalized()).toRotationMatrix();
  const Eigen::Vector3d spacing(0.8, 1.1, 2.5), originLps(-10.5, 20.25, 33.0);
  std::ostringstream h;
  h.precision(17);
  h << "NDims = 3\nBinaryData = True\nBinaryDataByteOrderMSB = False\nCompressedData = False\nTransformMatrix =";
  for (int c = 0; c < 3; ++c)
    for (int r = 0; r < 3; ++r) h << ' ' << R(r, c);
  h << "\nOffset = " << originLps.x() << ' ' << originLps.y() << ' ' << originLps.z() << "\nCenterOfRotation = 0 0 0\n";
  h << "AnatomicalOrientation = RAI\nElementSpacing = " << spacing.x() << ' ' << spacing.y() << ' ' << spacing.z()
    << "\nDimSize = 4 3 5\nElementType = MET_SHORT\n";
  write("oblique.img", header(h.str()) + raw(values));
  LoadReport rep;
  const Volume v = loadVolume(path("oblique.img"), &rep);
  EXPECT_NE(rep.format.find("MetaImage"), std::string::npos) << rep.format;
  ASSERT_EQ(v.dims(), Eigen::Vector3i(4, 3, 5));
  EXPECT_EQ(v.type(), ScalarType::Int16);
  const Eigen::Vector3d lps(-1, -1, 1);
  EXPECT_LT((v.geometry().spacing - spacing).norm(), 1e-12);
  EXPECT_LT((v.geometry().direction - lps.asDiagonal() * R).norm(), 1e-12);
  EXPECT_LT((v.geometry().origin - lps.cwiseProduct(originLps)).norm(), 1e-12);
  for (std::size_t i = 0; i < values.size(); ++i) ASSERT_EQ(v.value(i), float(values[i])) << i;
}

// A .mhd header with its data in a big-endian .raw file behind a 16-byte header of its own
// (HeaderSize), in unsigned short; and the same values in zlib and gzip .zraw files.
TEST_F(MetaImageIo, DetachedBigEndianAndCompressedData) {
  std::vector<std::uint16_t> values(3 * 2 * 4);
  for (std::size_t i = 0; i < values.size(); ++i) values[i] = std::uint16_t(i * 2731 % 60000);
  std::string big;
  for (std::uint16_t x : values) big += {char(x >> 8), char(x & 0xff)};
  write("data.raw", std::string(16, 'x') + big);
  write("big.mhd", header("NDims = 3\nDimSize = 3 2 4\nHeaderSize = 16\nElementByteOrderMSB = True\nElementType = MET_USHORT\n", "data.raw"));
  write("data.zraw", compressed(raw(values), 15));
  write("zlib.mhd", header("NDims = 3\nDimSize = 3 2 4\nCompressedData = True\nElementType = MET_USHORT\n", "data.zraw"));
  write("gzip.mha", header("NDims = 3\nDimSize = 3 2 4\nCompressedData = True\nElementType = MET_USHORT\n") + compressed(raw(values), 15 + 16));
  for (const char* f : {"big.mhd", "zlib.mhd", "gzip.mha"}) {
    SCOPED_TRACE(f);
    MetaImageInfo info;
    const Volume v = readMetaImage(path(f), 0, &info);
    ASSERT_EQ(v.voxelCount(), values.size());
    EXPECT_EQ(v.type(), ScalarType::Float32);  // values above 32767 do not fit int16
    for (std::size_t i = 0; i < values.size(); ++i) ASSERT_EQ(v.value(i), float(values[i])) << i;
  }
  // The data end the file when HeaderSize = -1.
  write("tail.mhd", header("NDims = 3\nDimSize = 3 2 4\nHeaderSize = -1\nElementByteOrderMSB = True\nElementType = MET_USHORT\n", "data.raw"));
  EXPECT_EQ(readMetaImage(path("tail.mhd")).value(5), float(values[5]));
}

// Volumes along a fourth axis and channels per element both count frames: frame f is channel
// f % channels of the fourth axis's sample f / channels.
TEST_F(MetaImageIo, FourDAndChannelsAreFrames) {
  const std::size_t voxels = 2 * 3 * 2;
  std::vector<float> values(voxels * 3 * 2);  // 3 time points x 2 channels
  for (std::size_t i = 0; i < values.size(); ++i) values[i] = float(i) * 0.5f - 7.0f;
  write("4d.mha", header("NDims = 4\nDimSize = 2 3 2 3\nElementSpacing = 1 2 3 40\nElementNumberOfChannels = 2\nElementType = MET_FLOAT\n") +
                      raw(values));
  MetaImageInfo info;
  (void)readMetaImage(path("4d.mha"), 0, &info);
  EXPECT_EQ(info.frames, 6);
  for (std::int64_t f = 0; f < 6; ++f) {
    LoadReport rep;
    const Volume v = loadVolume(path("4d.mha"), &rep, {}, LoadOptions{f});
    EXPECT_EQ(rep.frames, 6);
    ASSERT_EQ(v.dims(), Eigen::Vector3i(2, 3, 2));
    EXPECT_LT((v.geometry().spacing - Eigen::Vector3d(1, 2, 3)).norm(), 1e-12);
    const std::size_t t = std::size_t(f) / 2, c = std::size_t(f) % 2;
    for (std::size_t i = 0; i < voxels; ++i) ASSERT_EQ(v.value(i), values[(t * voxels + i) * 2 + c]) << "frame " << f << " voxel " << i;
  }
  try {
    (void)loadVolume(path("4d.mha"), nullptr, {}, LoadOptions{6});
    ADD_FAILURE() << "frame 6 accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("0 to 5"), std::string::npos) << e.what();
  }
}

// A 2D image is a one-slice volume; its in-plane directions (a turn) are kept.
TEST_F(MetaImageIo, TwoDImageIsOneSlice) {
  const std::vector<std::uint8_t> values{1, 2, 3, 4, 5, 6};
  write("slice.mha", header("NDims = 2\nDimSize = 3 2\nTransformMatrix = 0 1 -1 0\nOffset = 5 6\nElementSpacing = 0.5 2\nElementType = MET_UCHAR\n") +
                         raw(values));
  const Volume v = loadVolume(path("slice.mha"));
  ASSERT_EQ(v.dims(), Eigen::Vector3i(3, 2, 1));
  EXPECT_EQ(v.type(), ScalarType::UInt8);
  // LPS axis 0 = (0, 1), axis 1 = (-1, 0); in RAS x and y negated.
  EXPECT_LT((v.geometry().direction.col(0) - Eigen::Vector3d(0, -1, 0)).norm(), 1e-12);
  EXPECT_LT((v.geometry().direction.col(1) - Eigen::Vector3d(1, 0, 0)).norm(), 1e-12);
  EXPECT_LT((v.geometry().origin - Eigen::Vector3d(-5, -6, 0)).norm(), 1e-12);
  EXPECT_EQ(v.value(4), 5.0f);
}

// Every number type: integers that fit are int16, unsigned char stays uint8, the rest float.
TEST_F(MetaImageIo, NumberTypes) {
  write("char.mha", header("NDims = 3\nDimSize = 2 1 1\nElementType = MET_CHAR\n") + raw(std::vector<std::int8_t>{-5, 7}));
  write("int.mha", header("NDims = 3\nDimSize = 2 1 1\nElementType = MET_INT\n") + raw(std::vector<std::int32_t>{-1000, 3000}));
  write("bigint.mha", header("NDims = 3\nDimSize = 2 1 1\nElementType = MET_UINT\n") + raw(std::vector<std::uint32_t>{70000, 1}));
  write("double.mha", header("NDims = 3\nDimSize = 2 1 1\nElementType = MET_DOUBLE\n") + raw(std::vector<double>{-0.25, 1e3}));
  write("llong.mha", header("NDims = 3\nDimSize = 2 1 1\nElementType = MET_LONG_LONG\n") + raw(std::vector<std::int64_t>{-3, 4}));
  struct Case {
    const char* file;
    ScalarType type;
    float first, second;
  };
  for (const Case& c : {Case{"char.mha", ScalarType::Int16, -5, 7}, Case{"int.mha", ScalarType::Int16, -1000, 3000},
                        Case{"bigint.mha", ScalarType::Float32, 70000, 1}, Case{"double.mha", ScalarType::Float32, -0.25f, 1e3f},
                        Case{"llong.mha", ScalarType::Int16, -3, 4}}) {
    SCOPED_TRACE(c.file);
    const Volume v = readMetaImage(path(c.file));
    EXPECT_EQ(v.type(), c.type);
    EXPECT_EQ(v.value(0), c.first);
    EXPECT_EQ(v.value(1), c.second);
  }
}

// A label map in MetaImage selects the voxels of one label on the image's grid.
TEST_F(MetaImageIo, LabelMapAsMask) {
  write("image.mha", header("NDims = 3\nDimSize = 2 2 2\nElementType = MET_SHORT\n") + raw(ramp(8)));
  write("labels.mha", header("NDims = 3\nDimSize = 2 2 2\nElementType = MET_UCHAR\n") + raw(std::vector<std::uint8_t>{0, 4, 4, 1, 0, 0, 4, 2}));
  const Volume image = loadVolume(path("image.mha"));
  EXPECT_EQ(maskVoxels(path("labels.mha"), image, "handle", 4L), (std::vector<std::uint32_t>{1, 2, 6}));
  EXPECT_EQ(maskVoxels(path("labels.mha"), image, "handle", std::nullopt).size(), 5u);
}

// Our writer: an oblique volume of each type comes back with its grid and values; .mhd (a header
// with a detached data file) is refused rather than written as something else.
TEST_F(MetaImageIo, WriterRoundTrip) {
  VolumeGeometry g;
  g.dims = {5, 4, 3};
  g.spacing = {0.7, 1.3, 2.1};
  g.direction = Eigen::AngleAxisd(-0.7, Eigen::Vector3d(0.2, 1, -0.4).normalized()).toRotationMatrix();
  g.origin = {12.5, -40.25, 7};
  for (ScalarType type : {ScalarType::UInt8, ScalarType::Int16, ScalarType::Float32}) {
    SCOPED_TRACE(int(type));
    Volume v(g, type);
    for (std::size_t i = 0; i < v.voxelCount(); ++i) v.setValue(i, type == ScalarType::Float32 ? float(i) * 0.37f - 9 : float(i % 200));
    writeVolume(v, path("out.mha"));
    const Volume back = loadVolume(path("out.mha"));
    ASSERT_EQ(back.dims(), g.dims);
    EXPECT_EQ(back.type(), type);
    EXPECT_LT((back.geometry().spacing - g.spacing).norm(), 1e-9);
    EXPECT_LT((back.geometry().direction - g.direction).norm(), 1e-9);
    EXPECT_LT((back.geometry().origin - g.origin).norm(), 1e-9);
    for (std::size_t i = 0; i < v.voxelCount(); ++i) ASSERT_EQ(back.value(i), v.value(i)) << i;
  }
  EXPECT_THROW(writeVolume(Volume(g, ScalarType::Int16), path("out.mhd")), Error);
  EXPECT_FALSE(std::filesystem::exists(path("out.mhd")));
}

// Broken files: a clear error naming the file, never a crash, an allocation of the declared size,
// or values made up for data that are not there.
TEST_F(MetaImageIo, BrokenFilesAreRefused) {
  const std::string values = raw(ramp(8));
  const std::string shortHeader = "NDims = 3\nDimSize = 2 2 2\nElementType = MET_SHORT\n";
  write("truncated.mha", header(shortHeader) + values.substr(0, 12));
  write("notzlib.mha", header(shortHeader + "CompressedData = True\n") + "this is not zlib data");
  write("cut.mha", header(shortHeader + "CompressedData = True\n") + compressed(values, 15).substr(0, 8));
  write("toolong.mha", header(shortHeader + "CompressedData = True\n") + compressed(values + values, 15));
  write("huge.mha", header("NDims = 3\nDimSize = 100000 100000 100000\nElementType = MET_DOUBLE\n") + values);
  write("negative.mha", header("NDims = 3\nDimSize = 2 -2 2\nElementType = MET_SHORT\n") + values);
  write("fived.mha", header("NDims = 5\nDimSize = 2 2 2 1 1\nElementType = MET_SHORT\n") + values);
  write("oned.mha", header("NDims = 1\nDimSize = 8\nElementType = MET_SHORT\n") + values);
  write("notype.mha", header("NDims = 3\nDimSize = 2 2 2\n") + values);
  write("string.mha", header("NDims = 3\nDimSize = 2 2 2\nElementType = MET_STRING\n") + values);
  write("nodata.mhd", header(shortHeader, "missing.raw"));
  write("list.mhd", header(shortHeader, "LIST 2D"));
  write("zerospacing.mha", header(shortHeader + "ElementSpacing = 1 0 1\n") + values);
  // MetaIO loops for ever on a negative NDims (a fuzzing finding): refused before it parses.
  write("ndims-negative.mha", "NDims = -4\nDimSize = 3 2 1 2\nElementType = MET_USHORT\nElementDataFile = LOCAL\n" + values);
  write("ndims-eleven.mha", "NDims = 11\nDimSize = 1 1 1 1 1 1 1 1 1 1 1\nElementType = MET_SHORT\nElementDataFile = LOCAL\n" + values);
  expectRefused(path("truncated.mha"), "truncated");
  expectRefused(path("notzlib.mha"), "inflate");
  expectRefused(path("cut.mha"), "truncated");
  expectRefused(path("toolong.mha"), "more than");
  // ... and overflows a 255-character buffer on a longer field name (another finding), which
  // aborts the child process that parses the header, not the caller.
  write("long-name.mha", "ObjectType = Image\nNDims = 3\n" + std::string(400, 'K') + " = 1\nDimSize = 2 2 2\nElementType = MET_SHORT\n"
                         "ElementDataFile = LOCAL\n" + values);
  expectRefused(path("long-name.mha"), "MetaIO");
  expectRefused(path("ndims-negative.mha"), "NDims");
  expectRefused(path("ndims-eleven.mha"), "NDims");
  for (const char* f : {"huge.mha", "negative.mha", "fived.mha", "oned.mha", "notype.mha", "string.mha", "nodata.mhd", "list.mhd", "zerospacing.mha"}) {
    SCOPED_TRACE(f);
    expectRefused(path(f));
  }
}

}  // namespace
}  // namespace handson
