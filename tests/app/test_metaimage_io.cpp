// Tests for app/metaimage_io (MetaImage through ITK's MetaImageIO): hand-written headers (an
// oblique LPS transform, zlib-compressed floats, a detached .mhd/.raw pair, a 4D image, 2D) read
// through the content-sniffing loader, compared with the same grid written as NRRD; broken files.
#include "app/metaimage_io.h"

#include <gtest/gtest.h>
#include <unistd.h>
#include <zlib.h>

#include <Eigen/Geometry>
#include <atomic>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "app/nrrd_io.h"
#include "app/volume_io.h"
#include "file_test_fixture.h"
#include "sim/error.h"

namespace handson {
namespace {

namespace fs = std::filesystem;

class MetaImageIo : public test::FileTest {
 protected:
  void SetUp() override {
#ifndef HANDSON_HAVE_ITK
    GTEST_SKIP() << "built without MetaImage support (ITK's headers build with GCC only)";
#endif
    FileTest::SetUp();
  }
};
using test::raw;

std::string zlibbed(const std::string& s) {
  uLongf n = compressBound(uLong(s.size()));
  std::string out(n, '\0');
  EXPECT_EQ(compress(reinterpret_cast<Bytef*>(out.data()), &n, reinterpret_cast<const Bytef*>(s.data()), uLong(s.size())), Z_OK);
  out.resize(n);
  return out;
}

// An oblique image in ITK's LPS space: RAS after reading; the same grid as a NRRD of the same LPS
// numbers (two libraries, one geometry).
TEST_F(MetaImageIo, ObliqueLpsImageMatchesTheSameNrrd) {
  std::vector<std::int16_t> values(4 * 3 * 5);
  for (std::size_t i = 0; i < values.size(); ++i) values[i] = std::int16_t(int(i) * 41 % 3000 - 1000);
  const Eigen::Matrix3d R = Eigen::AngleAxisd(0.3, Eigen::Vector3d(1, -2, 0.5).normalized()).toRotationMatrix();
  const Eigen::Vector3d spacing(0.8, 1.1, 2.5), origin(-10.5, 20.25, 33.0);
  std::ostringstream h, n;
  h.precision(17);
  n.precision(17);
  h << "ObjectType = Image\nNDims = 3\nBinaryData = True\nBinaryDataByteOrderMSB = False\nCompressedData = False\nTransformMatrix =";
  for (int c = 0; c < 3; ++c)
    for (int r = 0; r < 3; ++r) h << " " << R(r, c);  // MetaIO lists the direction columns one after another
  h << "\nOffset = " << origin.x() << " " << origin.y() << " " << origin.z() << "\nElementSpacing = " << spacing.x() << " " << spacing.y() << " "
    << spacing.z() << "\nDimSize = 4 3 5\nElementType = MET_SHORT\nElementDataFile = LOCAL\n";
  write("oblique.mha", h.str() + raw(values));
  n << "NRRD0004\ntype: short\ndimension: 3\nspace: left-posterior-superior\nsizes: 4 3 5\nspace directions:";
  for (int c = 0; c < 3; ++c) n << " (" << R(0, c) * spacing[c] << "," << R(1, c) * spacing[c] << "," << R(2, c) * spacing[c] << ")";
  n << "\nendian: little\nencoding: raw\nspace origin: (" << origin.x() << "," << origin.y() << "," << origin.z() << ")\n\n";
  write("oblique.nrrd", n.str() + raw(values));
  LoadReport rep;
  const Volume m = loadVolume(path("oblique.mha"), &rep);
  EXPECT_EQ(rep.format, "MetaImage");
  const Volume r = loadVolume(path("oblique.nrrd"));
  EXPECT_TRUE(m.geometry().sameGrid(r.geometry())) << m.geometry().direction << "\n" << r.geometry().direction;
  EXPECT_LT((m.geometry().origin - r.geometry().origin).norm(), 1e-9);
  EXPECT_LT((m.geometry().origin - Eigen::Vector3d(10.5, -20.25, 33.0)).norm(), 1e-9);
  for (std::size_t i = 0; i < values.size(); ++i) ASSERT_EQ(m.value(i), values[i]) << i;
}

// zlib-compressed floats; a detached .mhd with its .raw; a 4D image's volumes; a 2D image.
TEST_F(MetaImageIo, CompressedDetached4DAnd2D) {
  std::vector<float> f(3 * 2 * 2);
  for (std::size_t i = 0; i < f.size(); ++i) f[i] = float(i) * 0.5f - 2.0f;
  const std::string z = zlibbed(raw(f));
  write("z.mha", "ObjectType = Image\nNDims = 3\nBinaryData = True\nCompressedData = True\nCompressedDataSize = " + std::to_string(z.size()) +
                     "\nDimSize = 3 2 2\nElementType = MET_FLOAT\nElementDataFile = LOCAL\n" + z);
  const Volume zv = loadVolume(path("z.mha"));
  EXPECT_EQ(zv.type(), ScalarType::Float32);
  for (std::size_t i = 0; i < f.size(); ++i) ASSERT_EQ(zv.value(i), f[i]);

  std::vector<std::uint8_t> labels(5 * 4 * 3);
  for (std::size_t i = 0; i < labels.size(); ++i) labels[i] = std::uint8_t(i % 6);
  write("labels.raw", raw(labels));
  write("labels.mhd", "ObjectType = Image\nNDims = 3\nElementSpacing = 2 2 3\nDimSize = 5 4 3\nElementType = MET_UCHAR\nElementDataFile = labels.raw\n");
  const Volume lv = loadVolume(path("labels.mhd"));
  EXPECT_EQ(lv.type(), ScalarType::UInt8);
  EXPECT_EQ(lv.geometry().spacing, Eigen::Vector3d(2, 2, 3));
  for (std::size_t i = 0; i < labels.size(); ++i) ASSERT_EQ(lv.value(i), labels[i]);

  std::vector<std::int32_t> four(2 * 2 * 2 * 3);
  for (std::size_t i = 0; i < four.size(); ++i) four[i] = std::int32_t(1000 * (i / 8) + i % 8);
  write("t.mha", "ObjectType = Image\nNDims = 4\nDimSize = 2 2 2 3\nElementType = MET_INT\nElementDataFile = LOCAL\n" + raw(four));
  for (int k = 0; k < 3; ++k) {
    LoadReport rep;
    const Volume v = loadVolume(path("t.mha"), &rep, {}, LoadOptions{k});
    EXPECT_EQ(rep.frames, 3);
    for (std::size_t i = 0; i < 8; ++i) ASSERT_EQ(v.value(i), 1000 * k + int(i));
  }
  EXPECT_THROW(loadVolume(path("t.mha"), nullptr, {}, LoadOptions{3}), Error);

  std::vector<std::int16_t> flat{1, 2, 3, 4, 5, 6};
  write("flat.mha", "ObjectType = Image\nNDims = 2\nElementSpacing = 0.5 0.25\nDimSize = 3 2\nElementType = MET_SHORT\nElementDataFile = LOCAL\n" + raw(flat));
  const Volume s = loadVolume(path("flat.mha"));
  EXPECT_EQ(s.dims(), Eigen::Vector3i(3, 2, 1));
  EXPECT_EQ(s.value(5), 6.0f);
}

// Short data (MetaIO only says so on its streams), a missing data file, colour, absurd sizes and
// garbage: one clear error naming the file.
TEST_F(MetaImageIo, BrokenFilesAreRefused) {
  const std::string head = "ObjectType = Image\nNDims = 3\nDimSize = 4 4 4\nElementType = MET_SHORT\n";
  write("short.mha", head + "ElementDataFile = LOCAL\n" + std::string(20, '\1'));
  write("nodata.mhd", head + "ElementDataFile = missing.raw\n");
  write("rgb.mha", "ObjectType = Image\nNDims = 3\nDimSize = 2 2 2\nElementNumberOfChannels = 3\nElementType = MET_UCHAR\nElementDataFile = LOCAL\n" +
                       std::string(24, '\1'));
  write("huge.mha", "ObjectType = Image\nNDims = 3\nDimSize = 100000 100000 100000\nElementType = MET_DOUBLE\nElementDataFile = LOCAL\n");
  write("junk.mha", "ObjectType = Image\nNDims = banana\n");
  for (const char* f : {"short.mha", "nodata.mhd", "rgb.mha", "huge.mha", "junk.mha"}) {
    SCOPED_TRACE(f);
    try {
      (void)loadVolume(path(f));
      ADD_FAILURE() << "accepted";
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find(f), std::string::npos) << e.what();
    }
  }
}

// Random damage to valid files (bytes of the header and data changed, lines cut, the file cut
// short), 1,500 times: each is read or refused with handson::Error - never a crash, a hang or
// another exception. (The clang libFuzzer build cannot compile ITK's headers; this stands in for a
// fuzzer in the GCC build.)
TEST_F(MetaImageIo, RandomDamageNeverCrashes) {
  std::vector<std::int16_t> values(4 * 3 * 2);
  for (std::size_t i = 0; i < values.size(); ++i) values[i] = std::int16_t(int(i) * 53 % 900 - 300);
  const std::string head = "ObjectType = Image\nNDims = 3\nBinaryData = True\nBinaryDataByteOrderMSB = False\nTransformMatrix = 1 0 0 0 1 0 0 0 1\n"
                           "Offset = 1 2 3\nElementSpacing = 0.8 0.8 2.5\nDimSize = 4 3 2\nElementType = MET_SHORT\n";
  const std::string z = zlibbed(raw(values));
  const std::vector<std::string> seeds = {
      head + "CompressedData = False\nElementDataFile = LOCAL\n" + raw(values),
      head + "CompressedData = True\nCompressedDataSize = " + std::to_string(z.size()) + "\nElementDataFile = LOCAL\n" + z,
      "ObjectType = Image\nNDims = 4\nDimSize = 2 2 2 3\nElementType = MET_SHORT\nElementDataFile = LOCAL\n" + raw(values)};
  std::mt19937 rng(7);
  int accepted = 0, refused = 0;
  for (int iter = 0; iter < 1500; ++iter) {
    std::string bytes = seeds[std::size_t(iter) % seeds.size()];
    switch (rng() % 4) {
      case 0:  // bytes changed anywhere
        for (int f = 1 + int(rng() % 4); f > 0; --f) bytes[rng() % bytes.size()] = char(rng());
        break;
      case 1:  // a digit of the header changed
        for (int f = 0; f < 3; ++f) {
          const std::size_t at = rng() % head.size();
          if (std::isdigit(static_cast<unsigned char>(bytes[at]))) bytes[at] = char('0' + rng() % 10);
        }
        break;
      case 2: bytes.resize(rng() % bytes.size()); break;  // cut short
      default: {  // a header line dropped
        const std::size_t at = bytes.find('\n', rng() % 120);
        const std::size_t next = at == std::string::npos ? at : bytes.find('\n', at + 1);
        if (next != std::string::npos) bytes.erase(at, next - at);
      }
    }
    write("damaged.mha", bytes);
    try {
      const Volume v = readMetaImage(path("damaged.mha"), iter % 2);
      EXPECT_LE(v.voxelCount(), 64u * 1024u * 1024u);
      ++accepted;
    } catch (const Error&) {
      ++refused;
    }
  }
  EXPECT_GT(accepted, 0);
  EXPECT_GT(refused, 0);
}

}  // namespace
}  // namespace handson
