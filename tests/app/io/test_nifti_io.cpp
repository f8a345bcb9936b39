// Tests for app/io/nifti_io: round trips through writeNifti/readNifti, hand-built NIfTI-1 and NIfTI-2
// files in both byte orders (headers laid out here byte by byte, independently of the reader's
// structs), scaling, and the refusal of broken or unsupported files.
#include "app/io/nifti_io.h"

#include <gtest/gtest.h>
#include <unistd.h>
#include <zlib.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <atomic>
#include <bit>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <initializer_list>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "sim/base/error.h"
#include "sim/volume.h"

#ifndef HANDSON_SHARED_DATA_DIR
#define HANDSON_SHARED_DATA_DIR "../shared/data"
#endif

namespace {

namespace fs = std::filesystem;
using handson::ScalarType;
using handson::Volume;
using handson::VolumeGeometry;

// ---- byte-level file building ------------------------------------------------------------------

// A growable byte buffer that stores values in a chosen byte order.
class Bytes {
 public:
  explicit Bytes(bool bigEndian = false) : big_(bigEndian) {}

  template <class T> void put(std::size_t offset, T v) {
    unsigned char b[sizeof(T)];
    std::memcpy(b, &v, sizeof(T));
    if (big_ != (std::endian::native == std::endian::big)) std::reverse(b, b + sizeof(T));
    putRaw(offset, b, sizeof(T));
  }
  void putRaw(std::size_t offset, const void* p, std::size_t n) {
    if (offset + n > data.size()) data.resize(offset + n, 0);
    std::memcpy(data.data() + offset, p, n);
  }
  template <class T> void append(const std::vector<T>& values) {
    for (const T& v : values) put(data.size(), v);
  }
  void resize(std::size_t n) { data.resize(n, 0); }

  std::vector<unsigned char> data;

 private:
  bool big_;
};

// Fields of a NIfTI-1 header the tests vary. Offsets follow the NIfTI-1 standard.
struct N1Spec {
  std::array<std::int16_t, 8> dim{3, 4, 3, 2, 1, 1, 1, 1};
  std::int16_t datatype = 4;  // int16
  std::int16_t bitpix = 16;
  std::array<float, 8> pixdim{1, 1, 1, 1, 1, 1, 1, 1};
  float voxOffset = 352;
  float slope = 0;
  float inter = 0;
  std::int16_t qformCode = 0;
  std::int16_t sformCode = 0;
  std::array<float, 3> quat{0, 0, 0};
  std::array<float, 3> qoffset{0, 0, 0};
  std::array<float, 12> srow{1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0};
  std::array<char, 4> magic{'n', '+', '1', '\0'};
  bool bigEndian = false;
};

Bytes buildN1(const N1Spec& s) {
  Bytes b(s.bigEndian);
  b.resize(352);
  b.put<std::int32_t>(0, 348);
  for (int i = 0; i < 8; ++i) b.put<std::int16_t>(40 + 2 * i, s.dim[i]);
  b.put<std::int16_t>(70, s.datatype);
  b.put<std::int16_t>(72, s.bitpix);
  for (int i = 0; i < 8; ++i) b.put<float>(76 + 4 * i, s.pixdim[i]);
  b.put<float>(108, s.voxOffset);
  b.put<float>(112, s.slope);
  b.put<float>(116, s.inter);
  b.put<char>(123, 2);  // mm
  b.put<std::int16_t>(252, s.qformCode);
  b.put<std::int16_t>(254, s.sformCode);
  for (int i = 0; i < 3; ++i) b.put<float>(256 + 4 * i, s.quat[i]);
  for (int i = 0; i < 3; ++i) b.put<float>(268 + 4 * i, s.qoffset[i]);
  for (int i = 0; i < 12; ++i) b.put<float>(280 + 4 * i, s.srow[i]);
  b.putRaw(344, s.magic.data(), 4);
  if (s.voxOffset > 352) b.resize(static_cast<std::size_t>(s.voxOffset));
  return b;
}

// Fields of a NIfTI-2 header the tests vary. Offsets follow the NIfTI-2 standard.
struct N2Spec {
  std::array<std::int64_t, 8> dim{3, 4, 3, 2, 1, 1, 1, 1};
  std::int16_t datatype = 8;  // int32
  std::int16_t bitpix = 32;
  std::array<double, 8> pixdim{1, 1, 1, 1, 1, 1, 1, 1};
  std::int64_t voxOffset = 544;
  double slope = 0;
  double inter = 0;
  std::int32_t qformCode = 0;
  std::int32_t sformCode = 0;
  std::array<double, 3> quat{0, 0, 0};
  std::array<double, 3> qoffset{0, 0, 0};
  std::array<double, 12> srow{1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0};
  bool bigEndian = false;
};

Bytes buildN2(const N2Spec& s) {
  Bytes b(s.bigEndian);
  b.resize(544);
  b.put<std::int32_t>(0, 540);
  b.putRaw(4, "n+2\0\r\n\032\n", 8);
  b.put<std::int16_t>(12, s.datatype);
  b.put<std::int16_t>(14, s.bitpix);
  for (int i = 0; i < 8; ++i) b.put<std::int64_t>(16 + 8 * i, s.dim[i]);
  for (int i = 0; i < 8; ++i) b.put<double>(104 + 8 * i, s.pixdim[i]);
  b.put<std::int64_t>(168, s.voxOffset);
  b.put<double>(176, s.slope);
  b.put<double>(184, s.inter);
  b.put<std::int32_t>(344, s.qformCode);
  b.put<std::int32_t>(348, s.sformCode);
  for (int i = 0; i < 3; ++i) b.put<double>(352 + 8 * i, s.quat[i]);
  for (int i = 0; i < 3; ++i) b.put<double>(376 + 8 * i, s.qoffset[i]);
  for (int i = 0; i < 12; ++i) b.put<double>(400 + 8 * i, s.srow[i]);
  b.put<std::int32_t>(500, 2);  // mm
  if (s.voxOffset > 544) b.resize(static_cast<std::size_t>(s.voxOffset));
  return b;
}

void writeFile(const std::string& path, const std::vector<unsigned char>& bytes) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
  ASSERT_TRUE(out.good()) << path;
}

void writeGzFile(const std::string& path, const std::vector<unsigned char>& bytes) {
  gzFile gz = gzopen(path.c_str(), "wb6");
  ASSERT_NE(gz, nullptr) << path;
  if (!bytes.empty()) {
    ASSERT_EQ(gzwrite(gz, bytes.data(), static_cast<unsigned>(bytes.size())), int(bytes.size()));
  }
  ASSERT_EQ(gzclose(gz), Z_OK);
}

std::vector<unsigned char> readFileBytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::vector<unsigned char>(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

// A header field of a file written by writeNifti (which writes host byte order).
template <class T> T getHost(const std::vector<unsigned char>& b, std::size_t offset) {
  T v;
  std::memcpy(&v, b.data() + offset, sizeof(T));
  return v;
}

// ---- volumes and comparisons -------------------------------------------------------------------

VolumeGeometry obliqueGeometry() {
  VolumeGeometry g;
  g.dims = {7, 5, 4};
  g.spacing = {0.7, 1.3, 2.5};
  g.origin = {-100.5, 20.25, 33.0};
  g.direction = Eigen::AngleAxisd(0.4, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  return g;
}

Volume makeVolume(ScalarType type, const VolumeGeometry& g) {
  Volume v(g, type);
  const std::size_t n = v.voxelCount();
  std::mt19937 rng(1234);
  switch (type) {
    case ScalarType::UInt8: {
      auto* d = v.data<std::uint8_t>();
      for (std::size_t i = 0; i < n; ++i) d[i] = static_cast<std::uint8_t>(rng() & 0xff);
      d[0] = 0;
      d[1] = 255;
      break;
    }
    case ScalarType::Int16: {
      auto* d = v.data<std::int16_t>();
      for (std::size_t i = 0; i < n; ++i) d[i] = static_cast<std::int16_t>(int(rng() % 4096) - 1024);
      d[0] = -32768;
      d[1] = 32767;
      break;
    }
    case ScalarType::Float32: {
      auto* d = v.data<float>();
      std::uniform_real_distribution<float> u(-1000.0f, 1000.0f);
      for (std::size_t i = 0; i < n; ++i) d[i] = u(rng);
      d[0] = 1e-30f;
      d[1] = -3.0e38f;
      break;
    }
  }
  return v;
}

void expectNear(const Eigen::MatrixXd& actual, const Eigen::MatrixXd& expected, double tol, const char* what) {
  ASSERT_EQ(actual.rows(), expected.rows());
  ASSERT_EQ(actual.cols(), expected.cols());
  EXPECT_LE((actual - expected).cwiseAbs().maxCoeff(), tol) << what << "\nactual:\n" << actual << "\nexpected:\n"
                                                             << expected;
}

void expectSameGeometry(const VolumeGeometry& a, const VolumeGeometry& b, double tol = 1e-5) {
  EXPECT_EQ(a.dims, b.dims);
  expectNear(a.spacing, b.spacing, tol, "spacing");
  expectNear(a.origin, b.origin, tol * 100, "origin");
  expectNear(a.direction, b.direction, tol, "direction");
}

std::vector<float> allValues(const Volume& v) {
  std::vector<float> out(v.voxelCount());
  for (std::size_t i = 0; i < out.size(); ++i) out[i] = v.value(i);
  return out;
}

// ---- fixture -----------------------------------------------------------------------------------

class NiftiIo : public ::testing::Test {
 protected:
  void SetUp() override {
    static std::atomic<int> counter{0};
    std::random_device rd;
    dir_ = fs::temp_directory_path() / ("handson_nifti_test_" + std::to_string(getpid()) + "_" +
                                        std::to_string(counter++) + "_" + std::to_string(rd()));
    fs::create_directories(dir_);
  }
  void TearDown() override {
    std::error_code ec;
    fs::remove_all(dir_, ec);
  }
  std::string path(const std::string& name) const { return (dir_ / name).string(); }

  // Names of the entries in the temp dir (to spot leftover temporary files).
  std::vector<std::string> listing() const {
    std::vector<std::string> names;
    for (const auto& e : fs::directory_iterator(dir_)) names.push_back(e.path().filename().string());
    std::sort(names.begin(), names.end());
    return names;
  }

  // readNifti must throw handson::Error naming the file and containing one of `fragments`.
  void expectReadError(const std::string& file, std::initializer_list<const char*> fragments) {
    try {
      (void)handson::readNifti(file);
      ADD_FAILURE() << "readNifti accepted " << file;
    } catch (const handson::Error& e) {
      const std::string msg = e.what();
      EXPECT_NE(msg.find(file), std::string::npos) << "message does not name the file: " << msg;
      bool found = false;
      for (const char* f : fragments) found = found || msg.find(f) != std::string::npos;
      EXPECT_TRUE(found) << "unexpected message: " << msg;
    }
  }

  fs::path dir_;
};

// Writes a NIfTI-1 file with the given header spec and values, reads it back.
template <class T> Volume roundTripRaw(const std::string& file, N1Spec spec, const std::vector<T>& values) {
  spec.bitpix = static_cast<std::int16_t>(8 * sizeof(T));
  Bytes b = buildN1(spec);
  b.append(values);
  writeFile(file, b.data);
  return handson::readNifti(file);
}

// ---- round trips -------------------------------------------------------------------------------

TEST_F(NiftiIo, RoundTripAllTypesPlainAndGzip) {
  const VolumeGeometry g = obliqueGeometry();
  for (ScalarType type : {ScalarType::UInt8, ScalarType::Int16, ScalarType::Float32}) {
    for (const char* ext : {".nii", ".nii.gz"}) {
      SCOPED_TRACE(std::string(handson::scalarTypeName(type)) + ext);
      const Volume original = makeVolume(type, g);
      const std::string file = path(std::string("vol_") + handson::scalarTypeName(type) + ext);
      handson::writeNifti(original, file);
      const auto bytes = readFileBytes(file);
      ASSERT_GE(bytes.size(), 2u);
      EXPECT_EQ(bytes[0] == 0x1f && bytes[1] == 0x8b, std::string(ext) == ".nii.gz");

      const Volume back = handson::readNifti(file);
      EXPECT_EQ(back.type(), type);
      expectSameGeometry(back.geometry(), g);
      ASSERT_EQ(back.byteSize(), original.byteSize());
      EXPECT_EQ(std::memcmp(back.bytes(), original.bytes(), original.byteSize()), 0);
    }
  }
  EXPECT_EQ(listing().size(), 6u);  // no temporary files left
}

TEST_F(NiftiIo, WrittenHeaderFields) {
  VolumeGeometry g = obliqueGeometry();
  g.direction.col(2) *= -1.0;  // left-handed
  const Volume v = makeVolume(ScalarType::Int16, g);
  const std::string file = path("fields.nii");
  handson::writeNifti(v, file);
  const auto b = readFileBytes(file);
  ASSERT_EQ(b.size(), 352u + v.byteSize());
  EXPECT_EQ(getHost<std::int32_t>(b, 0), 348);
  EXPECT_EQ(std::memcmp(b.data() + 344, "n+1\0", 4), 0);
  EXPECT_EQ(getHost<std::int16_t>(b, 40), 3);
  EXPECT_EQ(getHost<std::int16_t>(b, 42), 7);
  EXPECT_EQ(getHost<std::int16_t>(b, 44), 5);
  EXPECT_EQ(getHost<std::int16_t>(b, 46), 4);
  EXPECT_EQ(getHost<std::int16_t>(b, 70), 4);   // DT_INT16
  EXPECT_EQ(getHost<std::int16_t>(b, 72), 16);  // bitpix
  EXPECT_EQ(getHost<float>(b, 76), -1.0f);      // qfac for a left-handed grid
  EXPECT_FLOAT_EQ(getHost<float>(b, 80), 0.7f);
  EXPECT_FLOAT_EQ(getHost<float>(b, 84), 1.3f);
  EXPECT_FLOAT_EQ(getHost<float>(b, 88), 2.5f);
  EXPECT_EQ(getHost<float>(b, 108), 352.0f);
  const float slope = getHost<float>(b, 112), inter = getHost<float>(b, 116);
  EXPECT_TRUE((slope == 1.0f && inter == 0.0f) || (slope == 0.0f && inter == 0.0f));
  EXPECT_EQ(b[123] & 7, 2);                      // mm
  EXPECT_EQ(getHost<std::int16_t>(b, 252), 1);     // qform_code
  EXPECT_EQ(getHost<std::int16_t>(b, 254), 1);     // sform_code
  EXPECT_EQ(getHost<std::int32_t>(b, 348), 0);     // no extensions
  const Eigen::Matrix4d affine = g.indexToWorld();
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 4; ++c) EXPECT_NEAR(getHost<float>(b, 280 + 16 * r + 4 * c), affine(r, c), 1e-4);
}

// With the sform removed, the qform the writer produced must give back the same geometry, for
// right- and left-handed directions.
TEST_F(NiftiIo, WrittenQformMatchesGeometry) {
  for (bool leftHanded : {false, true}) {
    SCOPED_TRACE(leftHanded ? "left-handed" : "right-handed");
    VolumeGeometry g = obliqueGeometry();
    if (leftHanded) g.direction.col(1) *= -1.0;
    const std::string file = path(leftHanded ? "lh.nii" : "rh.nii");
    handson::writeNifti(makeVolume(ScalarType::Float32, g), file);
    auto b = readFileBytes(file);
    const std::int16_t zero = 0;
    std::memcpy(b.data() + 254, &zero, 2);  // sform_code = 0
    writeFile(file, b);
    expectSameGeometry(handson::readNifti(file).geometry(), g);
  }
}

TEST_F(NiftiIo, NonOrthonormalDirectionKeepsAffineAndDropsQform) {
  VolumeGeometry g = obliqueGeometry();
  g.direction(0, 1) += 0.3;  // sheared
  g.direction.col(1).normalize();
  const std::string file = path("shear.nii.gz");
  handson::writeNifti(makeVolume(ScalarType::UInt8, g), file);
  const Volume back = handson::readNifti(file);
  expectNear(back.geometry().indexToWorld(), g.indexToWorld(), 1e-4, "affine");

  const std::string plain = path("shear.nii");
  handson::writeNifti(makeVolume(ScalarType::UInt8, g), plain);
  EXPECT_EQ(getHost<std::int16_t>(readFileBytes(plain), 252), 0);  // qform_code
}

TEST_F(NiftiIo, OverwriteReplacesExistingFile) {
  const std::string file = path("over.nii");
  writeFile(file, std::vector<unsigned char>(10, 'x'));
  const Volume v = makeVolume(ScalarType::Int16, obliqueGeometry());
  handson::writeNifti(v, file);
  EXPECT_EQ(handson::readNifti(file).voxelCount(), v.voxelCount());
  EXPECT_EQ(listing(), std::vector<std::string>{"over.nii"});
}

// ---- hand-built files --------------------------------------------------------------------------

TEST_F(NiftiIo, ReadsNifti2) {
  N2Spec s;
  s.datatype = 8;  // int32, values fit int16
  s.sformCode = 1;
  s.srow = {0, 0, 2.0, 10, -1.5, 0, 0, 20, 0, 3.0, 0, -30};
  std::vector<std::int32_t> values(24);
  for (int i = 0; i < 24; ++i) values[i] = i * 100 - 1000;
  for (bool big : {false, true}) {
    SCOPED_TRACE(big ? "big-endian" : "little-endian");
    s.bigEndian = big;
    Bytes b = buildN2(s);
    b.append(values);
    const std::string file = path(big ? "n2be.nii.gz" : "n2le.nii");
    if (big) writeGzFile(file, b.data);
    else writeFile(file, b.data);
    const Volume v = handson::readNifti(file);
    EXPECT_EQ(v.type(), ScalarType::Int16);
    EXPECT_EQ(v.dims(), Eigen::Vector3i(4, 3, 2));
    expectNear(v.geometry().spacing, Eigen::Vector3d(1.5, 3.0, 2.0), 1e-12, "spacing");
    expectNear(v.geometry().origin, Eigen::Vector3d(10, 20, -30), 1e-12, "origin");
    Eigen::Matrix3d dir;
    dir << 0, 0, 1, -1, 0, 0, 0, 1, 0;
    expectNear(v.geometry().direction, dir, 1e-12, "direction");
    for (int i = 0; i < 24; ++i) EXPECT_EQ(v.value(std::size_t(i)), float(values[i]));
  }
}

TEST_F(NiftiIo, ReadsNifti2Float64WithExtensionOffset) {
  N2Spec s;
  s.datatype = 64;
  s.bitpix = 64;
  s.voxOffset = 640;
  s.pixdim = {1, 0.5, 0.25, 4, 1, 1, 1, 1};
  Bytes b = buildN2(s);
  b.put<std::int32_t>(540, 1);  // extension flag: the 96 extra bytes are an extension
  std::vector<double> values(24);
  for (int i = 0; i < 24; ++i) values[i] = i * 0.125 - 1.0;
  b.append(values);
  writeFile(path("f64.nii"), b.data);
  const Volume v = handson::readNifti(path("f64.nii"));
  EXPECT_EQ(v.type(), ScalarType::Float32);
  expectNear(v.geometry().spacing, Eigen::Vector3d(0.5, 0.25, 4), 1e-12, "spacing");
  for (int i = 0; i < 24; ++i) EXPECT_EQ(v.value(std::size_t(i)), float(values[i]));
}

TEST_F(NiftiIo, ReadsBigEndianNifti1) {
  N1Spec s;
  s.bigEndian = true;
  s.sformCode = 2;
  s.srow = {-0.8f, 0, 0, 100, 0, -0.8f, 0, 50, 0, 0, 2.5f, -70};
  std::vector<std::int16_t> values(24);
  for (int i = 0; i < 24; ++i) values[i] = static_cast<std::int16_t>(i * 1000 - 12000);
  for (bool gz : {false, true}) {
    SCOPED_TRACE(gz ? "gzip" : "plain");
    Bytes b = buildN1(s);
    b.append(values);
    const std::string file = path(gz ? "be.nii.gz" : "be.nii");
    if (gz) writeGzFile(file, b.data);
    else writeFile(file, b.data);
    const Volume v = handson::readNifti(file);
    EXPECT_EQ(v.type(), ScalarType::Int16);
    EXPECT_EQ(v.dims(), Eigen::Vector3i(4, 3, 2));
    expectNear(v.geometry().spacing, Eigen::Vector3d(0.8, 0.8, 2.5), 1e-6, "spacing");
    expectNear(v.geometry().origin, Eigen::Vector3d(100, 50, -70), 1e-6, "origin");
    expectNear(v.geometry().direction, Eigen::Vector3d(-1, -1, 1).asDiagonal().toDenseMatrix(), 1e-12, "direction");
    for (int i = 0; i < 24; ++i) EXPECT_EQ(v.value(std::size_t(i)), float(values[i]));
  }

  // Big-endian float32 and uint16 too.
  N1Spec f = s;
  f.datatype = 16;
  std::vector<float> fv(24);
  for (int i = 0; i < 24; ++i) fv[i] = float(i) * 0.5f - 3.25f;
  const Volume vf = roundTripRaw(path("bef.nii"), f, fv);
  EXPECT_EQ(vf.type(), ScalarType::Float32);
  EXPECT_EQ(allValues(vf), fv);

  N1Spec u = s;
  u.datatype = 512;
  std::vector<std::uint16_t> uv(24);
  for (int i = 0; i < 24; ++i) uv[i] = static_cast<std::uint16_t>(i * 2000);  // up to 46000: not int16
  const Volume vu = roundTripRaw(path("beu16.nii"), u, uv);
  EXPECT_EQ(vu.type(), ScalarType::Float32);
  for (int i = 0; i < 24; ++i) EXPECT_EQ(vu.value(std::size_t(i)), float(uv[i]));
}

// qform only: geometry from the quaternion, pixdim and qoffset, checked against hand computation.
TEST_F(NiftiIo, QformOnly) {
  {
    // 120 degrees about (1,1,1): a = b = c = d = 1/2 maps x->y, y->z, z->x. qfac = +1.
    N1Spec s;
    s.qformCode = 1;
    s.quat = {0.5f, 0.5f, 0.5f};
    s.qoffset = {10, -20, 30};
    s.pixdim = {1, 2, 3, 4, 1, 1, 1, 1};
    const Volume v = roundTripRaw(path("q1.nii"), s, std::vector<std::int16_t>(24, 7));
    Eigen::Matrix3d dir;
    dir << 0, 0, 1,  //
        1, 0, 0,     //
        0, 1, 0;
    expectNear(v.geometry().direction, dir, 1e-6, "direction");
    expectNear(v.geometry().spacing, Eigen::Vector3d(2, 3, 4), 1e-12, "spacing");
    // index (1,2,3) -> origin + 1*2*y + 2*3*z + 3*4*x = (10+12, -20+2, 30+6)
    expectNear(v.geometry().toWorld(Eigen::Vector3d(1, 2, 3)), Eigen::Vector3d(22, -18, 36), 1e-5, "world");
  }
  {
    // 90 degrees about z (b = c = 0, d = sin 45) with qfac = -1: i -> +y, j -> -x, k -> -z.
    N1Spec s;
    s.qformCode = 1;
    s.quat = {0, 0, float(std::sqrt(0.5))};
    s.qoffset = {10, -20, 30};
    s.pixdim = {-1, 2, 3, 4, 1, 1, 1, 1};
    const Volume v = roundTripRaw(path("q2.nii"), s, std::vector<std::int16_t>(24, 7));
    Eigen::Matrix3d dir;
    dir << 0, -1, 0,  //
        1, 0, 0,      //
        0, 0, -1;
    expectNear(v.geometry().direction, dir, 1e-6, "direction");
    // index (1,2,3) -> (10 - 2*3, -20 + 1*2, 30 - 3*4)
    expectNear(v.geometry().toWorld(Eigen::Vector3d(1, 2, 3)), Eigen::Vector3d(4, -18, 18), 1e-5, "world");
  }
}

TEST_F(NiftiIo, PixdimOnly) {
  N1Spec s;
  s.pixdim = {0, 0.5, 0.75, 3, 0, 0, 0, 0};
  const Volume v = roundTripRaw(path("pix.nii"), s, std::vector<std::int16_t>(24, 1));
  expectNear(v.geometry().spacing, Eigen::Vector3d(0.5, 0.75, 3), 1e-12, "spacing");
  expectNear(v.geometry().origin, Eigen::Vector3d::Zero(), 0, "origin");
  expectNear(v.geometry().direction, Eigen::Matrix3d::Identity(), 0, "direction");
}

TEST_F(NiftiIo, SformWinsOverQform) {
  N1Spec s;
  s.qformCode = 1;
  s.quat = {0, 0, 1};  // 180 degrees about z
  s.qoffset = {1, 2, 3};
  s.sformCode = 1;
  s.srow = {2, 0, 0, 5, 0, 2, 0, 6, 0, 0, 2, 7};
  const Volume v = roundTripRaw(path("both.nii"), s, std::vector<std::int16_t>(24, 1));
  expectNear(v.geometry().origin, Eigen::Vector3d(5, 6, 7), 1e-12, "origin");
  expectNear(v.geometry().direction, Eigen::Matrix3d::Identity(), 1e-12, "direction");
  expectNear(v.geometry().spacing, Eigen::Vector3d(2, 2, 2), 1e-12, "spacing");
}

TEST_F(NiftiIo, VoxOffsetAndExtraUnitDims) {
  N1Spec s;
  s.voxOffset = 432;  // an 80-byte extension sits before the data
  s.dim = {5, 4, 3, 2, 1, 1, 1, 1};
  Bytes b = buildN1(s);
  b.put<std::int32_t>(348, 1);
  b.put<std::int32_t>(352, 80);
  b.put<std::int32_t>(356, 6);  // comment extension
  b.putRaw(360, "hello", 5);
  std::vector<std::int16_t> values(24);
  for (int i = 0; i < 24; ++i) values[i] = static_cast<std::int16_t>(i);
  b.append(values);
  writeGzFile(path("ext.nii.gz"), b.data);
  EXPECT_EQ(allValues(handson::readNifti(path("ext.nii.gz"))), std::vector<float>(values.begin(), values.end()));

  N1Spec z;  // vox_offset 0 in a single file: data right after the header
  z.voxOffset = 0;
  z.dim = {4, 4, 3, 2, 1, 1, 1, 1};
  EXPECT_EQ(allValues(roundTripRaw(path("off0.nii"), z, values)), std::vector<float>(values.begin(), values.end()));
}

TEST_F(NiftiIo, TrailingBytesAfterDataAccepted) {
  Bytes b = buildN1(N1Spec{});
  std::vector<std::int16_t> values(24, 3);
  b.append(values);
  b.append(std::vector<std::int16_t>(100, -1));
  writeFile(path("trail.nii"), b.data);
  writeGzFile(path("trail.nii.gz"), b.data);
  EXPECT_EQ(allValues(handson::readNifti(path("trail.nii"))), std::vector<float>(24, 3.0f));
  EXPECT_EQ(allValues(handson::readNifti(path("trail.nii.gz"))), std::vector<float>(24, 3.0f));
}

TEST_F(NiftiIo, TypesAndScaling) {
  std::vector<std::int16_t> i16(24);
  for (int i = 0; i < 24; ++i) i16[i] = static_cast<std::int16_t>(i * 10 - 50);
  N1Spec s;
  {
    SCOPED_TRACE("int16 slope 2 inter -1000 stays int16");
    s.slope = 2;
    s.inter = -1000;
    const Volume v = roundTripRaw(path("a.nii"), s, i16);
    EXPECT_EQ(v.type(), ScalarType::Int16);
    for (int i = 0; i < 24; ++i) EXPECT_EQ(v.value(std::size_t(i)), float(i16[i] * 2 - 1000));
  }
  {
    SCOPED_TRACE("int16 slope 0.5 becomes float");
    s.slope = 0.5f;
    s.inter = 0;
    const Volume v = roundTripRaw(path("b.nii"), s, i16);
    EXPECT_EQ(v.type(), ScalarType::Float32);
    for (int i = 0; i < 24; ++i) EXPECT_EQ(v.value(std::size_t(i)), float(i16[i]) * 0.5f);
  }
  {
    SCOPED_TRACE("int16 scaled out of range becomes float");
    s.slope = 1000;
    s.inter = 0;
    const Volume v = roundTripRaw(path("c.nii"), s, i16);
    EXPECT_EQ(v.type(), ScalarType::Float32);
    EXPECT_EQ(v.value(std::size_t(23)), 180000.0f);
  }
  {
    SCOPED_TRACE("int16 slope NaN ignored");
    s.slope = std::numeric_limits<float>::quiet_NaN();
    s.inter = 5;
    const Volume v = roundTripRaw(path("d.nii"), s, i16);
    EXPECT_EQ(v.type(), ScalarType::Int16);
    EXPECT_EQ(allValues(v), std::vector<float>(i16.begin(), i16.end()));
  }
  std::vector<std::uint8_t> u8(24);
  for (int i = 0; i < 24; ++i) u8[i] = static_cast<std::uint8_t>(i * 10);
  N1Spec u = s;
  u.datatype = 2;
  for (auto [slope, inter] : {std::pair<float, float>{1, 0}, {0, 0}, {0, 7}}) {
    SCOPED_TRACE("uint8 unscaled stays uint8");
    u.slope = slope;
    u.inter = inter;
    const Volume v = roundTripRaw(path("e.nii"), u, u8);
    EXPECT_EQ(v.type(), ScalarType::UInt8);
    EXPECT_EQ(allValues(v), std::vector<float>(u8.begin(), u8.end()));
  }
  {
    SCOPED_TRACE("uint8 slope 2 inter -10 becomes int16");
    u.slope = 2;
    u.inter = -10;
    const Volume v = roundTripRaw(path("f.nii"), u, u8);
    EXPECT_EQ(v.type(), ScalarType::Int16);
    for (int i = 0; i < 24; ++i) EXPECT_EQ(v.value(std::size_t(i)), float(u8[i] * 2 - 10));
  }
  {
    SCOPED_TRACE("float32 scaled");
    N1Spec f = s;
    f.datatype = 16;
    f.slope = 2;
    f.inter = 1;
    std::vector<float> fv(24);
    for (int i = 0; i < 24; ++i) fv[i] = float(i) * 0.25f;
    const Volume v = roundTripRaw(path("g.nii"), f, fv);
    EXPECT_EQ(v.type(), ScalarType::Float32);
    for (int i = 0; i < 24; ++i) EXPECT_EQ(v.value(std::size_t(i)), fv[i] * 2 + 1);
  }
  {
    SCOPED_TRACE("int8 becomes int16");
    N1Spec t = s;
    t.datatype = 256;
    t.slope = 0;
    std::vector<std::int8_t> v8(24);
    for (int i = 0; i < 24; ++i) v8[i] = static_cast<std::int8_t>(i * 10 - 120);
    const Volume v = roundTripRaw(path("h.nii"), t, v8);
    EXPECT_EQ(v.type(), ScalarType::Int16);
    EXPECT_EQ(allValues(v), std::vector<float>(v8.begin(), v8.end()));
  }
  N1Spec w = s;
  w.slope = 0;
  {
    SCOPED_TRACE("uint16 / uint32 / int64 / uint64 small values become int16");
    std::vector<std::uint16_t> a(24);
    std::vector<std::uint32_t> b(24);
    std::vector<std::int64_t> c(24);
    std::vector<std::uint64_t> d(24);
    for (int i = 0; i < 24; ++i) {
      a[i] = static_cast<std::uint16_t>(i * 1000);
      b[i] = static_cast<std::uint32_t>(i * 1000);
      c[i] = i * 1000 - 32768;
      d[i] = static_cast<std::uint64_t>(i);
    }
    w.datatype = 512;
    const Volume va = roundTripRaw(path("i1.nii"), w, a);
    w.datatype = 768;
    const Volume vb = roundTripRaw(path("i2.nii"), w, b);
    w.datatype = 1024;
    const Volume vc = roundTripRaw(path("i3.nii"), w, c);
    w.datatype = 1280;
    const Volume vd = roundTripRaw(path("i4.nii"), w, d);
    for (const Volume* v : {&va, &vb, &vc, &vd}) EXPECT_EQ(v->type(), ScalarType::Int16);
    EXPECT_EQ(allValues(va), std::vector<float>(a.begin(), a.end()));
    EXPECT_EQ(allValues(vb), std::vector<float>(b.begin(), b.end()));
    EXPECT_EQ(allValues(vc), std::vector<float>(c.begin(), c.end()));
    EXPECT_EQ(allValues(vd), std::vector<float>(d.begin(), d.end()));
  }
  {
    SCOPED_TRACE("int32 out of int16 range becomes float");
    std::vector<std::int32_t> a(24, 5);
    a[3] = 100000;
    a[4] = -40000;
    w.datatype = 8;
    const Volume v = roundTripRaw(path("j.nii"), w, a);
    EXPECT_EQ(v.type(), ScalarType::Float32);
    EXPECT_EQ(allValues(v), std::vector<float>(a.begin(), a.end()));
  }
  {
    SCOPED_TRACE("float64 becomes float32");
    std::vector<double> a(24, 2.0);
    a[5] = -1.5;
    w.datatype = 64;
    const Volume v = roundTripRaw(path("k.nii"), w, a);
    EXPECT_EQ(v.type(), ScalarType::Float32);
    EXPECT_EQ(allValues(v), std::vector<float>(a.begin(), a.end()));
  }
}

// ---- refusals ----------------------------------------------------------------------------------

TEST_F(NiftiIo, MissingFileAndDirectory) {
  expectReadError(path("does_not_exist.nii.gz"), {"not found"});
  expectReadError(dir_.string(), {"directory"});
}

TEST_F(NiftiIo, EmptyAndTruncatedHeader) {
  writeFile(path("empty.nii"), {});
  expectReadError(path("empty.nii"), {"empty"});
  Bytes b = buildN1(N1Spec{});
  b.resize(200);
  writeFile(path("short.nii"), b.data);
  expectReadError(path("short.nii"), {"truncated"});
  writeGzFile(path("short.nii.gz"), b.data);
  expectReadError(path("short.nii.gz"), {"truncated"});
}

TEST_F(NiftiIo, TruncatedData) {
  Bytes b = buildN1(N1Spec{});
  b.append(std::vector<std::int16_t>(23, 1));  // one voxel short
  writeFile(path("short.nii"), b.data);
  expectReadError(path("short.nii"), {"truncated"});
  writeGzFile(path("short.nii.gz"), b.data);
  expectReadError(path("short.nii.gz"), {"truncated"});

  // A gzip stream cut short (no trailer, last block missing).
  const std::string full = path("full.nii.gz");
  handson::writeNifti(makeVolume(ScalarType::Float32, obliqueGeometry()), full);
  auto bytes = readFileBytes(full);
  bytes.resize(bytes.size() / 2);
  writeFile(path("cut.nii.gz"), bytes);
  expectReadError(path("cut.nii.gz"), {"truncated"});
  // Only the 8-byte trailer (CRC and length) missing: the data are there but unverifiable.
  bytes = readFileBytes(full);
  ASSERT_GT(bytes.size(), 8u);
  bytes.erase(bytes.end() - 8, bytes.end());
  writeFile(path("notrailer.nii.gz"), bytes);
  expectReadError(path("notrailer.nii.gz"), {"truncated"});
}

TEST_F(NiftiIo, CorruptGzip) {
  // A compressible image, so the deflate stream is Huffman coded rather than stored.
  VolumeGeometry g;
  g.dims = {64, 64, 8};
  Volume v(g, ScalarType::UInt8);
  for (int k = 0; k < 8; ++k)
    for (int j = 0; j < 64; ++j)
      for (int i = 0; i < 64; ++i) v.setValue(i, j, k, float((i / 8 + j / 4 + k) % 7));
  const std::string good = path("good.nii.gz");
  handson::writeNifti(v, good);
  const auto original = readFileBytes(good);
  {
    auto bytes = original;
    for (std::size_t i = bytes.size() / 2; i < bytes.size() / 2 + 8; ++i) bytes[i] ^= 0x5a;
    writeFile(path("corrupt.nii.gz"), bytes);
    expectReadError(path("corrupt.nii.gz"), {"corrupt", "truncated"});
  }
  {
    // Random (incompressible) data are stored verbatim: damage there is caught by the CRC.
    const std::string stored = path("stored.nii.gz");
    handson::writeNifti(makeVolume(ScalarType::Float32, obliqueGeometry()), stored);
    auto bytes = readFileBytes(stored);
    for (std::size_t i = bytes.size() / 2; i < bytes.size() / 2 + 8; ++i) bytes[i] ^= 0x5a;
    writeFile(stored, bytes);
    expectReadError(stored, {"corrupt"});
  }
  {
    auto bytes = original;
    bytes[bytes.size() - 6] ^= 0xff;  // CRC mismatch
    writeFile(path("crc.nii.gz"), bytes);
    expectReadError(path("crc.nii.gz"), {"corrupt"});
  }
  {
    std::vector<unsigned char> bytes = {0x1f, 0x8b, 0x63, 0x00, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10};  // bad method
    writeFile(path("header.nii.gz"), bytes);
    expectReadError(path("header.nii.gz"), {"corrupt"});
  }
}

TEST_F(NiftiIo, WrongMagicAndNotNifti) {
  N1Spec s;
  s.magic = {'x', 'y', 'z', '\0'};
  Bytes b = buildN1(s);
  b.append(std::vector<std::int16_t>(24, 1));
  writeFile(path("magic.nii"), b.data);
  expectReadError(path("magic.nii"), {"magic"});

  s.magic = {'n', 'i', '1', '\0'};
  Bytes pair = buildN1(s);
  writeFile(path("pair.hdr"), pair.data);
  expectReadError(path("pair.hdr"), {"two-file"});  // its .img is not there

  const std::string text = "this is not a medical image, just some text that is long enough to be a header";
  writeFile(path("text.nii"), std::vector<unsigned char>(text.begin(), text.end()));
  expectReadError(path("text.nii"), {"not a NIfTI file"});
}

TEST_F(NiftiIo, BadDimensions) {
  for (auto dim : {std::array<std::int16_t, 8>{3, 4, 0, 2, 1, 1, 1, 1}, std::array<std::int16_t, 8>{3, 4, -3, 2, 1, 1, 1, 1},
                   std::array<std::int16_t, 8>{0, 4, 3, 2, 1, 1, 1, 1}, std::array<std::int16_t, 8>{9, 4, 3, 2, 1, 1, 1, 1}}) {
    N1Spec s;
    s.dim = dim;
    Bytes b = buildN1(s);
    b.append(std::vector<std::int16_t>(24, 1));
    writeFile(path("dims.nii"), b.data);
    expectReadError(path("dims.nii"), {"invalid"});
  }
}

// A 2D image (a single slice, as written by 2D tools): a volume one voxel thick. Its missing axis
// takes 1 mm where pixdim[3] is 0, and the direction completing a right-handed frame where the
// sform leaves that column at zero.
TEST_F(NiftiIo, TwoDimensionalIsOneSlice) {
  N1Spec two;
  two.dim = {2, 4, 6, 1, 1, 1, 1, 1};
  two.pixdim = {1, 0.5, 0.75, 0, 1, 1, 1, 1};
  std::vector<std::int16_t> values(24);
  for (int i = 0; i < 24; ++i) values[std::size_t(i)] = std::int16_t(i * 7 - 50);
  const Volume v = roundTripRaw(path("2d.nii"), two, values);
  EXPECT_EQ(v.dims(), Eigen::Vector3i(4, 6, 1));
  expectNear(v.geometry().spacing, Eigen::Vector3d(0.5, 0.75, 1.0), 1e-6, "spacing");
  for (int i = 0; i < 24; ++i) EXPECT_EQ(v.value(std::size_t(i)), values[std::size_t(i)]);
  // An sform whose third column is zero: axes x' = -y, y' = x (a turn about z), so z' = +z.
  two.sformCode = 1;
  two.srow = {0, 0.5, 0, 10, -0.75, 0, 0, 20, 0, 0, 0, 30};
  const Volume s = roundTripRaw(path("2d_sform.nii"), two, values);
  Eigen::Matrix3d expected;
  expected << 0, 1, 0, -1, 0, 0, 0, 0, 1;
  expectNear(s.geometry().direction, expected, 1e-6, "direction");
  expectNear(s.geometry().spacing, Eigen::Vector3d(0.75, 0.5, 1.0), 1e-6, "spacing");
  expectNear(s.geometry().origin, Eigen::Vector3d(10, 20, 30), 1e-6, "origin");
}

// A 4D image (fMRI, multi-phase CT, 4D label sets): one 3D volume at a time, chosen by frame, the
// count told; a frame past the last is refused with the count; a file missing its last volume is
// truncated.
TEST_F(NiftiIo, FourDimensionalImageIsReadOneVolumeAtATime) {
  N1Spec s;
  s.dim = {4, 4, 3, 2, 3, 1, 1, 1};
  std::vector<std::int16_t> values(72);
  for (int i = 0; i < 72; ++i) values[std::size_t(i)] = std::int16_t(1000 * (i / 24) + i % 24);
  Bytes b = buildN1(s);
  b.append(values);
  writeFile(path("4d.nii"), b.data);
  writeGzFile(path("4d.nii.gz"), b.data);
  for (const char* file : {"4d.nii", "4d.nii.gz"}) {
    SCOPED_TRACE(file);
    for (int f = 0; f < 3; ++f) {
      handson::NiftiInfo info;
      const Volume v = handson::readNifti(path(file), handson::NiftiReadOptions{f}, &info);
      EXPECT_EQ(info.frames, 3);
      EXPECT_EQ(info.rank, 4);
      ASSERT_EQ(v.dims(), Eigen::Vector3i(4, 3, 2));
      for (int i = 0; i < 24; ++i) EXPECT_EQ(v.value(std::size_t(i)), 1000 * f + i);
    }
    try {
      (void)handson::readNifti(path(file), handson::NiftiReadOptions{3});
      ADD_FAILURE() << "frame 3 of 3 accepted";
    } catch (const handson::Error& e) {
      EXPECT_NE(std::string(e.what()).find("holds 3 volumes"), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find("0 to 2"), std::string::npos) << e.what();
    }
  }
  // 5D (e.g. a vector per voxel over time): dims 4 to 7 multiply.
  s.dim = {5, 4, 3, 2, 1, 3, 1, 1};
  Bytes b5 = buildN1(s);
  b5.append(values);
  writeFile(path("5d.nii"), b5.data);
  handson::NiftiInfo info5;
  EXPECT_EQ(handson::readNifti(path("5d.nii"), handson::NiftiReadOptions{2}, &info5).value(0), 2000);
  EXPECT_EQ(info5.frames, 3);
  // The last volume cut short: truncated, whichever volume is asked for.
  s.dim = {4, 4, 3, 2, 3, 1, 1, 1};
  Bytes cut = buildN1(s);
  cut.append(std::vector<std::int16_t>(values.begin(), values.end() - 5));
  writeFile(path("4d_cut.nii"), cut.data);
  expectReadError(path("4d_cut.nii"), {"truncated"});

  s.dim = {4, 4, 3, 2, 1, 1, 1, 1};  // a 4D header holding one volume is an ordinary volume
  EXPECT_EQ(roundTripRaw(path("4d1.nii"), s, std::vector<std::int16_t>(24, 1)).dims(), Eigen::Vector3i(4, 3, 2));
}

// Two-file NIfTI (.hdr + .img; magic "ni1" / "ni2"), each file gzipped or not, upper or lower
// case, given by either file: the same volume as the single-file image of the same header.
TEST_F(NiftiIo, TwoFilePairsReadLikeSingleFiles) {
  std::vector<std::int16_t> values(24);
  for (int i = 0; i < 24; ++i) values[std::size_t(i)] = std::int16_t(3 * i - 11);
  N1Spec single;
  single.sformCode = 1;
  single.srow = {0.8, 0, 0, -5, 0, 0.9, 0, 6, 0, 0, 2.5, 7};
  const Volume expected = roundTripRaw(path("single.nii"), single, values);

  N1Spec pair = single;
  pair.magic = {'n', 'i', '1', '\0'};
  pair.voxOffset = 0;
  Bytes hdr = buildN1(pair);
  hdr.resize(348);
  Bytes img;
  img.append(values);
  struct Case { const char* hdr; const char* img; bool gzHdr, gzImg; const char* given; };
  for (const Case& c : {Case{"a.hdr", "a.img", false, false, "a.hdr"}, Case{"b.hdr", "b.img", false, false, "b.img"},
                        Case{"c.hdr.gz", "c.img.gz", true, true, "c.hdr.gz"}, Case{"d.hdr.gz", "d.img.gz", true, true, "d.img.gz"},
                        Case{"e.hdr", "e.img.gz", false, true, "e.hdr"}, Case{"F.HDR", "F.IMG", false, false, "F.HDR"}}) {
    SCOPED_TRACE(c.given);
    if (c.gzHdr) writeGzFile(path(c.hdr), hdr.data); else writeFile(path(c.hdr), hdr.data);
    if (c.gzImg) writeGzFile(path(c.img), img.data); else writeFile(path(c.img), img.data);
    handson::NiftiInfo info;
    const Volume v = handson::readNifti(path(c.given), {}, &info);
    EXPECT_TRUE(info.twoFile);
    EXPECT_EQ(info.dataPath, path(c.img));
    expectSameGeometry(v.geometry(), expected.geometry());
    EXPECT_EQ(allValues(v), allValues(expected));
  }
  // NIfTI-2 pairs too.
  N2Spec n2;
  n2.voxOffset = 0;
  Bytes h2 = buildN2(n2);
  h2.putRaw(4, "ni2\0\r\n\032\n", 8);
  h2.resize(540);
  Bytes i2;
  std::vector<std::int32_t> v32(24);
  for (int i = 0; i < 24; ++i) v32[std::size_t(i)] = 100 * i;
  i2.append(v32);
  writeFile(path("n2.hdr"), h2.data);
  writeFile(path("n2.img"), i2.data);
  const Volume v2 = handson::readNifti(path("n2.hdr"));
  EXPECT_EQ(v2.value(23), 2300.0f);
  // The image file missing, or too short.
  writeFile(path("lonely.hdr"), hdr.data);
  expectReadError(path("lonely.hdr"), {"image file"});
  writeFile(path("short.hdr"), hdr.data);
  writeFile(path("short.img"), std::vector<unsigned char>(img.data.begin(), img.data.end() - 4));
  try {
    (void)handson::readNifti(path("short.hdr"));
    ADD_FAILURE() << "short .img accepted";
  } catch (const handson::Error& e) {
    EXPECT_NE(std::string(e.what()).find("truncated"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("short.img"), std::string::npos) << e.what();
  }
}

TEST_F(NiftiIo, AbsurdDimensionsRefusedQuickly) {
  const auto start = std::chrono::steady_clock::now();
  N2Spec s;
  s.dim = {3, 100000, 100000, 100000, 1, 1, 1, 1};
  Bytes b = buildN2(s);
  b.append(std::vector<std::int32_t>(1000, 1));
  writeFile(path("huge2.nii"), b.data);
  expectReadError(path("huge2.nii"), {"larger than"});
  writeGzFile(path("huge2.nii.gz"), b.data);
  expectReadError(path("huge2.nii.gz"), {"larger than"});

  N1Spec s1;
  s1.dim = {3, 32767, 32767, 32767, 1, 1, 1, 1};
  writeFile(path("huge1.nii"), buildN1(s1).data);
  expectReadError(path("huge1.nii"), {"larger than"});

  // Within the voxel limit (2e9 voxels, 4 GB) but far more than the file holds: refused from the
  // file size, before any allocation.
  s1.dim = {3, 2000, 1000, 1000, 1, 1, 1, 1};
  Bytes small = buildN1(s1);
  small.append(std::vector<std::int16_t>(1000, 1));
  writeFile(path("big1.nii"), small.data);
  expectReadError(path("big1.nii"), {"truncated"});
  writeGzFile(path("big1.nii.gz"), small.data);
  expectReadError(path("big1.nii.gz"), {"truncated"});

  N2Spec s2;
  s2.dim = {3, std::int64_t{1} << 40, 1, 1, 1, 1, 1, 1};
  writeFile(path("wide.nii"), buildN2(s2).data);
  expectReadError(path("wide.nii"), {"too large", "larger than"});

  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  EXPECT_LT(seconds, 2.0);
}

TEST_F(NiftiIo, BadSpacingAndTransforms) {
  const float nan = std::numeric_limits<float>::quiet_NaN();
  {
    N1Spec s;  // pixdim-only geometry
    s.pixdim = {1, 1, nan, 1, 1, 1, 1, 1};
    Bytes b = buildN1(s);
    b.append(std::vector<std::int16_t>(24, 1));
    writeFile(path("nan.nii"), b.data);
    expectReadError(path("nan.nii"), {"voxel size"});
  }
  {
    N1Spec s;  // qform geometry
    s.qformCode = 1;
    s.pixdim = {1, 0, 1, 1, 1, 1, 1, 1};
    Bytes b = buildN1(s);
    b.append(std::vector<std::int16_t>(24, 1));
    writeFile(path("zero.nii"), b.data);
    expectReadError(path("zero.nii"), {"voxel size"});
  }
  {
    N1Spec s;
    s.qformCode = 1;
    s.quat = {nan, 0, 0};
    Bytes b = buildN1(s);
    b.append(std::vector<std::int16_t>(24, 1));
    writeFile(path("qnan.nii"), b.data);
    expectReadError(path("qnan.nii"), {"qform"});
  }
  for (auto srow : {std::array<float, 12>{}, std::array<float, 12>{1, 1, 0, 0, 1, 1, 0, 0, 0, 0, 0, 0},
                    std::array<float, 12>{1, 2, 3, 0, 2, 4, 6, 0, 1, 1, 1, 0},
                    std::array<float, 12>{1, 0, 0, nan, 0, 1, 0, 0, 0, 0, 1, 0}}) {
    N1Spec s;
    s.sformCode = 1;
    s.srow = srow;
    Bytes b = buildN1(s);
    b.append(std::vector<std::int16_t>(24, 1));
    writeFile(path("sform.nii"), b.data);
    expectReadError(path("sform.nii"), {"sform"});
  }
}

TEST_F(NiftiIo, UnsupportedDatatypes) {
  const std::pair<std::int16_t, const char*> cases[] = {{32, "complex64"}, {128, "RGB24"}, {2304, "RGBA32"}, {1, "binary"},
                                                        {1792, "complex128"}, {99, "unknown"}};
  for (const auto& [dt, name] : cases) {
    N1Spec s;
    s.datatype = dt;
    Bytes b = buildN1(s);
    b.append(std::vector<std::int32_t>(48, 1));
    writeFile(path("dt.nii"), b.data);
    expectReadError(path("dt.nii"), {name});
  }
}

TEST_F(NiftiIo, FailedWriteLeavesNothing) {
  const Volume v = makeVolume(ScalarType::Int16, obliqueGeometry());
  const std::string missing = path("no/such/dir/out.nii.gz");
  EXPECT_THROW(handson::writeNifti(v, missing), handson::Error);
  EXPECT_FALSE(fs::exists(missing));
  EXPECT_FALSE(fs::exists(path("no")));

  // The destination is a directory: the rename fails after the data were written.
  fs::create_directory(path("taken.nii"));
  EXPECT_THROW(handson::writeNifti(v, path("taken.nii")), handson::Error);
  EXPECT_EQ(listing(), std::vector<std::string>{"taken.nii"});

  EXPECT_THROW(handson::writeNifti(Volume(), path("empty.nii")), handson::Error);
  EXPECT_EQ(listing(), std::vector<std::string>{"taken.nii"});
}

// Random damage to the header: every outcome must be a Volume or a handson::Error, never a crash
// (run under the sanitizers to make this meaningful).
TEST_F(NiftiIo, RandomHeaderDamageNeverCrashes) {
  N1Spec s;
  s.qformCode = 1;
  s.sformCode = 1;
  s.quat = {0.1f, 0.2f, 0.3f};
  s.slope = 2;
  Bytes b = buildN1(s);
  b.append(std::vector<std::int16_t>(24, 9));
  std::mt19937 rng(42);
  int accepted = 0, refused = 0;
  for (int iter = 0; iter < 600; ++iter) {
    auto bytes = b.data;
    const int flips = 1 + int(rng() % 4);
    for (int f = 0; f < flips; ++f) bytes[rng() % 348] = static_cast<unsigned char>(rng());
    const bool gz = iter % 2 == 1;
    const std::string file = path(gz ? "fuzz.nii.gz" : "fuzz.nii");
    if (gz) writeGzFile(file, bytes);
    else writeFile(file, bytes);
    try {
      const Volume v = handson::readNifti(file);
      EXPECT_LE(v.byteSize(), 4 * bytes.size());
      ++accepted;
    } catch (const handson::Error&) {
      ++refused;
    }
  }
  EXPECT_GT(accepted, 0);
  EXPECT_GT(refused, 0);
}

// ---- real data ---------------------------------------------------------------------------------

TEST(NiftiIoRealData, Ircadb) {
  const std::string file = HANDSON_SHARED_DATA_DIR "/ircadb1.1/ct.nii.gz";
  if (!fs::exists(file)) GTEST_SKIP() << file << " not available";
  const Volume v = handson::readNifti(file);
  EXPECT_EQ(v.dims(), Eigen::Vector3i(512, 512, 129));
  EXPECT_EQ(v.type(), ScalarType::Int16);
  expectNear(v.geometry().spacing, Eigen::Vector3d(0.57, 0.57, 1.6), 1e-5, "spacing");
  const auto [lo, hi] = v.valueRange();
  EXPECT_GE(lo, -1024.0f);
  EXPECT_LE(hi, 3071.0f);
  EXPECT_LT(lo, hi);
}

TEST(NiftiIoRealData, TotalsegSmall) {
  const std::string file = HANDSON_SHARED_DATA_DIR "/totalseg-small/ct.nii.gz";
  if (!fs::exists(file)) GTEST_SKIP() << file << " not available";
  const Volume v = handson::readNifti(file);
  EXPECT_EQ(v.dims(), Eigen::Vector3i(122, 101, 30));
  EXPECT_EQ(v.type(), ScalarType::Int16);
  expectNear(v.geometry().spacing, Eigen::Vector3d(3, 3, 3), 1e-6, "spacing");
  expectNear(v.geometry().direction, Eigen::Matrix3d::Identity(), 1e-6, "direction");
  expectNear(v.geometry().origin, Eigen::Vector3d(-177.956, 11.319, 94.302), 1e-3, "origin");
  const auto [lo, hi] = v.valueRange();
  EXPECT_GE(lo, -2048.0f);
  EXPECT_LE(hi, 4095.0f);
  EXPECT_LT(lo, hi);
}

}  // namespace
