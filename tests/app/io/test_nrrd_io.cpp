// Tests for app/io/nrrd_io (NRRD through Teem): hand-written headers (independent of Teem's writer) in
// LPS, RAS and no space, raw and gzip encodings, a detached header, a 4D list axis, 2D, and broken
// files; and the same volume as a NIfTI file written by our writer.
#include "app/io/nrrd_io.h"

#include <gtest/gtest.h>
#include <unistd.h>
#include <zlib.h>

#include <Eigen/Geometry>
#include <atomic>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>
#include <vector>

#include "app/io/nifti_io.h"
#include "app/io/volume_io.h"
#include "file_test_fixture.h"
#include "sim/base/error.h"

namespace handson {
namespace {

namespace fs = std::filesystem;

using NrrdIo = test::FileTest;
using test::compressed;
using test::ramp;
using test::raw;


// An oblique LPS volume (Slicer's default space): directions and origin come back in RAS (x and y
// negated), values and index order as written; the same volume through our NIfTI writer and the
// content-sniffing loader gives the same grid.
TEST_F(NrrdIo, LpsSpaceIsConvertedToRas) {
  const auto values = ramp(4 * 3 * 5);
  const Eigen::Matrix3d R = Eigen::AngleAxisd(0.3, Eigen::Vector3d(1, -2, 0.5).normalized()).toRotationMatrix();
  const Eigen::Vector3d spacing(0.8, 1.1, 2.5), originLps(-10.5, 20.25, 33.0);
  std::ostringstream h;
  h.precision(17);
  h << "NRRD0004\n# written by the test\ntype: short\ndimension: 3\nspace: left-posterior-superior\nsizes: 4 3 5\nspace directions:";
  for (int c = 0; c < 3; ++c) h << " (" << R(0, c) * spacing[c] << "," << R(1, c) * spacing[c] << "," << R(2, c) * spacing[c] << ")";
  h << "\nkinds: domain domain domain\nendian: little\nencoding: raw\nspace origin: (" << originLps.x() << "," << originLps.y() << ","
    << originLps.z() << ")\n\n";
  write("lps.nrrd", h.str() + raw(values));
  NrrdInfo info;
  const Volume v = readNrrd(path("lps.nrrd"), 0, &info);
  EXPECT_EQ(info.space, "left-posterior-superior");
  ASSERT_EQ(v.dims(), Eigen::Vector3i(4, 3, 5));
  EXPECT_EQ(v.type(), ScalarType::Int16);
  for (std::size_t i = 0; i < values.size(); ++i) ASSERT_EQ(v.value(i), values[i]) << i;
  const Eigen::Matrix3d flip = Eigen::Vector3d(-1, -1, 1).asDiagonal();
  EXPECT_LT((v.geometry().direction - flip * R).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_LT((v.geometry().spacing - spacing).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_LT((v.geometry().origin - flip * originLps).norm(), 1e-12);
  // The same through loadVolume (sniffed by content, whatever the name) and through NIfTI.
  write("no_extension", h.str() + raw(values));
  LoadReport rep;
  const Volume sniffed = loadVolume(path("no_extension"), &rep);
  EXPECT_EQ(rep.format.rfind("NRRD", 0), 0u) << rep.format;
  writeNifti(v, path("same.nii.gz"));
  const Volume viaNifti = loadVolume(path("same.nii.gz"));
  EXPECT_TRUE(sniffed.geometry().sameGrid(viaNifti.geometry()));
  for (std::size_t i = 0; i < values.size(); ++i) ASSERT_EQ(sniffed.value(i), viaNifti.value(i));
}

// A gzip-encoded uint8 label map in RAS space (a segmentation), big-endian shorts with a detached
// header, and a file without space information.
TEST_F(NrrdIo, EncodingsDetachedDataAndNoSpace) {
  std::vector<std::uint8_t> labels(6 * 5 * 4);
  for (std::size_t i = 0; i < labels.size(); ++i) labels[i] = std::uint8_t(i % 7);
  write("seg.seg.nrrd", "NRRD0004\ntype: uint8\ndimension: 3\nspace: right-anterior-superior\nsizes: 6 5 4\n"
                        "space directions: (2,0,0) (0,2,0) (0,0,3)\nkinds: domain domain domain\nencoding: gzip\nspace origin: (1,2,3)\n\n" +
                            compressed(raw(labels), 15 + 16));
  const Volume seg = loadVolume(path("seg.seg.nrrd"));
  EXPECT_EQ(seg.type(), ScalarType::UInt8);
  EXPECT_EQ(seg.geometry().origin, Eigen::Vector3d(1, 2, 3));
  EXPECT_EQ(seg.geometry().spacing, Eigen::Vector3d(2, 2, 3));
  for (std::size_t i = 0; i < labels.size(); ++i) ASSERT_EQ(seg.value(i), labels[i]);

  const auto values = ramp(3 * 4 * 2);
  std::string big;
  for (std::int16_t x : values) {
    big.push_back(char((std::uint16_t(x) >> 8) & 0xff));
    big.push_back(char(std::uint16_t(x) & 0xff));
  }
  write("data.raw", big);
  write("detached.nhdr", "NRRD0004\ntype: short\ndimension: 3\nsizes: 3 4 2\nspacings: 0.5 0.5 1.5\nendian: big\nencoding: raw\ndata file: data.raw\n");
  const Volume d = loadVolume(path("detached.nhdr"));
  EXPECT_EQ(d.geometry().spacing, Eigen::Vector3d(0.5, 0.5, 1.5));
  EXPECT_EQ(d.geometry().origin, Eigen::Vector3d::Zero());
  for (std::size_t i = 0; i < values.size(); ++i) ASSERT_EQ(d.value(i), values[i]);
}

// A list axis first (vector data, a segmentation's layers): one volume per entry, chosen by frame,
// the count told; 2D: a one-slice volume; doubles become float32.
TEST_F(NrrdIo, ListAxisAnd2D) {
  std::vector<float> v(2 * 3 * 2 * 2);
  for (std::size_t i = 0; i < v.size(); ++i) v[i] = float(i) + 0.25f;
  write("list.nrrd", "NRRD0004\ntype: float\ndimension: 4\nspace: left-posterior-superior\nsizes: 2 3 2 2\n"
                     "space directions: none (1,0,0) (0,1,0) (0,0,1)\nkinds: list domain domain domain\nendian: little\nencoding: raw\n\n" +
                         raw(v));
  for (int f = 0; f < 2; ++f) {
    NrrdInfo info;
    const Volume x = readNrrd(path("list.nrrd"), f, &info);
    EXPECT_EQ(info.frames, 2);
    ASSERT_EQ(x.dims(), Eigen::Vector3i(3, 2, 2));
    for (std::size_t i = 0; i < 12; ++i) ASSERT_EQ(x.value(i), v[2 * i + std::size_t(f)]);
  }
  EXPECT_THROW(readNrrd(path("list.nrrd"), 2), Error);
  std::vector<double> flat{1.5, 2.5, 3.5, 4.5, 5.5, 6.5};
  write("flat.nrrd", "NRRD0004\ntype: double\ndimension: 2\nsizes: 3 2\nendian: little\nencoding: raw\n\n" + raw(flat));
  const Volume s = readNrrd(path("flat.nrrd"));
  EXPECT_EQ(s.dims(), Eigen::Vector3i(3, 2, 1));
  EXPECT_EQ(s.type(), ScalarType::Float32);
  EXPECT_EQ(s.value(5), 6.5f);
}

// Written by writeNrrd (and writeVolume for a .nrrd path): read back, the same grid and values,
// every type; the header is LPS as 3D Slicer writes it; a failed write leaves nothing.
TEST_F(NrrdIo, WriteReadRoundTrip) {
  VolumeGeometry g;
  g.dims = {5, 4, 3};
  g.spacing = {0.7, 1.3, 2.5};
  g.origin = {-100.5, 20.25, 33.0};
  g.direction = Eigen::AngleAxisd(0.4, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  for (ScalarType type : {ScalarType::UInt8, ScalarType::Int16, ScalarType::Float32}) {
    SCOPED_TRACE(scalarTypeName(type));
    Volume v(g, type);
    for (std::size_t i = 0; i < v.voxelCount(); ++i) v.setValue(i, type == ScalarType::Float32 ? float(i) * 0.5f - 7.25f : float(i * 3 % 200));
    const std::string file = path(std::string("out_") + scalarTypeName(type) + ".nrrd");
    writeVolume(v, file);
    std::ifstream in(file, std::ios::binary);
    std::string head(2000, '\0');
    in.read(head.data(), std::streamsize(head.size()));
    head.resize(std::size_t(in.gcount()));
    EXPECT_EQ(head.rfind("NRRD000", 0), 0u);
    EXPECT_NE(head.find("space: left-posterior-superior"), std::string::npos);
    EXPECT_NE(head.find("encoding: gzip"), std::string::npos);
    const Volume back = loadVolume(file);
    EXPECT_EQ(back.type(), type);
    EXPECT_TRUE(back.geometry().sameGrid(g));
    EXPECT_LT((back.geometry().origin - g.origin).norm(), 1e-9);
    for (std::size_t i = 0; i < v.voxelCount(); ++i) ASSERT_EQ(back.value(i), v.value(i)) << i;
  }
  EXPECT_THROW(writeNrrd(Volume(g, ScalarType::Int16), path("no/such/dir/x.nrrd")), Error);
  std::size_t left = 0;
  for (const auto& e : fs::directory_iterator(dir_)) left += e.path().filename().string().find(".tmp-") != std::string::npos;
  EXPECT_EQ(left, 0u);
}

// Broken files: a clear error naming the file, never a crash or an allocation of the declared size.
TEST_F(NrrdIo, BrokenFilesAreRefused) {
  const auto values = ramp(24);
  const std::string header = "NRRD0004\ntype: short\ndimension: 3\nsizes: 2 3 4\nendian: little\nencoding: raw\n\n";
  write("short.nrrd", header + raw(values).substr(0, 30));
  write("huge.nrrd", "NRRD0004\ntype: double\ndimension: 3\nsizes: 100000 100000 100000\nencoding: raw\n\n" + raw(values));
  write("junk.nrrd", "NRRD0004\ntype: banana\ndimension: 3\n\n");
  write("gz.nrrd", "NRRD0004\ntype: short\ndimension: 3\nsizes: 2 3 4\nencoding: gzip\n\nnot gzip data at all");
  write("nodata.nhdr", "NRRD0004\ntype: short\ndimension: 3\nsizes: 2 3 4\nencoding: raw\ndata file: missing.raw\n");
  write("five.nrrd", "NRRD0004\ntype: short\ndimension: 5\nsizes: 2 2 2 2 2\nendian: little\nencoding: raw\n\n" + raw(ramp(32)));
  for (const char* f : {"short.nrrd", "huge.nrrd", "junk.nrrd", "gz.nrrd", "nodata.nhdr", "five.nrrd"}) {
    SCOPED_TRACE(f);
    try {
      (void)loadVolume(path(f));
      ADD_FAILURE() << "accepted";
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find(f), std::string::npos) << e.what();
    }
  }
  // Found by fuzz_nrrd: raw data declared far larger than the file (2.5 GB in 269 bytes) is refused
  // from the header, before Teem allocates it.
  write("declared.nrrd", "NRRD0004\ntype: short\ndimension: 3\nsizes: 2 311111111 2\nendian: little\nencoding: raw\n\n" + raw(values));
  try {
    (void)loadVolume(path("declared.nrrd"));
    ADD_FAILURE() << "accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("declares 2488888888 bytes of data but the file holds only"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace handson
