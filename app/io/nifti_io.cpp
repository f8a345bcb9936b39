#include "nifti_io.h"

#include <sys/stat.h>
#include <unistd.h>
#include <zlib.h>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <Eigen/LU>
#include <Eigen/SVD>
#include <algorithm>
#include <array>
#include <bit>
#include <cerrno>
#include <cctype>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <iomanip>
#include <memory>
#include <optional>
#include <new>
#include <sstream>
#include <type_traits>
#include <vector>

#include "sim/base/atomic_file.h"
#include "sim/base/error.h"

namespace handson {
namespace {

// ------------------------------------------------------------------------------------------------
// On-disk headers. Both are stored in the byte order of the machine that wrote them; the reader
// recognises a foreign order by a byte-swapped sizeof_hdr. Field offsets are in the comments.
// ------------------------------------------------------------------------------------------------
#pragma pack(push, 1)

// NIfTI-1: 348 bytes, then a 4-byte extension flag (and optional extensions); in a single .nii
// file the voxel data start at vox_offset (>= 352).
struct Nifti1Header {
  std::int32_t sizeof_hdr;              //   0  348
  char data_type[10];                   //   4  unused (Analyze 7.5 leftover)
  char db_name[18];                     //  14  unused
  std::int32_t extents;                 //  32  unused
  std::int16_t session_error;           //  36  unused
  char regular;                         //  38  unused ('r')
  char dim_info;                        //  39  frequency/phase/slice encoding directions
  std::int16_t dim[8];                  //  40  dim[0] = number of dimensions, dim[1..7] = sizes
  float intent_p1;                      //  56
  float intent_p2;                      //  60
  float intent_p3;                      //  64
  std::int16_t intent_code;             //  68
  std::int16_t datatype;                //  70  DT_* code below
  std::int16_t bitpix;                  //  72  bits per voxel
  std::int16_t slice_start;             //  74
  float pixdim[8];                      //  76  pixdim[0] = qfac (+-1), pixdim[1..3] = voxel size
  float vox_offset;                     // 108  byte offset of the voxel data
  float scl_slope;                      // 112  value = stored * slope + inter (slope 0: none)
  float scl_inter;                      // 116
  std::int16_t slice_end;               // 120
  char slice_code;                      // 122
  char xyzt_units;                      // 123  space units in bits 0-2 (2 = mm)
  float cal_max;                        // 124  display range
  float cal_min;                        // 128
  float slice_duration;                 // 132
  float toffset;                        // 136
  std::int32_t glmax;                   // 140  unused
  std::int32_t glmin;                   // 144  unused
  char descrip[80];                     // 148  free text
  char aux_file[24];                    // 228
  std::int16_t qform_code;              // 252  0 = no qform
  std::int16_t sform_code;              // 254  0 = no sform
  float quatern_b;                      // 256  qform rotation quaternion (a is implied)
  float quatern_c;                      // 260
  float quatern_d;                      // 264
  float qoffset_x;                      // 268  qform translation (mm)
  float qoffset_y;                      // 272
  float qoffset_z;                      // 276
  float srow_x[4];                      // 280  sform affine, rows 1..3
  float srow_y[4];                      // 296
  float srow_z[4];                      // 312
  char intent_name[16];                 // 328
  char magic[4];                        // 344  "n+1\0" (single file), "ni1\0" (.hdr/.img pair)
};
static_assert(sizeof(Nifti1Header) == 348);
static_assert(offsetof(Nifti1Header, dim) == 40);
static_assert(offsetof(Nifti1Header, pixdim) == 76);
static_assert(offsetof(Nifti1Header, qform_code) == 252);
static_assert(offsetof(Nifti1Header, srow_x) == 280);
static_assert(offsetof(Nifti1Header, magic) == 344);

// NIfTI-2: 540 bytes, then the same 4-byte extension flag; data at vox_offset (>= 544). Same
// meaning as NIfTI-1 with 64-bit sizes and doubles, reordered so the magic comes early.
struct Nifti2Header {
  std::int32_t sizeof_hdr;              //   0  540
  char magic[8];                        //   4  "n+2\0\r\n\032\n"
  std::int16_t datatype;                //  12
  std::int16_t bitpix;                  //  14
  std::int64_t dim[8];                  //  16
  double intent_p1;                     //  80
  double intent_p2;                     //  88
  double intent_p3;                     //  96
  double pixdim[8];                     // 104
  std::int64_t vox_offset;              // 168
  double scl_slope;                     // 176
  double scl_inter;                     // 184
  double cal_max;                       // 192
  double cal_min;                       // 200
  double slice_duration;                // 208
  double toffset;                       // 216
  std::int64_t slice_start;             // 224
  std::int64_t slice_end;               // 232
  char descrip[80];                     // 240
  char aux_file[24];                    // 320
  std::int32_t qform_code;              // 344
  std::int32_t sform_code;              // 348
  double quatern_b;                     // 352
  double quatern_c;                     // 360
  double quatern_d;                     // 368
  double qoffset_x;                     // 376
  double qoffset_y;                     // 384
  double qoffset_z;                     // 392
  double srow_x[4];                     // 400
  double srow_y[4];                     // 432
  double srow_z[4];                     // 464
  std::int32_t slice_code;              // 496
  std::int32_t xyzt_units;              // 500
  std::int32_t intent_code;             // 504
  char intent_name[16];                 // 508
  char dim_info;                        // 524
  char unused_str[15];                  // 525
};
static_assert(sizeof(Nifti2Header) == 540);
static_assert(offsetof(Nifti2Header, pixdim) == 104);
static_assert(offsetof(Nifti2Header, qform_code) == 344);
static_assert(offsetof(Nifti2Header, srow_x) == 400);
static_assert(offsetof(Nifti2Header, dim_info) == 524);

#pragma pack(pop)

constexpr std::size_t kNifti1DataStart = 352;  // header + 4-byte extension flag
constexpr std::size_t kNifti2DataStart = 544;

// NIfTI datatype codes.
enum : int {
  kDtBinary = 1,
  kDtUInt8 = 2,
  kDtInt16 = 4,
  kDtInt32 = 8,
  kDtFloat32 = 16,
  kDtComplex64 = 32,
  kDtFloat64 = 64,
  kDtRgb24 = 128,
  kDtInt8 = 256,
  kDtUInt16 = 512,
  kDtUInt32 = 768,
  kDtInt64 = 1024,
  kDtUInt64 = 1280,
  kDtFloat128 = 1536,
  kDtComplex128 = 1792,
  kDtComplex256 = 2048,
  kDtRgba32 = 2304,
};

constexpr int kXformScannerAnat = 1;
constexpr char kUnitsMm = 2;

// Bytes per voxel of a supported datatype, 0 if unsupported.
std::size_t datatypeSize(int dt) {
  switch (dt) {
    case kDtUInt8:
    case kDtInt8: return 1;
    case kDtInt16:
    case kDtUInt16: return 2;
    case kDtInt32:
    case kDtUInt32:
    case kDtFloat32: return 4;
    case kDtInt64:
    case kDtUInt64:
    case kDtFloat64: return 8;
    default: return 0;
  }
}

std::string unsupportedDatatypeName(int dt) {
  switch (dt) {
    case kDtBinary: return "1-bit binary";
    case kDtComplex64: return "complex64";
    case kDtComplex128: return "complex128";
    case kDtComplex256: return "complex256";
    case kDtRgb24: return "RGB24 colour";
    case kDtRgba32: return "RGBA32 colour";
    case kDtFloat128: return "float128";
    default: return "unknown datatype code " + std::to_string(dt);
  }
}

// ------------------------------------------------------------------------------------------------
// Byte order helpers.
// ------------------------------------------------------------------------------------------------
template <class T> T byteSwapped(T v) {
  static_assert(std::is_arithmetic_v<T>);
  if constexpr (sizeof(T) == 1) {
    return v;
  } else if constexpr (sizeof(T) == 2) {
    return std::bit_cast<T>(__builtin_bswap16(std::bit_cast<std::uint16_t>(v)));
  } else if constexpr (sizeof(T) == 4) {
    return std::bit_cast<T>(__builtin_bswap32(std::bit_cast<std::uint32_t>(v)));
  } else {
    static_assert(sizeof(T) == 8);
    return std::bit_cast<T>(__builtin_bswap64(std::bit_cast<std::uint64_t>(v)));
  }
}

template <class T> T loadValue(const std::byte* p, bool swap) {
  T v;
  std::memcpy(&v, p, sizeof(T));
  return swap ? byteSwapped(v) : v;
}

template <class U> void swapElements(std::byte* data, std::size_t count) {
  for (std::size_t i = 0; i < count; ++i) {
    U v;
    std::memcpy(&v, data + i * sizeof(U), sizeof(U));
    v = byteSwapped(v);
    std::memcpy(data + i * sizeof(U), &v, sizeof(U));
  }
}

void swapBuffer(std::byte* data, std::size_t count, std::size_t elementSize) {
  switch (elementSize) {
    case 2: swapElements<std::uint16_t>(data, count); break;
    case 4: swapElements<std::uint32_t>(data, count); break;
    case 8: swapElements<std::uint64_t>(data, count); break;
    default: break;
  }
}

std::string errnoText(int err) { return std::strerror(err); }

std::string formatNumber(double v) {
  std::ostringstream s;
  s << v;
  return s.str();
}

// ------------------------------------------------------------------------------------------------
// Input: a regular file read plainly or through zlib, in bounded chunks.
// ------------------------------------------------------------------------------------------------
[[noreturn]] void readFail(const std::string& path, const std::string& what) {
  throw Error("Cannot read NIfTI file '" + path + "': " + what);
}

constexpr std::size_t kChunk = std::size_t{16} << 20;

class InputFile {
 public:
  explicit InputFile(const std::string& path) : path_(path) {
    namespace fs = std::filesystem;
    if (path.empty()) readFail(path, "no file name given");
    std::error_code ec;
    const fs::file_status st = fs::status(path, ec);
    if (st.type() == fs::file_type::not_found) readFail(path, "file not found");
    if (ec) readFail(path, ec.message());
    if (st.type() == fs::file_type::directory) readFail(path, "is a directory, not a NIfTI file");
    if (st.type() != fs::file_type::regular) readFail(path, "not a regular file");
    fileSize_ = fs::file_size(path, ec);
    if (ec) readFail(path, ec.message());

    plain_ = std::fopen(path.c_str(), "rb");
    if (!plain_) readFail(path, errnoText(errno));
    unsigned char magic[2] = {0, 0};
    const std::size_t got = std::fread(magic, 1, 2, plain_);
    if (got == 2 && magic[0] == 0x1f && magic[1] == 0x8b) {
      std::fclose(plain_);
      plain_ = nullptr;
      gz_ = gzopen(path.c_str(), "rb");
      if (!gz_) readFail(path, errno ? errnoText(errno) : std::string("cannot open gzip stream"));
      gzbuffer(gz_, 1u << 17);
    } else if (std::fseek(plain_, 0, SEEK_SET) != 0) {
      readFail(path, errnoText(errno));
    }
  }
  ~InputFile() {
    if (plain_) std::fclose(plain_);
    if (gz_) gzclose(gz_);
  }
  InputFile(const InputFile&) = delete;
  InputFile& operator=(const InputFile&) = delete;

  bool compressed() const { return gz_ != nullptr; }
  std::uintmax_t fileSize() const { return fileSize_; }

  // Reads up to n bytes; fewer only at the end of the stream. Throws on I/O or gzip errors.
  std::size_t read(void* dst, std::size_t n) {
    auto* out = static_cast<unsigned char*>(dst);
    std::size_t done = 0;
    while (done < n) {
      const std::size_t want = std::min(n - done, kChunk);
      std::size_t got = 0;
      if (gz_) {
        const int r = gzread(gz_, out + done, static_cast<unsigned>(want));
        if (r < 0) readFail(path_, "corrupt gzip data (" + gzipError() + ")");
        got = static_cast<std::size_t>(r);
      } else {
        got = std::fread(out + done, 1, want, plain_);
        if (got < want && std::ferror(plain_)) readFail(path_, errnoText(errno));
      }
      done += got;
      if (got < want) break;
    }
    return done;
  }

  void readExact(void* dst, std::size_t n, const std::string& what) {
    const std::size_t got = read(dst, n);
    if (got < n) truncated(what, n, got);
  }

  void skip(std::size_t n, const std::string& what) {
    std::array<unsigned char, 1 << 16> scratch;
    std::size_t done = 0;
    while (done < n) {
      const std::size_t want = std::min(n - done, scratch.size());
      const std::size_t got = read(scratch.data(), want);
      done += got;
      if (got < want) truncated(what, n, done);
    }
  }

  // For gzip input: reads on to the end of the stream so zlib checks its CRC and length trailer
  // (damage in the data is otherwise invisible). Trailing bytes beyond the image are allowed; past
  // a bounded amount of them the check is given up rather than decompressing without limit.
  void checkEnd() {
    if (!gz_) return;
    constexpr std::size_t kMaxTrailing = std::size_t{8} << 20;
    std::array<unsigned char, 1 << 16> scratch;
    std::size_t drained = 0;
    while (drained < kMaxTrailing) {
      const int r = gzread(gz_, scratch.data(), static_cast<unsigned>(scratch.size()));
      if (r < 0) readFail(path_, "corrupt gzip data (" + gzipError() + ")");
      if (r == 0) {
        int errnum = Z_OK;
        gzerror(gz_, &errnum);
        if (errnum != Z_OK) readFail(path_, "corrupt or truncated gzip stream (" + gzipError() + ")");
        return;
      }
      drained += static_cast<std::size_t>(r);
    }
  }

 private:
  std::string gzipError() {
    int errnum = Z_OK;
    const char* msg = gzerror(gz_, &errnum);
    if (errnum == Z_ERRNO) return errnoText(errno);
    std::string text = msg && *msg ? msg : "unknown zlib error";
    const std::string prefix = path_ + ": ";  // zlib puts the path in front; the caller names it too
    if (text.rfind(prefix, 0) == 0) text.erase(0, prefix.size());
    return text;
  }

  [[noreturn]] void truncated(const std::string& what, std::size_t expected, std::size_t got) {
    std::ostringstream msg;
    if (fileSize_ == 0) {
      msg << "the file is empty";
    } else {
      msg << "file is truncated: expected " << expected << " bytes of " << what << ", got only " << got;
      if (gz_) {
        int errnum = Z_OK;
        gzerror(gz_, &errnum);
        if (errnum != Z_OK) msg << " (" << gzipError() << ")";
      }
    }
    readFail(path_, msg.str());
  }

  std::string path_;
  std::uintmax_t fileSize_ = 0;
  std::FILE* plain_ = nullptr;
  gzFile gz_ = nullptr;
};

// ------------------------------------------------------------------------------------------------
// Header decoding: both versions become one HeaderInfo in native order and double precision.
// ------------------------------------------------------------------------------------------------
struct HeaderInfo {
  int version = 1;
  std::int64_t dim[8] = {};
  int datatype = 0;
  double pixdim[8] = {};
  double voxOffset = 0;
  double slope = 0;
  double inter = 0;
  int qformCode = 0;
  int sformCode = 0;
  double quat[3] = {};
  double qoffset[3] = {};
  double srow[3][4] = {};
};

template <class H> HeaderInfo decodeHeader(const H& h, bool swap, int version) {
  auto get = [swap](auto v) { return swap ? byteSwapped(v) : v; };
  HeaderInfo info;
  info.version = version;
  for (int i = 0; i < 8; ++i) {
    info.dim[i] = static_cast<std::int64_t>(get(h.dim[i]));
    info.pixdim[i] = static_cast<double>(get(h.pixdim[i]));
  }
  info.datatype = get(h.datatype);
  info.voxOffset = static_cast<double>(get(h.vox_offset));
  info.slope = static_cast<double>(get(h.scl_slope));
  info.inter = static_cast<double>(get(h.scl_inter));
  info.qformCode = static_cast<int>(get(h.qform_code));
  info.sformCode = static_cast<int>(get(h.sform_code));
  info.quat[0] = static_cast<double>(get(h.quatern_b));
  info.quat[1] = static_cast<double>(get(h.quatern_c));
  info.quat[2] = static_cast<double>(get(h.quatern_d));
  info.qoffset[0] = static_cast<double>(get(h.qoffset_x));
  info.qoffset[1] = static_cast<double>(get(h.qoffset_y));
  info.qoffset[2] = static_cast<double>(get(h.qoffset_z));
  for (int c = 0; c < 4; ++c) {
    info.srow[0][c] = static_cast<double>(get(h.srow_x[c]));
    info.srow[1][c] = static_cast<double>(get(h.srow_y[c]));
    info.srow[2][c] = static_cast<double>(get(h.srow_z[c]));
  }
  return info;
}

// Rotation matrix of the unit quaternion (a, b, c, d) with a = sqrt(1 - b^2 - c^2 - d^2) >= 0.
Eigen::Matrix3d quaternionToMatrix(double b, double c, double d) {
  double a2 = 1.0 - (b * b + c * c + d * d);
  double a = 0.0;
  if (a2 < 1e-7) {  // 180-degree rotation (or slightly denormalised): renormalise (b, c, d)
    const double norm = std::sqrt(b * b + c * c + d * d);
    b /= norm;
    c /= norm;
    d /= norm;
  } else {
    a = std::sqrt(a2);
  }
  Eigen::Matrix3d r;
  r << a * a + b * b - c * c - d * d, 2 * (b * c - a * d), 2 * (b * d + a * c),  //
      2 * (b * c + a * d), a * a + c * c - b * b - d * d, 2 * (c * d - a * b),   //
      2 * (b * d - a * c), 2 * (c * d + a * b), a * a + d * d - b * b - c * c;
  return r;
}

Eigen::Vector3d pixdimSpacing(const HeaderInfo& h, const std::string& path) {
  Eigen::Vector3d s(h.pixdim[1], h.pixdim[2], h.pixdim[3]);
  if (!s.allFinite() || (s.array() == 0.0).any()) {
    readFail(path, "invalid voxel size (pixdim " + formatNumber(s.x()) + ", " + formatNumber(s.y()) + ", " +
                       formatNumber(s.z()) + "): each must be finite and non-zero");
  }
  return s.cwiseAbs();
}

VolumeGeometry decodeGeometry(HeaderInfo h, const Eigen::Vector3i& dims, const std::string& path) {
  VolumeGeometry g;
  g.dims = dims;
  // A 1D or 2D image: its missing axes are one voxel thick; writers leave their pixdim at 0 or 1 and
  // their sform column at zero, so a missing axis takes 1 mm and the direction completing a
  // right-handed frame.
  const int rank = int(std::clamp<std::int64_t>(h.dim[0], 1, 3));
  for (int i = rank + 1; i <= 3; ++i)
    if (!std::isfinite(h.pixdim[i]) || h.pixdim[i] == 0.0) h.pixdim[i] = 1.0;
  if (h.sformCode > 0) {
    Eigen::Matrix3d a;
    Eigen::Vector3d t;
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 3; ++c) a(r, c) = h.srow[r][c];
      t[r] = h.srow[r][3];
    }
    if (!a.allFinite() || !t.allFinite()) readFail(path, "the sform matrix contains non-finite values");
    for (int c = rank; c < 3; ++c) {
      if (a.col(c).norm() > 0.0) continue;
      const Eigen::Vector3d e[3] = {Eigen::Vector3d::UnitX(), Eigen::Vector3d::UnitY(), Eigen::Vector3d::UnitZ()};
      const Eigen::Vector3d u = a.col((c + 1) % 3).norm() > 0.0 ? Eigen::Vector3d(a.col((c + 1) % 3)) : e[(c + 1) % 3];
      const Eigen::Vector3d v = a.col((c + 2) % 3).norm() > 0.0 ? Eigen::Vector3d(a.col((c + 2) % 3)) : e[(c + 2) % 3];
      const Eigen::Vector3d n = u.cross(v);
      a.col(c) = n.norm() > 0.0 ? Eigen::Vector3d(n.normalized() * std::abs(h.pixdim[c + 1])) : e[c];
    }
    for (int c = 0; c < 3; ++c) {
      const double norm = a.col(c).norm();
      if (!(norm > 0.0)) readFail(path, "the sform matrix is singular (column " + std::to_string(c + 1) + " is zero)");
      g.spacing[c] = norm;
      g.direction.col(c) = a.col(c) / norm;
    }
    if (!(std::abs(g.direction.determinant()) >= 1e-6)) readFail(path, "the sform matrix is singular");
    g.origin = t;
  } else if (h.qformCode > 0) {
    const Eigen::Vector3d q(h.quat[0], h.quat[1], h.quat[2]);
    const Eigen::Vector3d offset(h.qoffset[0], h.qoffset[1], h.qoffset[2]);
    if (!q.allFinite() || !offset.allFinite()) readFail(path, "the qform contains non-finite values");
    g.direction = quaternionToMatrix(q.x(), q.y(), q.z());
    if (h.pixdim[0] < 0.0) g.direction.col(2) *= -1.0;  // qfac = -1: left-handed grid
    g.spacing = pixdimSpacing(h, path);
    g.origin = offset;
  } else {
    g.spacing = pixdimSpacing(h, path);
  }
  try {
    g.validate();
  } catch (const Error& e) {
    readFail(path, e.what());
  }
  return g;
}

struct Scaling {
  bool apply = false;
  double slope = 1.0;
  double inter = 0.0;
};

bool isInteger(double v) { return std::isfinite(v) && v == std::floor(v); }

float toFloat(double v) {
  constexpr double kMax = std::numeric_limits<float>::max();
  if (v > kMax) return std::numeric_limits<float>::infinity();
  if (v < -kMax) return -std::numeric_limits<float>::infinity();
  return static_cast<float>(v);
}

// Converts raw voxels of file type T into an Int16 volume if every (scaled) value is an integer in
// int16 range, else a Float32 volume.
template <class T>
Volume convertValues(const std::byte* raw, const VolumeGeometry& g, bool swap, const Scaling& s) {
  const std::size_t n = g.voxelCount();
  auto valueAt = [&](std::size_t i) {
    const double v = static_cast<double>(loadValue<T>(raw + i * sizeof(T), swap));
    return s.apply ? v * s.slope + s.inter : v;
  };
  bool toInt16 = false;
  if constexpr (std::is_integral_v<T>) {
    if (!s.apply || (isInteger(s.slope) && isInteger(s.inter))) {
      toInt16 = true;
      for (std::size_t i = 0; i < n; ++i) {
        const double v = valueAt(i);
        if (!(v >= -32768.0 && v <= 32767.0)) {
          toInt16 = false;
          break;
        }
      }
    }
  }
  if (toInt16) {
    Volume out(g, ScalarType::Int16);
    std::int16_t* d = out.data<std::int16_t>();
    for (std::size_t i = 0; i < n; ++i) d[i] = static_cast<std::int16_t>(valueAt(i));
    return out;
  }
  Volume out(g, ScalarType::Float32);
  float* d = out.data<float>();
  for (std::size_t i = 0; i < n; ++i) d[i] = toFloat(valueAt(i));
  return out;
}

Volume convertRaw(int dt, const std::byte* raw, const VolumeGeometry& g, bool swap, const Scaling& s) {
  switch (dt) {
    case kDtUInt8: return convertValues<std::uint8_t>(raw, g, swap, s);
    case kDtInt8: return convertValues<std::int8_t>(raw, g, swap, s);
    case kDtInt16: return convertValues<std::int16_t>(raw, g, swap, s);
    case kDtUInt16: return convertValues<std::uint16_t>(raw, g, swap, s);
    case kDtInt32: return convertValues<std::int32_t>(raw, g, swap, s);
    case kDtUInt32: return convertValues<std::uint32_t>(raw, g, swap, s);
    case kDtInt64: return convertValues<std::int64_t>(raw, g, swap, s);
    case kDtUInt64: return convertValues<std::uint64_t>(raw, g, swap, s);
    case kDtFloat32: return convertValues<float>(raw, g, swap, s);
    case kDtFloat64: return convertValues<double>(raw, g, swap, s);
    default: throw Error("unsupported datatype");  // unreachable: checked by the caller
  }
}

// Reads header bytes [4, size) into `header` (the first 4, sizeof_hdr, are already there).
void readRestOfHeader(InputFile& in, const std::string& path, unsigned char* header, std::size_t size,
                      const char* version) {
  const std::size_t got = in.read(header + 4, size - 4);
  if (got < size - 4) {
    readFail(path, std::string("file is truncated: a ") + version + " header needs " + std::to_string(size) +
                       " bytes, the file has only " + std::to_string(got + 4));
  }
}

// A file name's extension, lower case, with ".gz" kept: "a.HDR.gz" -> ".hdr.gz".
std::string niftiExtension(const std::string& path) {
  std::string name = std::filesystem::path(path).filename().string();
  std::transform(name.begin(), name.end(), name.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  const bool gz = name.size() > 3 && name.compare(name.size() - 3, 3, ".gz") == 0;
  if (gz) name.resize(name.size() - 3);
  const std::size_t dot = name.rfind('.');
  return (dot == std::string::npos ? std::string() : name.substr(dot)) + (gz ? ".gz" : "");
}

// The other file of a two-file pair (.hdr <-> .img, each gzipped or not, either case): the first of
// the candidates that exists, or "" when none does.
std::string companionFile(const std::string& path, const char* fromExt, const char* toExt) {
  const std::string ext = niftiExtension(path);
  const bool gz = ext.size() > 3 && ext.compare(ext.size() - 3, 3, ".gz") == 0;
  if (ext.substr(0, 4) != fromExt) return {};
  const std::size_t cut = path.size() - ext.size();
  const std::string stem = path.substr(0, cut);
  const bool upper = std::isupper(static_cast<unsigned char>(path[cut + 1])) != 0;
  std::string to = toExt;
  if (upper) std::transform(to.begin(), to.end(), to.begin(), [](unsigned char c) { return char(std::toupper(c)); });
  const std::string gzTail = path.substr(path.size() - (gz ? 3 : 0));
  std::error_code ec;
  for (const std::string& candidate : {stem + to + gzTail, stem + to, stem + to + ".gz"})
    if (std::filesystem::is_regular_file(candidate, ec)) return candidate;
  return {};
}

// The header's dimensions checked (1 to 7, each >= 1, the 3D part within int), the missing axes of
// a 1D or 2D image set to 1, and the volume `frame` of dims 4 to 7 checked against their count,
// which is returned. Fails naming the file.
std::int64_t checkDimensions(HeaderInfo& h, std::int64_t frame, const std::string& path) {
  const std::int64_t rank = h.dim[0];
  if (rank < 1 || rank > 7) readFail(path, "invalid number of dimensions dim[0] = " + std::to_string(rank));
  for (int i = 1; i <= rank; ++i) {
    if (h.dim[i] <= 0)
      readFail(path, "invalid image size: dim[" + std::to_string(i) + "] = " + std::to_string(h.dim[i]) +
                         " (each must be >= 1)");
  }
  for (std::int64_t i = rank + 1; i <= 3; ++i) h.dim[i] = 1;
  double framesD = 1.0;
  for (int i = 4; i <= rank; ++i) framesD *= static_cast<double>(h.dim[i]);
  if (framesD > 1e12) readFail(path, "absurd number of volumes (" + formatNumber(framesD) + ")");
  const std::int64_t frames = static_cast<std::int64_t>(framesD);
  if (frame < 0 || frame >= frames) {
    std::ostringstream msg;
    msg << "volume " << frame << " was asked for, but the image holds " << frames << " volume" << (frames == 1 ? "" : "s");
    if (frames > 1) msg << " (" << rank << "D, size";
    if (frames > 1) for (int i = 1; i <= rank; ++i) msg << (i == 1 ? " " : "x") << h.dim[i];
    msg << (frames > 1 ? "; --frame takes 0 to " + std::to_string(frames - 1) + ")" : std::string());
    readFail(path, msg.str());
  }
  for (int i = 1; i <= 3; ++i) {
    if (h.dim[i] > std::numeric_limits<int>::max())
      readFail(path, "image size dim[" + std::to_string(i) + "] = " + std::to_string(h.dim[i]) + " is too large");
  }
  return frames;
}

// The header as read: its fields, the byte order, and where its data may start.
struct ParsedHeader {
  HeaderInfo h;
  bool swap = false;     ///< the file's byte order is the other one
  bool twoFile = false;  ///< a .hdr/.img pair: the data are in the .img
  std::size_t headerBytes = 0, minDataStart = 0;
};

// sizeof_hdr tells the version and the byte order; then the rest of the NIfTI-1 or -2 header.
ParsedHeader readHeader(InputFile& in, const std::string& path) {
  std::int32_t sizeofHdr = 0;
  in.readExact(&sizeofHdr, sizeof sizeofHdr, "NIfTI header");
  ParsedHeader p;
  if (sizeofHdr == 348 || byteSwapped(sizeofHdr) == 348) {
    p.swap = sizeofHdr != 348;
    Nifti1Header raw;
    std::memcpy(&raw, &sizeofHdr, sizeof sizeofHdr);
    readRestOfHeader(in, path, reinterpret_cast<unsigned char*>(&raw), sizeof raw, "NIfTI-1");
    p.twoFile = std::memcmp(raw.magic, "ni1\0", 4) == 0;
    if (!p.twoFile && std::memcmp(raw.magic, "n+1\0", 4) != 0)
      readFail(path, "not a NIfTI-1 file (bad magic; Analyze 7.5 headers are not supported)");
    p.h = decodeHeader(raw, p.swap, 1);
    p.headerBytes = sizeof raw;
    p.minDataStart = kNifti1DataStart;
  } else if (sizeofHdr == 540 || byteSwapped(sizeofHdr) == 540) {
    p.swap = sizeofHdr != 540;
    Nifti2Header raw;
    std::memcpy(&raw, &sizeofHdr, sizeof sizeofHdr);
    readRestOfHeader(in, path, reinterpret_cast<unsigned char*>(&raw), sizeof raw, "NIfTI-2");
    p.twoFile = std::memcmp(raw.magic, "ni2\0\r\n\032\n", 8) == 0;
    if (!p.twoFile && std::memcmp(raw.magic, "n+2\0\r\n\032\n", 8) != 0) readFail(path, "not a NIfTI-2 file (bad magic)");
    p.h = decodeHeader(raw, p.swap, 2);
    p.headerBytes = sizeof raw;
    p.minDataStart = kNifti2DataStart;
  } else {
    readFail(path, "not a NIfTI file (header size field is " + std::to_string(sizeofHdr) + ", expected 348 or 540)");
  }
  return p;
}

// Where the image data lie: every volume's bytes from `start` to `end`, the chosen one's from frameStart.
struct DataRange {
  std::size_t start = 0, bytes = 0, frameStart = 0;  ///< bytes: one volume's
  double end = 0.0;                                   ///< (double: a header's sizes may overflow)
};

DataRange dataRange(const ParsedHeader& p, std::size_t volumeBytes, std::int64_t frames, std::int64_t frame, const std::string& path) {
  const HeaderInfo& h = p.h;
  if (!std::isfinite(h.voxOffset) || h.voxOffset < 0.0 || h.voxOffset > 1e15)
    readFail(path, "invalid data offset vox_offset = " + formatNumber(h.voxOffset));
  DataRange r;
  r.start = p.twoFile ? static_cast<std::size_t>(h.voxOffset) : std::max(static_cast<std::size_t>(h.voxOffset), p.minDataStart);
  r.bytes = volumeBytes;
  r.end = static_cast<double>(r.start) + static_cast<double>(frames) * static_cast<double>(volumeBytes);
  r.frameStart = r.start + static_cast<std::size_t>(frame) * volumeBytes;
  return r;
}

// Every volume must be in the file (the chosen one is read); deflate cannot expand data by more
// than about 1032:1, which bounds what a .gz can hold.
void checkFileHoldsData(const InputFile& data, const DataRange& r, bool twoFile, const std::string& dataPath) {
  if (!data.compressed() && static_cast<double>(data.fileSize()) < r.end) {
    std::ostringstream msg;
    msg << "file is truncated: the header describes " << std::setprecision(15) << r.end - double(r.start) << " bytes of image data ending at byte "
        << r.end << ", but " << (twoFile ? "the image file" : "the file") << " has only " << data.fileSize() << " bytes";
    readFail(dataPath, msg.str());
  }
  if (data.compressed() && r.end > static_cast<double>(data.fileSize()) * 1040.0 + 65536.0) {
    std::ostringstream msg;
    msg << "file is truncated: the header describes " << std::setprecision(15) << r.end - double(r.start)
        << " bytes of image data, more than the " << data.fileSize() << "-byte compressed file can contain";
    readFail(dataPath, msg.str());
  }
}

Scaling scalingOf(const HeaderInfo& h) {
  Scaling scaling;
  if (std::isfinite(h.slope) && h.slope != 0.0) {
    scaling.slope = h.slope;
    scaling.inter = std::isfinite(h.inter) ? h.inter : 0.0;
    scaling.apply = !(scaling.slope == 1.0 && scaling.inter == 0.0);
  }
  return scaling;
}

// How one volume's voxels are read and turned into a Volume.
struct VoxelRead {
  const ParsedHeader& header;
  const VolumeGeometry& geometry;
  Scaling scaling;
  bool checkEnd = false;  ///< gzip: its trailer checked after them (the last volume)
};

// Types Volume stores as-is are read straight into the volume; the rest go through a raw buffer.
Volume readVoxels(InputFile& data, const VoxelRead& v, const std::string& path) {
  const HeaderInfo& h = v.header.h;
  const std::size_t n = v.geometry.voxelCount(), elementSize = datatypeSize(h.datatype), dataBytes = n * elementSize;
  const bool direct = (h.datatype == kDtUInt8 && !v.scaling.apply) || (h.datatype == kDtInt16 && !v.scaling.apply) || h.datatype == kDtFloat32;
  try {
    checkAllocation(n, direct ? dataBytes : dataBytes + n * sizeof(float), "image data");
  } catch (const Error& e) {
    readFail(path, e.what());
  }
  if (!direct) {
    auto raw = std::make_unique_for_overwrite<std::byte[]>(dataBytes);
    data.readExact(raw.get(), dataBytes, "image data");
    if (v.checkEnd) data.checkEnd();
    return convertRaw(h.datatype, raw.get(), v.geometry, v.header.swap, v.scaling);
  }
  const ScalarType type = h.datatype == kDtUInt8 ? ScalarType::UInt8 : h.datatype == kDtInt16 ? ScalarType::Int16 : ScalarType::Float32;
  Volume volume(v.geometry, type);
  data.readExact(volume.bytes(), dataBytes, "image data");
  if (v.checkEnd) data.checkEnd();
  if (v.header.swap && elementSize > 1) swapBuffer(volume.bytes(), n, elementSize);
  if (v.scaling.apply) {  // float32 only
    float* d = volume.data<float>();
    for (std::size_t i = 0; i < n; ++i) d[i] = toFloat(double(d[i]) * v.scaling.slope + v.scaling.inter);
  }
  return volume;
}

Volume readNiftiImpl(const std::string& givenPath, const NiftiReadOptions& options, NiftiInfo* info) {
  // An .img (or .img.gz) given for a two-file pair: the header is its .hdr.
  std::string path = givenPath;
  if (const std::string hdr = companionFile(givenPath, ".img", ".hdr"); !hdr.empty()) path = hdr;
  InputFile in(path);
  ParsedHeader p = readHeader(in, path);
  HeaderInfo& h = p.h;  // checkDimensions completes its dims

  // --- dimensions: one 3D volume (1D and 2D images are one voxel thick); dims 4 to 7 count volumes.
  const std::int64_t frames = checkDimensions(h, options.frame, path);
  const Eigen::Vector3i dims(static_cast<int>(h.dim[1]), static_cast<int>(h.dim[2]), static_cast<int>(h.dim[3]));
  const std::size_t elementSize = datatypeSize(h.datatype);
  if (elementSize == 0)
    readFail(path, "unsupported voxel type (" + unsupportedDatatypeName(h.datatype) + "); only scalar integer and floating-point images are supported");
  // --- geometry (validates dims, voxel count, spacing and direction before any allocation).
  const VolumeGeometry geometry = decodeGeometry(h, dims, path);

  // --- where the data are, and whether the file can hold them. A two-file pair keeps them in the
  // .img beside the .hdr, from vox_offset (usually 0).
  std::optional<InputFile> imgFile;
  std::string dataPath = path;
  if (p.twoFile) {
    dataPath = companionFile(path, ".hdr", ".img");
    if (dataPath.empty())
      readFail(path, "is the header of a two-file NIfTI pair, but its image file (" + std::filesystem::path(path).stem().string() +
                         ".img or .img.gz) is not beside it");
    imgFile.emplace(dataPath);
  }
  InputFile& data = p.twoFile ? *imgFile : in;
  const DataRange range = dataRange(p, geometry.voxelCount() * elementSize, frames, options.frame, path);  // voxels <= kMaxVoxels after validate()
  checkFileHoldsData(data, range, p.twoFile, dataPath);
  if (info) {
    info->frames = frames;
    info->rank = int(h.dim[0]);
    info->twoFile = p.twoFile;
    info->dataPath = dataPath;
  }
  data.skip(range.frameStart - (p.twoFile ? 0 : p.headerBytes), options.frame > 0 ? "the volumes before the one asked for" : "header extensions");
  return readVoxels(data, {p, geometry, scalingOf(h), options.frame == frames - 1}, path);
}

// ------------------------------------------------------------------------------------------------
// Output: a temporary file in the destination directory, renamed into place on success.
// ------------------------------------------------------------------------------------------------
[[noreturn]] void writeFail(const std::string& path, const std::string& what) {
  throw Error("Cannot write NIfTI file '" + path + "': " + what);
}

// The file itself is sim/base/atomic_file's; this adds the gzip stream (on a dup of its descriptor).
class AtomicOutput {
 public:
  AtomicOutput(const std::string& path, bool gzip) : file_(path, "NIfTI file") {
    if (!gzip) return;
    const int gzfd = dup(file_.fd());
    if (gzfd < 0) file_.fail(errnoText(errno));
    gz_ = gzdopen(gzfd, "wb6");
    if (!gz_) {
      close(gzfd);
      file_.fail("cannot start gzip compression");
    }
    gzbuffer(gz_, 1u << 17);
  }
  ~AtomicOutput() {
    if (gz_) gzclose(gz_);
  }
  AtomicOutput(const AtomicOutput&) = delete;
  AtomicOutput& operator=(const AtomicOutput&) = delete;

  void write(const void* data, std::size_t n) {
    if (!gz_) return file_.write(data, n);
    const auto* p = static_cast<const unsigned char*>(data);
    for (std::size_t done = 0; done < n;) {
      const int r = gzwrite(gz_, p + done, static_cast<unsigned>(std::min(n - done, kChunk)));
      if (r <= 0) {
        int errnum = Z_OK;
        const char* msg = gzerror(gz_, &errnum);
        file_.fail(errnum == Z_ERRNO ? errnoText(errno) : std::string(msg ? msg : "gzip error"));
      }
      done += static_cast<std::size_t>(r);
    }
  }

  void commit() {
    if (gz_) {
      const int r = gzclose(gz_);
      gz_ = nullptr;
      if (r != Z_OK) file_.fail(r == Z_ERRNO ? errnoText(errno) : "gzip compression failed");
    }
    file_.commit();
  }

 private:
  AtomicFile file_;
  gzFile gz_ = nullptr;
};

bool endsWithGz(const std::string& path) {
  if (path.size() < 3) return false;
  const std::string tail = path.substr(path.size() - 3);
  return tail[0] == '.' && (tail[1] == 'g' || tail[1] == 'G') && (tail[2] == 'z' || tail[2] == 'Z');
}

}  // namespace

Volume readNifti(const std::string& path, const NiftiReadOptions& options, NiftiInfo* info) {
  try {
    return readNiftiImpl(path, options, info);
  } catch (const std::bad_alloc&) {
    readFail(path, "not enough memory to load the image");
  }
}

void writeNifti(const Volume& volume, const std::string& path) {
  if (path.empty()) writeFail(path, "no file name given");
  if (volume.empty()) writeFail(path, "the volume is empty");
  const VolumeGeometry& g = volume.geometry();
  try {
    g.validate();
  } catch (const Error& e) {
    writeFail(path, e.what());
  }
  const std::size_t n = volume.voxelCount();
  if (volume.byteSize() != n * scalarTypeSize(volume.type())) writeFail(path, "the volume's storage does not match its size");
  if ((g.dims.array() > 32767).any())
    writeFail(path, "dimensions " + std::to_string(g.dims.x()) + "x" + std::to_string(g.dims.y()) + "x" +
                        std::to_string(g.dims.z()) + " exceed the NIfTI-1 limit of 32767 per axis");

  Nifti1Header h;
  std::memset(&h, 0, sizeof h);
  h.sizeof_hdr = 348;
  h.regular = 'r';
  h.dim[0] = 3;
  for (int i = 0; i < 3; ++i) h.dim[i + 1] = static_cast<std::int16_t>(g.dims[i]);
  for (int i = 4; i < 8; ++i) h.dim[i] = 1;
  switch (volume.type()) {
    case ScalarType::UInt8: h.datatype = kDtUInt8; h.bitpix = 8; break;
    case ScalarType::Int16: h.datatype = kDtInt16; h.bitpix = 16; break;
    case ScalarType::Float32: h.datatype = kDtFloat32; h.bitpix = 32; break;
  }
  h.vox_offset = static_cast<float>(kNifti1DataStart);
  h.scl_slope = 1.0f;
  h.scl_inter = 0.0f;
  h.xyzt_units = kUnitsMm;
  std::snprintf(h.descrip, sizeof h.descrip, "Handson");
  std::memcpy(h.magic, "n+1\0", 4);

  // sform: the full affine.
  const Eigen::Matrix4d affine = g.indexToWorld();
  for (int c = 0; c < 4; ++c) {
    h.srow_x[c] = static_cast<float>(affine(0, c));
    h.srow_y[c] = static_cast<float>(affine(1, c));
    h.srow_z[c] = static_cast<float>(affine(2, c));
  }
  h.sform_code = kXformScannerAnat;

  // qform: rotation quaternion + qfac, only representable for an orthonormal direction.
  h.pixdim[0] = 1.0f;
  for (int i = 0; i < 3; ++i) h.pixdim[i + 1] = static_cast<float>(g.spacing[i]);
  for (int i = 4; i < 8; ++i) h.pixdim[i] = 1.0f;
  const Eigen::Matrix3d& d = g.direction;
  if ((d.transpose() * d - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff() < 1e-4) {
    Eigen::Matrix3d r = d;
    const double qfac = r.determinant() < 0.0 ? -1.0 : 1.0;
    r.col(2) *= qfac;  // now a proper rotation
    Eigen::JacobiSVD<Eigen::Matrix3d> svd(r, Eigen::ComputeFullU | Eigen::ComputeFullV);
    r = svd.matrixU() * svd.matrixV().transpose();  // nearest rotation, removes rounding noise
    Eigen::Quaterniond q(r);
    q.normalize();
    if (q.w() < 0.0) q.coeffs() *= -1.0;  // NIfTI stores b, c, d with a >= 0
    h.quatern_b = static_cast<float>(q.x());
    h.quatern_c = static_cast<float>(q.y());
    h.quatern_d = static_cast<float>(q.z());
    h.qoffset_x = static_cast<float>(g.origin.x());
    h.qoffset_y = static_cast<float>(g.origin.y());
    h.qoffset_z = static_cast<float>(g.origin.z());
    h.pixdim[0] = static_cast<float>(qfac);
    h.qform_code = kXformScannerAnat;
  }

  try {
    AtomicOutput out(path, endsWithGz(path));
    out.write(&h, sizeof h);
    const unsigned char extension[4] = {0, 0, 0, 0};  // no header extensions
    out.write(extension, sizeof extension);
    out.write(volume.bytes(), volume.byteSize());
    out.commit();
  } catch (const std::bad_alloc&) {
    writeFail(path, "not enough memory");
  }
}

}  // namespace handson
