#include "app/io/dicom_io.h"

#include <gdcmDataSet.h>
#include <gdcmDirectory.h>
#include <gdcmImage.h>
#include <gdcmImageReader.h>
#include <gdcmPhotometricInterpretation.h>
#include <gdcmPixelFormat.h>
#include <gdcmScanner.h>
#include <gdcmTag.h>
#include <gdcmTrace.h>
#include <gdcmTransferSyntax.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <optional>
#include <set>
#include <sstream>
#include <system_error>
#include <type_traits>

#include <csignal>
#include <cerrno>
#include <unistd.h>

#include "sim/base/child_process.h"
#include "sim/base/binary_io.h"
#include "sim/base/error.h"

namespace handson {
namespace {

namespace fs = std::filesystem;

const gdcm::Tag kSeriesInstanceUid(0x0020, 0x000e);
const gdcm::Tag kSeriesDescription(0x0008, 0x103e);
const gdcm::Tag kSopInstanceUid(0x0008, 0x0018);
const gdcm::Tag kImagePosition(0x0020, 0x0032);
const gdcm::Tag kImageOrientation(0x0020, 0x0037);
const gdcm::Tag kRows(0x0028, 0x0010);
const gdcm::Tag kColumns(0x0028, 0x0011);
const gdcm::Tag kPixelSpacing(0x0028, 0x0030);
const gdcm::Tag kNumberOfFrames(0x0028, 0x0008);
const gdcm::Tag kSliceThickness(0x0018, 0x0050);
const gdcm::Tag kSpacingBetweenSlices(0x0018, 0x0088);
const gdcm::Tag kRescaleIntercept(0x0028, 0x1052);
const gdcm::Tag kRescaleSlope(0x0028, 0x1053);
const gdcm::Tag kPhotometric(0x0028, 0x0004);
const gdcm::Tag kSamplesPerPixel(0x0028, 0x0002);
const gdcm::Tag kBitsAllocated(0x0028, 0x0100);
const gdcm::Tag kBitsStored(0x0028, 0x0101);
const gdcm::Tag kHighBit(0x0028, 0x0102);
const gdcm::Tag kPixelRepresentation(0x0028, 0x0103);
const gdcm::Tag kRecognitionCode(0x0008, 0x0010);  // retired ACR-NEMA

std::string trim(const std::string& s) {
  const char* ws = " \t\r\n";
  const auto b = s.find_first_not_of(ws);
  if (b == std::string::npos) return {};
  const auto e = s.find_last_not_of(ws);
  std::string out = s.substr(b, e - b + 1);
  // UIDs are padded with NUL.
  while (!out.empty() && out.back() == '\0') out.pop_back();
  return out;
}

/// Parses a backslash-separated list of decimal strings (DS / IS). Returns nullopt if any part is
/// not a finite number.
std::optional<std::vector<double>> parseNumbers(const std::string& text) {
  std::vector<double> out;
  std::string t = trim(text);
  if (t.empty()) return std::nullopt;
  std::size_t start = 0;
  while (true) {
    const std::size_t end = t.find('\\', start);
    const std::string part = trim(t.substr(start, end == std::string::npos ? std::string::npos : end - start));
    if (part.empty()) return std::nullopt;
    char* stop = nullptr;
    const double v = std::strtod(part.c_str(), &stop);
    if (stop == part.c_str() || *stop != '\0' || !std::isfinite(v)) return std::nullopt;
    out.push_back(v);
    if (end == std::string::npos) break;
    start = end + 1;
  }
  return out;
}

std::string tagText(const gdcm::Scanner& scanner, const std::string& file, const gdcm::Tag& tag) {
  const char* v = scanner.GetValue(file.c_str(), tag);
  return v ? trim(v) : std::string();
}

std::string datasetText(const gdcm::DataSet& ds, const gdcm::Tag& tag) {
  if (!ds.FindDataElement(tag)) return {};
  const gdcm::DataElement& de = ds.GetDataElement(tag);
  const gdcm::ByteValue* bv = de.GetByteValue();
  if (!bv || bv->GetLength() == 0) return {};
  return trim(std::string(bv->GetPointer(), bv->GetLength()));
}

std::string fileName(const std::string& path) { return fs::path(path).filename().string(); }

std::string formatMm(double v) {
  std::ostringstream s;
  s.precision(4);
  s << v;
  return s.str();
}

/// LPS (DICOM patient) to RAS (NIfTI world): negate x and y.
Eigen::Vector3d lpsToRas(const Eigen::Vector3d& v) { return {0.0 - v.x(), 0.0 - v.y(), v.z()}; }

/// Header values of one DICOM image file, from the scanner.
struct SliceHeader {
  std::string path;
  std::string seriesUid;
  std::string sopUid;
  int rows = 0, columns = 0;
  int frames = 1;
  int pixelRepresentation = -1;                     // 0 unsigned, 1 signed, -1 not given
  int bitsStored = 0;                               // 0: not given
  std::optional<std::vector<double>> pixelSpacing;  // row spacing \ column spacing
  std::optional<std::vector<double>> orientation;   // row cosine, column cosine (LPS)
  std::optional<std::vector<double>> position;      // LPS mm
  double key = 0.0;                                 // position along the slice normal
};

/// Redirects GDCM's warning and error output into a buffer while alive, so that a broken file
/// gives one clear handson::Error instead of library noise on stderr. The warnings are also how
/// GDCM signals uncompressed pixel data cut short ("Incomplete Pixel Data").
class GdcmTraceCapture {
 public:
  GdcmTraceCapture()
      : oldWarning_(&gdcm::Trace::GetWarningStream()),
        oldError_(&gdcm::Trace::GetErrorStream()),
        warningFlag_(gdcm::Trace::GetWarningFlag()),
        errorFlag_(gdcm::Trace::GetErrorFlag()) {
    gdcm::Trace::SetWarningStream(buffer_);
    gdcm::Trace::SetErrorStream(buffer_);
    gdcm::Trace::SetWarning(true);
    gdcm::Trace::SetError(true);
  }
  ~GdcmTraceCapture() {
    gdcm::Trace::SetWarning(warningFlag_);
    gdcm::Trace::SetError(errorFlag_);
    gdcm::Trace::SetWarningStream(*oldWarning_);
    gdcm::Trace::SetErrorStream(*oldError_);
  }
  GdcmTraceCapture(const GdcmTraceCapture&) = delete;
  GdcmTraceCapture& operator=(const GdcmTraceCapture&) = delete;

  /// Everything GDCM wrote since the last call.
  std::string take() {
    std::string text = buffer_.str();
    buffer_.str({});
    buffer_.clear();
    return text;
  }

 private:
  std::ostringstream buffer_;
  std::ostream* oldWarning_;
  std::ostream* oldError_;
  bool warningFlag_, errorFlag_;
};

std::string transferSyntaxText(const gdcm::TransferSyntax& ts) {
  static const std::map<std::string, const char*> names = {
      {"1.2.840.10008.1.2", "Implicit VR Little Endian"},
      {"1.2.840.10008.1.2.1", "Explicit VR Little Endian"},
      {"1.2.840.10008.1.2.1.99", "Deflated Explicit VR Little Endian"},
      {"1.2.840.10008.1.2.2", "Explicit VR Big Endian"},
      {"1.2.840.10008.1.2.4.50", "JPEG Baseline (Process 1)"},
      {"1.2.840.10008.1.2.4.51", "JPEG Extended (Process 2 & 4)"},
      {"1.2.840.10008.1.2.4.57", "JPEG Lossless, Non-Hierarchical (Process 14)"},
      {"1.2.840.10008.1.2.4.70", "JPEG Lossless, First-Order Prediction (Process 14 [Selection Value 1])"},
      {"1.2.840.10008.1.2.4.80", "JPEG-LS Lossless"},
      {"1.2.840.10008.1.2.4.81", "JPEG-LS Near-Lossless"},
      {"1.2.840.10008.1.2.4.90", "JPEG 2000 Image Compression (Lossless Only)"},
      {"1.2.840.10008.1.2.4.91", "JPEG 2000 Image Compression"},
      {"1.2.840.10008.1.2.4.92", "JPEG 2000 Part 2 Multi-component Image Compression (Lossless Only)"},
      {"1.2.840.10008.1.2.4.93", "JPEG 2000 Part 2 Multi-component Image Compression"},
      {"1.2.840.10008.1.2.5", "RLE Lossless"},
  };
  const char* uid = gdcm::TransferSyntax::GetTSString(ts);
  std::string out = uid ? trim(uid) : std::string();
  if (out.empty()) return "unknown";
  if (const auto it = names.find(out); it != names.end()) out += std::string(" (") + it->second + ")";
  return out;
}

/// Converts one decoded slice to rescaled values. Returns false (leaving `out` partially written)
/// as soon as a value is not an integer in int16 range when `out` is int16.
template <class Raw, class Out>
bool convertSlice(const char* buffer, std::size_t count, double slope, double intercept, Out* out) {
  for (std::size_t n = 0; n < count; ++n) {
    Raw raw;
    std::memcpy(&raw, buffer + n * sizeof(Raw), sizeof(Raw));
    const double v = double(raw) * slope + intercept;
    if constexpr (std::is_same_v<Out, std::int16_t>) {
      if (!(v >= -32768.0 && v <= 32767.0) || v != std::nearbyint(v)) return false;
      out[n] = static_cast<std::int16_t>(v);
    } else {
      out[n] = static_cast<float>(v);
    }
  }
  return true;
}

// The header's PixelRepresentation is authoritative over what a codec decoded: a JPEG 2000 (or JPEG-LS)
// codestream may call signed stored values unsigned, or the other way round. Stored values are
// BitsStored-bit integers, two's complement when signed. A compressed slice whose decoded values
// (whichever type the codec reported) are all in [0, 2^bits) with some at or above 2^(bits-1), under a
// header that says signed, was decoded as unsigned: its values are sign-extended from BitsStored bits (-2000 HU read as 6192 is
// -2000 again). Negative decoded values under a header that says unsigned are taken modulo 2^bits.
// Values outside the BitsStored range (files whose BitsStored is too small) are left alone.
// Returns the type to read the rewritten buffer as; nullopt when codec and header agree.
template <class T>
constexpr gdcm::PixelFormat::ScalarType pixelTypeOf() {
  using PF = gdcm::PixelFormat;
  if constexpr (std::is_same_v<T, std::int8_t>) return PF::INT8;
  else if constexpr (std::is_same_v<T, std::uint8_t>) return PF::UINT8;
  else if constexpr (std::is_same_v<T, std::int16_t>) return PF::INT16;
  else if constexpr (std::is_same_v<T, std::uint16_t>) return PF::UINT16;
  else if constexpr (std::is_same_v<T, std::int32_t>) return PF::INT32;
  else return PF::UINT32;
}

template <class T, class Signed, class Unsigned>
std::optional<gdcm::PixelFormat::ScalarType> fixSignedness(char* buffer, std::size_t count, bool headerSigned, int bits) {
  bits = std::clamp(bits, 2, int(8 * sizeof(T)));
  std::int64_t lo = std::numeric_limits<std::int64_t>::max(), hi = std::numeric_limits<std::int64_t>::min();
  for (std::size_t n = 0; n < count; ++n) {
    T raw;
    std::memcpy(&raw, buffer + n * sizeof(T), sizeof(T));
    lo = std::min<std::int64_t>(lo, std::int64_t(raw));
    hi = std::max<std::int64_t>(hi, std::int64_t(raw));
  }
  const std::int64_t span = std::int64_t(1) << bits, half = span / 2;
  if (headerSigned && lo >= 0 && hi < span && hi >= half) {
    for (std::size_t n = 0; n < count; ++n) {
      T raw;
      std::memcpy(&raw, buffer + n * sizeof(T), sizeof(T));
      const Signed v = Signed(std::int64_t(raw) >= half ? std::int64_t(raw) - span : std::int64_t(raw));
      std::memcpy(buffer + n * sizeof(T), &v, sizeof(T));
    }
    return pixelTypeOf<Signed>();
  }
  if (!headerSigned && lo < 0 && lo >= -half && hi < half) {
    for (std::size_t n = 0; n < count; ++n) {
      T raw;
      std::memcpy(&raw, buffer + n * sizeof(T), sizeof(T));
      const Unsigned v = Unsigned(std::int64_t(raw) < 0 ? std::int64_t(raw) + span : std::int64_t(raw));
      std::memcpy(buffer + n * sizeof(T), &v, sizeof(T));
    }
    return pixelTypeOf<Unsigned>();
  }
  return std::nullopt;
}

gdcm::PixelFormat::ScalarType applyHeaderSignedness(gdcm::PixelFormat::ScalarType type, char* buffer, std::size_t count, bool headerSigned,
                                                    int bits, bool& changed) {
  using PF = gdcm::PixelFormat;
  std::optional<PF::ScalarType> fixed;
  switch (type) {
    case PF::UINT8: fixed = fixSignedness<std::uint8_t, std::int8_t, std::uint8_t>(buffer, count, headerSigned, bits); break;
    case PF::INT8: fixed = fixSignedness<std::int8_t, std::int8_t, std::uint8_t>(buffer, count, headerSigned, bits); break;
    case PF::UINT16: fixed = fixSignedness<std::uint16_t, std::int16_t, std::uint16_t>(buffer, count, headerSigned, bits); break;
    case PF::INT16: fixed = fixSignedness<std::int16_t, std::int16_t, std::uint16_t>(buffer, count, headerSigned, bits); break;
    case PF::UINT32: fixed = fixSignedness<std::uint32_t, std::int32_t, std::uint32_t>(buffer, count, headerSigned, bits); break;
    case PF::INT32: fixed = fixSignedness<std::int32_t, std::int32_t, std::uint32_t>(buffer, count, headerSigned, bits); break;
    default: break;
  }
  if (fixed) changed = true;
  return fixed.value_or(type);
}

template <class Out>
bool convertSlice(gdcm::PixelFormat::ScalarType type, const char* buffer, std::size_t count, double slope,
                  double intercept, Out* out) {
  switch (type) {
    case gdcm::PixelFormat::UINT8: return convertSlice<std::uint8_t>(buffer, count, slope, intercept, out);
    case gdcm::PixelFormat::INT8: return convertSlice<std::int8_t>(buffer, count, slope, intercept, out);
    case gdcm::PixelFormat::UINT16: return convertSlice<std::uint16_t>(buffer, count, slope, intercept, out);
    case gdcm::PixelFormat::INT16: return convertSlice<std::int16_t>(buffer, count, slope, intercept, out);
    case gdcm::PixelFormat::UINT32: return convertSlice<std::uint32_t>(buffer, count, slope, intercept, out);
    case gdcm::PixelFormat::INT32: return convertSlice<std::int32_t>(buffer, count, slope, intercept, out);
    case gdcm::PixelFormat::FLOAT32: return convertSlice<float>(buffer, count, slope, intercept, out);
    case gdcm::PixelFormat::FLOAT64: return convertSlice<double>(buffer, count, slope, intercept, out);
    default: break;
  }
  throw Error("internal error: unsupported DICOM pixel type");
}

std::size_t pixelTypeSize(gdcm::PixelFormat::ScalarType type) {
  switch (type) {
    case gdcm::PixelFormat::UINT8:
    case gdcm::PixelFormat::INT8: return 1;
    case gdcm::PixelFormat::UINT16:
    case gdcm::PixelFormat::INT16: return 2;
    case gdcm::PixelFormat::UINT32:
    case gdcm::PixelFormat::INT32:
    case gdcm::PixelFormat::FLOAT32: return 4;
    case gdcm::PixelFormat::FLOAT64: return 8;
    default: return 0;
  }
}

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  const std::size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

/// Walks a file's DICOM element structure (headers and declared lengths only, values are skipped)
/// before GDCM sees it. Debian's GDCM is built with assertions, and a DICOM file cut short inside
/// its header aborts the process in gdcm::Reader; this check turns such files into a clear error.
class DicomStructureCheck {
 public:
  enum class Verdict {
    Ok,        ///< structure complete (or deflated, which cannot be walked): safe to hand to GDCM
    NotDicom,  ///< no DICOM structure at all: skip the file
    Broken,    ///< a DICOM file (has the "DICM" signature) that is truncated or malformed
  };

  explicit DicomStructureCheck(const std::string& path) : path_(path) {}

  Verdict run() {
    std::error_code ec;
    const std::uintmax_t size = fs::file_size(path_, ec);
    if (ec) {
      problem_ = "cannot determine its size: " + ec.message();
      return Verdict::NotDicom;
    }
    size_ = size;
    in_.open(path_, std::ios::binary);
    if (!in_) {
      problem_ = "cannot be opened";
      return Verdict::NotDicom;
    }
    unsigned char magic[4] = {0, 0, 0, 0};
    const bool part10 = size_ >= 132 && seek(128) && readBytes(magic, 4) && std::memcmp(magic, "DICM", 4) == 0;
    if (!part10) {
      // A raw data set without preamble (old files): accept only if it parses completely.
      if (!seek(0)) return Verdict::NotDicom;
      unsigned char head[8];
      if (!readBytes(head, 8)) return Verdict::NotDicom;
      const std::uint16_t group = std::uint16_t(head[0] | (head[1] << 8));
      if (group != 0x0002 && group != 0x0008) return Verdict::NotDicom;
      const bool explicitVr = isVr(head[4], head[5]);
      if (!seek(0)) return Verdict::NotDicom;
      return walkElements(explicitVr, false, 0) && elements_ > 0 ? Verdict::Ok : Verdict::NotDicom;
    }
    // File meta information: group 0002, explicit VR little endian.
    std::string transferSyntax;
    int metaElements = 0;
    while (true) {
      const std::uint64_t at = pos_;
      unsigned char g[2];
      if (!readBytes(g, 2)) break;
      if ((g[0] | (g[1] << 8)) != 0x0002) {
        seek(at);
        break;
      }
      seek(at);
      Header h;
      if (!readHeader(h, true)) return Verdict::Broken;
      if (h.length == kUndefined) return fail("undefined length in the file meta information");
      if (h.group == 0x0002 && h.element == 0x0010 && h.length < 256) {
        std::string v(h.length, '\0');
        if (!readBytes(reinterpret_cast<unsigned char*>(v.data()), h.length))
          return fail("the file ends inside the transfer syntax UID");
        transferSyntax = trim(v);
      } else if (!skip(h, h.length)) {
        return Verdict::Broken;
      }
      ++metaElements;
    }
    if (metaElements == 0) return fail("no file meta information after the DICM signature");
    if (transferSyntax == "1.2.840.10008.1.2.1.99") {
      // Deflated: the data set cannot be walked without inflating it; GDCM inflates it, and says so
      // if no pixel data is inside.
      hasPixelData_ = true;
      return Verdict::Ok;
    }
    bool explicitVr = transferSyntax != "1.2.840.10008.1.2";
    bigEndian_ = transferSyntax == "1.2.840.10008.1.2.2";
    if (transferSyntax.empty()) {
      unsigned char head[6];
      const std::uint64_t at = pos_;
      explicitVr = readBytes(head, 6) && isVr(head[4], head[5]);
      seek(at);
    }
    const std::uint64_t start = pos_;
    if (walkElements(explicitVr, false, 0) && elements_ > 0) return Verdict::Ok;
    // Some writers encode the data set unlike their transfer syntax says; GDCM copes with that.
    const std::string firstProblem = problem_.empty() ? "no data set after the file meta information" : problem_;
    elements_ = 0;
    hasPixelData_ = false;
    fragments_.clear();
    if (seek(start) && walkElements(!explicitVr, false, 0) && elements_ > 0) return Verdict::Ok;
    problem_ = firstProblem;
    return Verdict::Broken;
  }

  const std::string& problem() const { return problem_; }
  /// Whether the top-level data set holds pixel data (7FE0,0008/0009/0010).
  bool hasPixelData() const { return hasPixelData_; }
  /// Encapsulated pixel data: each item's (file offset, length), the basic offset table first, as
  /// the item lengths say (a delimiter's bytes inside an item are data).
  const std::vector<std::pair<std::uint64_t, std::uint32_t>>& fragments() const { return fragments_; }

 private:
  static constexpr std::uint32_t kUndefined = 0xffffffffu;
  static constexpr int kMaxDepth = 64;

  struct Header {
    std::uint16_t group = 0, element = 0;
    char vr[2] = {0, 0};
    bool hasVr = false;
    std::uint32_t length = 0;
  };

  static bool isVr(unsigned char a, unsigned char b) {
    static const char* const vrs[] = {"AE", "AS", "AT", "CS", "DA", "DS", "DT", "FD", "FL", "IS", "LO",
                                      "LT", "OB", "OD", "OF", "OL", "OV", "OW", "PN", "SH", "SL", "SQ",
                                      "SS", "ST", "SV", "TM", "UC", "UI", "UL", "UN", "UR", "US", "UT", "UV"};
    for (const char* v : vrs)
      if (v[0] == char(a) && v[1] == char(b)) return true;
    return false;
  }
  static bool isLongVr(const char* vr) {
    static const char* const vrs[] = {"OB", "OD", "OF", "OL", "OV", "OW", "SQ", "SV", "UC", "UN", "UR", "UT", "UV"};
    for (const char* v : vrs)
      if (v[0] == vr[0] && v[1] == vr[1]) return true;
    return false;
  }

  Verdict fail(const std::string& why) {
    problem_ = why;
    return Verdict::Broken;
  }
  bool failed(const std::string& why) {
    if (problem_.empty()) problem_ = why;
    return false;
  }

  bool seek(std::uint64_t p) {
    if (p > size_) return false;
    in_.clear();
    in_.seekg(std::streamoff(p));
    pos_ = p;
    return bool(in_);
  }
  bool readBytes(unsigned char* dst, std::uint64_t n) {
    if (pos_ + n > size_) return false;
    in_.read(reinterpret_cast<char*>(dst), std::streamsize(n));
    if (!in_) return false;
    pos_ += n;
    return true;
  }
  bool skip(const Header& h, std::uint64_t n) {
    if (pos_ + n > size_) {
      std::ostringstream msg;
      msg << "element (" << std::hex;
      msg.width(4);
      msg.fill('0');
      msg << h.group << ",";
      msg.width(4);
      msg << h.element << std::dec << ") declares " << n << " bytes but only " << (size_ - pos_)
          << " remain in the file";
      return failed(msg.str());
    }
    return seek(pos_ + n);
  }
  std::uint16_t u16(const unsigned char* p, bool big) const {
    return big ? std::uint16_t((p[0] << 8) | p[1]) : std::uint16_t(p[0] | (p[1] << 8));
  }
  std::uint32_t u32(const unsigned char* p, bool big) const {
    return big ? (std::uint32_t(p[0]) << 24) | (std::uint32_t(p[1]) << 16) | (std::uint32_t(p[2]) << 8) | p[3]
               : std::uint32_t(p[0]) | (std::uint32_t(p[1]) << 8) | (std::uint32_t(p[2]) << 16) |
                     (std::uint32_t(p[3]) << 24);
  }

  bool readHeader(Header& h, bool explicitVr) {
    const bool big = bigEndian_;
    unsigned char b[8];
    if (!readBytes(b, 8)) return failed("the file ends inside an element header");
    h.group = u16(b, big);
    h.element = u16(b + 2, big);
    h.hasVr = false;
    if (h.group == 0xfffe) {
      h.length = u32(b + 4, big);
    } else if (explicitVr && isVr(b[4], b[5])) {
      h.hasVr = true;
      h.vr[0] = char(b[4]);
      h.vr[1] = char(b[5]);
      if (isLongVr(h.vr)) {
        unsigned char l[4];
        if (!readBytes(l, 4)) return failed("the file ends inside an element header");
        h.length = u32(l, big);
      } else {
        h.length = u16(b + 6, big);
      }
    } else {
      h.length = u32(b + 4, big);  // implicit VR (also explicit files with implicit private elements)
    }
    return true;
  }
  /// Elements until the end of the file (top level) or an item delimitation item (inItem).
  bool walkElements(bool explicitVr, bool inItem, int depth) {
    if (depth > kMaxDepth) return failed("sequences nested too deeply");
    while (true) {
      if (!inItem && pos_ == size_) return true;
      Header h;
      if (!readHeader(h, explicitVr)) return false;
      if (h.group == 0xfffe) {
        if (h.element == 0xe00d && inItem) return true;
        if (!inItem && (h.element == 0xe00d || h.element == 0xe0dd)) {  // stray delimiter: tolerated
          if (h.length != kUndefined && !skip(h, h.length)) return false;
          continue;
        }
        return failed("misplaced item tag in the data set");
      }
      ++elements_;
      if (!inItem && h.group == 0x7fe0 && (h.element == 0x0008 || h.element == 0x0009 || h.element == 0x0010))
        hasPixelData_ = true;
      if (h.length == kUndefined) {
        const bool encapsulated = h.group == 0x7fe0 && h.element == 0x0010;
        const bool unknownVr = h.hasVr && h.vr[0] == 'U' && h.vr[1] == 'N';
        if (!walkSequence(explicitVr && !unknownVr, depth + 1, encapsulated)) return false;
      } else if (!skip(h, h.length)) {
        return false;
      }
    }
  }

  /// Items of an undefined-length sequence (or encapsulated pixel data) up to its delimiter.
  bool walkSequence(bool explicitVr, int depth, bool encapsulated) {
    if (depth > kMaxDepth) return failed("sequences nested too deeply");
    while (true) {
      Header h;
      if (!readHeader(h, explicitVr)) return failed("the file ends inside a sequence");
      if (h.group != 0xfffe) return failed("a sequence item is missing its item tag");
      if (h.element == 0xe0dd) return true;
      if (h.element != 0xe000) return failed("unexpected delimiter inside a sequence");
      if (h.length == kUndefined) {
        if (encapsulated) return failed("a pixel data fragment has undefined length");
        if (!walkElements(explicitVr, true, depth + 1)) return false;
      } else {
        if (encapsulated && depth == 1) fragments_.push_back({pos_, h.length});
        if (!skip(h, h.length)) return false;
      }
    }
  }

  std::string path_;
  std::ifstream in_;
  std::uint64_t size_ = 0, pos_ = 0;
  bool bigEndian_ = false;
  bool hasPixelData_ = false;
  std::vector<std::pair<std::uint64_t, std::uint32_t>> fragments_;
  int elements_ = 0;
  std::string problem_;
};

struct DirectoryListing {
  std::vector<std::string> files;    ///< regular files (symbolic links followed), sorted
  std::vector<std::string> subdirs;  ///< subdirectories, sorted (not searched)
};

DirectoryListing listDirectory(const std::string& directory) {
  DirectoryListing out;
  std::error_code ec;
  fs::directory_iterator it(directory, ec);
  if (ec) throw Error("cannot list DICOM directory '" + directory + "': " + ec.message());
  for (; it != fs::directory_iterator(); it.increment(ec)) {
    if (ec) throw Error("cannot list DICOM directory '" + directory + "': " + ec.message());
    std::error_code sec;
    if (it->is_regular_file(sec))
      out.files.push_back(it->path().string());
    else if (it->is_directory(sec))
      out.subdirs.push_back(it->path().string());
  }
  if (ec) throw Error("cannot list DICOM directory '" + directory + "': " + ec.message());
  std::sort(out.files.begin(), out.files.end());
  std::sort(out.subdirs.begin(), out.subdirs.end());
  return out;
}

/// A hint for a directory whose images may sit in subdirectories (not searched).
std::string subdirectoryHint(const DirectoryListing& listing) {
  if (listing.subdirs.empty()) return {};
  return "; subdirectories are not searched: give the directory of one series, for example '" +
         listing.subdirs.front() + "'";
}

}  // namespace

// For a JPEG 2000 slice that does not decode: what its codestream's SIZ marker says against the
// header ("its JPEG 2000 codestream describes a W x H image, the header C x R; "), found through the
// pixel data items as their lengths define them; "" when they agree or it cannot be told.
std::string codestreamMismatch(const std::string& path, int columns, int rows) {
  DicomStructureCheck check(path);
  if (check.run() != DicomStructureCheck::Verdict::Ok || check.fragments().size() < 2) return {};
  const auto [offset, length] = check.fragments()[1];  // [0] is the basic offset table
  if (length < 28) return {};
  std::ifstream in(path, std::ios::binary);
  unsigned char b[28];
  in.seekg(std::streamoff(offset));
  if (!in.read(reinterpret_cast<char*>(b), 28) || b[0] != 0xff || b[1] != 0x4f || b[2] != 0xff || b[3] != 0x51) return {};
  auto u32 = [&](int at) { return (std::uint64_t(b[at]) << 24) | (std::uint64_t(b[at + 1]) << 16) | (std::uint64_t(b[at + 2]) << 8) | b[at + 3]; };
  const std::uint64_t x = u32(8), y = u32(12), x0 = u32(16), y0 = u32(20);  // Xsiz, Ysiz, XOsiz, YOsiz
  if (x < x0 || y < y0 || (x - x0 == std::uint64_t(columns) && y - y0 == std::uint64_t(rows))) return {};
  return "its JPEG 2000 codestream describes a " + std::to_string(x - x0) + "x" + std::to_string(y - y0) + " image, the header " +
         std::to_string(columns) + "x" + std::to_string(rows) + "; ";
}

// Slices at positions `keys` (mm along the normal, increasing; the volume's k-th slice at keys[k])
// resampled onto keys.front() + k * step, k = 0 .. round(span / step), linearly between the two
// slices around each position (a position on a slice takes that slice exactly). The geometry keeps
// its origin and k axis; its k spacing must already be the new one.
Volume regularizeSlices(const Volume& in, const std::vector<double>& keys, double step) {
  const int n = int(keys.size());
  const double span = keys.back() - keys.front();
  const int out = int(std::lround(span / step)) + 1;
  VolumeGeometry g = in.geometry();
  g.dims.z() = out;
  g.validate();
  const std::size_t sliceVoxels = std::size_t(g.dims.x()) * std::size_t(g.dims.y());
  checkAllocation(g.voxelCount(), g.voxelCount() * (in.type() == ScalarType::Int16 ? 2 : 4), "the regularized DICOM series");
  Volume v(g, in.type());
  int j = 0;
  for (int k = 0; k < out; ++k) {
    const double q = std::min(keys.front() + double(k) * step, keys.back());
    while (j + 2 < n && keys[std::size_t(j) + 1] <= q) ++j;
    double w = std::clamp((q - keys[std::size_t(j)]) / (keys[std::size_t(j) + 1] - keys[std::size_t(j)]), 0.0, 1.0);
    if (w < 1e-6) w = 0.0;
    if (w > 1.0 - 1e-6) w = 1.0;
    const std::size_t a = std::size_t(j) * sliceVoxels, b = a + sliceVoxels, o = std::size_t(k) * sliceVoxels;
    if (in.type() == ScalarType::Int16) {
      const std::int16_t* src = in.data<std::int16_t>();
      std::int16_t* dst = v.data<std::int16_t>();
      for (std::size_t p = 0; p < sliceVoxels; ++p)
        dst[o + p] = std::int16_t(std::lround(double(src[a + p]) + w * (double(src[b + p]) - double(src[a + p]))));
    } else {
      const float* src = in.data<float>();
      float* dst = v.data<float>();
      for (std::size_t p = 0; p < sliceVoxels; ++p) dst[o + p] = float(double(src[a + p]) + w * (double(src[b + p]) - double(src[a + p])));
    }
  }
  return v;
}

// The slice axis of two or more slices sorted by `key` (their position along `normal`, mm) at
// `positions`: its direction, its spacing, and - steps more than 10 % from the median - the regular
// step to resample onto (0 when even). Fills the report's step figures and warnings.
struct SliceAxis {
  Eigen::Vector3d direction;
  double spacing = 1.0, regularStep = 0.0;
};

SliceAxis sliceAxisOf(const std::vector<SliceHeader>& slices, const std::vector<Eigen::Vector3d>& positions, const Eigen::Vector3d& normal,
                      double pixelSpacing, const std::string& directory, DicomReadReport& report) {
  const int n = int(slices.size());
  SliceAxis axis;
  std::vector<double> steps;
  for (int s = 0; s + 1 < n; ++s) steps.push_back(slices[s + 1].key - slices[s].key);
  const double med = median(steps);
  report.minStepMm = *std::min_element(steps.begin(), steps.end());
  report.maxStepMm = *std::max_element(steps.begin(), steps.end());
  report.sliceStepMm = med;
  for (double s : steps)
    if (std::abs(s - med) > 0.1 * med) report.spacingGaps = true;
  if (report.spacingGaps) {
    // Resampled onto a regular grid at the smallest step (at most twice the slice count, so that
    // two near-duplicate positions cannot blow the volume up), by linear interpolation between the
    // two slices around each grid position: every slice stays where it was acquired.
    const double span = slices.back().key - slices.front().key;
    axis.regularStep = std::max(report.minStepMm, span / double(2 * n));
    std::ostringstream w;
    w << "DICOM slice spacing is uneven: steps range from " << formatMm(report.minStepMm) << " to " << formatMm(report.maxStepMm)
      << " mm (missing slices?); the " << n << " slices are resampled onto a regular grid of " << std::lround(span / axis.regularStep) + 1
      << " slices " << formatMm(axis.regularStep) << " mm apart (linear interpolation between neighbouring slices)";
    report.warnings.push_back(w.str());
    report.sliceStepMm = axis.regularStep;
  }
  const Eigen::Vector3d span = positions.back() - positions.front();
  axis.direction = span.normalized();
  const double cosTilt = axis.direction.dot(normal);
  if (!(cosTilt > 0.1))
    throw Error("DICOM slice positions in '" + directory + "' do not advance along the slice normal");
  axis.spacing = (axis.regularStep > 0 ? axis.regularStep : med) / cosTilt;
  if (cosTilt < std::cos(0.5 * 3.14159265358979 / 180.0)) {
    std::ostringstream w;
    w << "DICOM slices are sheared (gantry tilt of " << formatMm(std::acos(std::min(1.0, cosTilt)) * 180.0 / 3.14159265358979)
      << " degrees); the volume keeps the tilted slice axis";
    report.warnings.push_back(w.str());
  }
  // Slices far off the line from the first to the last position.
  double offLine = 0.0;
  for (const Eigen::Vector3d& p : positions) {
    const Eigen::Vector3d d = p - positions.front();
    offLine = std::max(offLine, (d - d.dot(axis.direction) * axis.direction).norm());
  }
  if (offLine > 0.5 * pixelSpacing)
    report.warnings.push_back("DICOM slice positions do not lie on one line (up to " + formatMm(offLine) +
                              " mm off); the volume assumes they do");
  return axis;
}

// One slice read by GDCM: checked against the series' size and its own pixel data, decoded into
// `buffer` (its stored values, as GDCM's pixel type says). Throws handson::Error naming the file.
struct DecodedSlice {
  std::string syntax;
  gdcm::PixelFormat::ScalarType pixelType{};
  bool monochrome1 = false;
  double slope = 1.0, intercept = 0.0;
};

DecodedSlice decodeSlice(const gdcm::ImageReader& reader, const std::string& path, bool incomplete, int columns, int rows, std::vector<char>& buffer) {
  DecodedSlice d;
  const gdcm::Image& image = reader.GetImage();
  d.syntax = transferSyntaxText(image.GetTransferSyntax());
  const std::string& syntax = d.syntax;
  if (image.GetNumberOfDimensions() == 3 && image.GetDimension(2) > 1)
    throw Error("DICOM file '" + path + "' holds several frames: multi-frame DICOM is not supported");
  if (int(image.GetColumns()) != columns || int(image.GetRows()) != rows)
    throw Error("DICOM file '" + path + "' has a pixel matrix of " + std::to_string(image.GetColumns()) + "x" +
                std::to_string(image.GetRows()) + ", unlike the rest of the series (" + std::to_string(columns) + "x" + std::to_string(rows) + ")");
  const gdcm::PixelFormat& pf = image.GetPixelFormat();
  if (pf.GetSamplesPerPixel() != 1)
    throw Error("DICOM file '" + path + "' holds colour images (" + std::to_string(pf.GetSamplesPerPixel()) +
                " samples per pixel): only greyscale volumes are supported");
  d.pixelType = pf.GetScalarType();
  const std::size_t pixelSize = pixelTypeSize(d.pixelType);
  if (pixelSize == 0) throw Error("DICOM file '" + path + "' uses an unsupported pixel format (" + pf.GetScalarTypeAsString() + ")");
  d.monochrome1 = image.GetPhotometricInterpretation() == gdcm::PhotometricInterpretation::MONOCHROME1;
  const std::size_t expected = std::size_t(columns) * std::size_t(rows) * pixelSize;
  if (image.GetBufferLength() != expected)
    throw Error("DICOM file '" + path + "': unexpected pixel data size (" + std::to_string(image.GetBufferLength()) + " bytes instead of " +
                std::to_string(expected) + ")");
  const gdcm::DataSet& ds = reader.GetFile().GetDataSet();
  if (!ds.FindDataElement(gdcm::Tag(0x7fe0, 0x0010)))
    throw Error("DICOM file '" + path + "' has no pixel data: the file is truncated or not an image");
  if (!image.GetTransferSyntax().IsEncapsulated()) {  // (compressed data: the codec checks its own)
    // Uncompressed pixel data shorter than the image: GDCM may accept a truncated file.
    const gdcm::DataElement& pd = ds.GetDataElement(gdcm::Tag(0x7fe0, 0x0010));
    const gdcm::ByteValue* bv = pd.GetByteValue();
    std::error_code sizeError;
    const std::uintmax_t fileSize = fs::file_size(path, sizeError);
    // (A deflated file is legitimately smaller than its pixel data.)
    const bool deflated = reader.GetFile().GetHeader().GetDataSetTransferSyntax() == gdcm::TransferSyntax::DeflatedExplicitVRLittleEndian;
    if (bv && (incomplete || bv->GetLength() < expected || (!sizeError && !deflated && fileSize < expected)))
      throw Error("DICOM file '" + path + "' is truncated: its pixel data is shorter than the " + std::to_string(columns) + "x" +
                  std::to_string(rows) + " image it declares");
    if (!bv && !pd.GetSequenceOfFragments())
      throw Error("DICOM file '" + path + "' has empty pixel data: the file is truncated or corrupt");
  }
  buffer.resize(expected);
  if (!image.GetBuffer(buffer.data()))
    throw Error("cannot decode the pixel data of DICOM file '" + path + "' (transfer syntax " + syntax + "): " +
                codestreamMismatch(path, columns, rows) + "the file is truncated or corrupt, or the compression is not supported");
  if (const auto v = parseNumbers(datasetText(ds, kRescaleSlope)); v && !v->empty() && (*v)[0] != 0.0) d.slope = (*v)[0];
  if (const auto v = parseNumbers(datasetText(ds, kRescaleIntercept)); v && !v->empty()) d.intercept = (*v)[0];
  return d;
}

// Lists the series found (largest first) in the report and chooses one: the series of the file
// `seriesOf` when given, else the largest; says so when there are several. Throws handson::Error
// when the given file is in none of them.
void chooseSeries(const std::map<std::string, std::vector<SliceHeader>>& bySeries, const std::map<std::string, std::string>& descriptions,
                  const std::string& seriesOf, const std::string& directory, DicomReadReport& report) {
  for (const auto& [uid, slices] : bySeries)
    report.seriesFound.push_back(DicomSeriesInfo{uid, descriptions.at(uid), int(slices.size())});
  std::stable_sort(report.seriesFound.begin(), report.seriesFound.end(),
                   [](const DicomSeriesInfo& a, const DicomSeriesInfo& b) { return a.fileCount > b.fileCount; });
  report.chosen = report.seriesFound.front();
  if (!seriesOf.empty()) {  // the series of the file the user gave
    const std::string want = fileName(seriesOf);
    const auto holds = [&](const DicomSeriesInfo& s) {
      const auto& sl = bySeries.at(s.seriesInstanceUid);
      return std::any_of(sl.begin(), sl.end(), [&](const SliceHeader& h) { return fileName(h.path) == want; });
    };
    const auto it = std::find_if(report.seriesFound.begin(), report.seriesFound.end(), holds);
    if (it == report.seriesFound.end())
      throw Error("DICOM file '" + seriesOf + "' is not a DICOM image this reader can load (no pixel data or not an image)");
    report.chosen = *it;
  }
  auto seriesName = [](const DicomSeriesInfo& s) {
    std::string n = s.seriesInstanceUid.empty() ? std::string("(no SeriesInstanceUID)") : s.seriesInstanceUid;
    if (!s.description.empty()) n += " \"" + s.description + "\"";
    return n;
  };
  if (report.seriesFound.size() > 1) {
    std::ostringstream w;
    w << report.seriesFound.size() << " DICOM series found in '" << directory << "'; loading "
      << (seriesOf.empty() ? std::string("the largest") : "the one of '" + fileName(seriesOf) + "'") << ", "
      << seriesName(report.chosen) << " (" << report.chosen.fileCount << " files). Others:";
    bool first = true;
    for (const DicomSeriesInfo& other : report.seriesFound) {
      if (other.seriesInstanceUid == report.chosen.seriesInstanceUid) continue;
      w << (first ? "" : ",") << " " << seriesName(other) << " (" << other.fileCount << " files)";
      first = false;
    }
    report.warnings.push_back(w.str());
  }
}

// The slices of one series agree on size, pixel spacing and orientation, one slice per file.
// Throws handson::Error naming the two files that differ.
void checkSlicesAgree(const std::vector<SliceHeader>& slices, const std::string& directory) {
  const SliceHeader& ref = slices.front();
  for (const SliceHeader& h : slices) {
    if (h.frames > 1)
      throw Error("DICOM file '" + h.path + "' holds " + std::to_string(h.frames) +
                  " frames: multi-frame (enhanced) DICOM is not supported, only one slice per file");
    if (h.rows != ref.rows || h.columns != ref.columns)
      throw Error("DICOM slices differ in size: '" + fileName(ref.path) + "' is " + std::to_string(ref.columns) + "x" +
                  std::to_string(ref.rows) + " but '" + fileName(h.path) + "' is " + std::to_string(h.columns) + "x" +
                  std::to_string(h.rows) + " (in '" + directory + "')");
    auto differ = [](const std::optional<std::vector<double>>& a, const std::optional<std::vector<double>>& b,
                     double tol) {
      if (a.has_value() != b.has_value()) return true;
      if (!a) return false;
      if (a->size() != b->size()) return true;
      for (std::size_t n = 0; n < a->size(); ++n)
        if (std::abs((*a)[n] - (*b)[n]) > tol * std::max(1.0, std::abs((*a)[n]))) return true;
      return false;
    };
    if (differ(h.pixelSpacing, ref.pixelSpacing, 1e-4))
      throw Error("DICOM slices differ in pixel spacing: '" + fileName(ref.path) + "' and '" + fileName(h.path) +
                  "' (in '" + directory + "')");
    if (differ(h.orientation, ref.orientation, 1e-4))
      throw Error("DICOM slices differ in orientation (ImageOrientationPatient): '" + fileName(ref.path) + "' and '" +
                  fileName(h.path) + "' (in '" + directory + "')");
  }
}

// Sorts the slices by position along `normal` (their key, mm) and drops a second copy of the same
// instance; two different images at one position are refused. A single slice without a position is
// placed at the origin.
void sortSlicesAlong(std::vector<SliceHeader>& slices, const Eigen::Vector3d& normal, const std::string& directory, DicomReadReport& report) {
  for (SliceHeader& h : slices) {
    if (!h.position || h.position->size() != 3) {
      if (slices.size() > 1)
        throw Error("DICOM file '" + h.path + "' has no valid ImagePositionPatient (0020,0032): the slices cannot be "
                    "ordered");
      report.warnings.push_back("DICOM image has no valid ImagePositionPatient; placing it at the origin");
      h.position = std::vector<double>{0.0, 0.0, 0.0};
    }
    const Eigen::Vector3d p = lpsToRas({(*h.position)[0], (*h.position)[1], (*h.position)[2]});
    h.key = p.dot(normal);
  }
  std::stable_sort(slices.begin(), slices.end(), [](const SliceHeader& a, const SliceHeader& b) { return a.key < b.key; });

  // Duplicate positions: the same instance twice is dropped, two different images are refused.
  {
    std::vector<SliceHeader> unique;
    for (SliceHeader& h : slices) {
      if (!unique.empty() && std::abs(h.key - unique.back().key) < 1e-3) {
        const SliceHeader& prev = unique.back();
        if (!h.sopUid.empty() && h.sopUid == prev.sopUid) {
          report.warnings.push_back("DICOM file '" + fileName(h.path) + "' is a copy of '" + fileName(prev.path) +
                                    "' (same SOP Instance UID); ignored");
          continue;
        }
        throw Error("DICOM files '" + fileName(prev.path) + "' and '" + fileName(h.path) + "' in '" + directory +
                    "' are different images at the same slice position (" + formatMm(h.key) +
                    " mm along the slice normal): the series holds more than one volume (several acquisitions, "
                    "echoes or time points?). Put each volume's files in a directory of its own");
      }
      unique.push_back(std::move(h));
    }
    slices = std::move(unique);
  }
}

// What a directory's read looks for, and where its warnings go.
struct DicomSource {
  const std::string& directory;
  const std::string& seriesOf;  ///< one file given: its series is wanted (else empty)
  DicomReadReport& report;
};

// The files that are sound DICOM (those holding pixel data marked), and how many are not DICOM.
struct DicomCandidates {
  std::vector<std::string> files;
  std::set<std::string> withPixelData;
  int skipped = 0;
};

// The image files' headers by SeriesInstanceUID, and each series' description.
struct SeriesGroups {
  std::map<std::string, std::vector<SliceHeader>> bySeries;
  std::map<std::string, std::string> descriptions;
};

// Each file's structure walked before GDCM parses it (GDCM aborts on some truncated headers): the
// DICOM files are the candidates (those with pixel data marked), the rest count as skipped. A damaged file is refused - unless one file was given (`seriesOf`) and it is another.
DicomCandidates checkStructures(const std::vector<std::string>& files, const DicomSource& src) {
  DicomCandidates c;
  const std::string &seriesOf = src.seriesOf, &directory = src.directory;
  DicomReadReport& report = src.report;
  std::vector<std::string>& candidates = c.files;
  std::set<std::string>& withPixelData = c.withPixelData;
  int& skipped = c.skipped;
  for (std::size_t f = 0; f < files.size(); ++f) {
    DicomStructureCheck check(files[f]);
    switch (check.run()) {
      case DicomStructureCheck::Verdict::Ok:
        candidates.push_back(files[f]);
        if (check.hasPixelData()) withPixelData.insert(files[f]);
        break;
      case DicomStructureCheck::Verdict::NotDicom: ++skipped; break;
      case DicomStructureCheck::Verdict::Broken:
        // One file given (its series wanted): a damaged file of the directory that is not it is
        // left out, with a warning, rather than refusing the series.
        if (!seriesOf.empty() && fileName(files[f]) != fileName(seriesOf)) {
          report.warnings.push_back("DICOM file '" + fileName(files[f]) + "' in '" + directory + "' is truncated or corrupt (" + check.problem() +
                                    "): left out");
          break;
        }
        throw Error("DICOM file '" + files[f] + "' is truncated or corrupt (" + check.problem() +
                    "); remove or replace it");
    }
  }
  return c;
}

// The header of one image file as the scanner read it (rows and columns present), checked for what
// this reader and GDCM take. Throws handson::Error naming the file otherwise.
SliceHeader sliceHeaderOf(const gdcm::Scanner& scanner, const std::string& f, const std::string& rowsText, const std::string& colsText,
                          bool hasPixelData) {
  SliceHeader h;
  h.path = f;
  // An image whose header or pixel data stops early: cut at an element boundary, so GDCM would
  // read it without complaint.
  const auto rows = parseNumbers(rowsText);
  const auto cols = parseNumbers(colsText);
  if (!rows || !cols || rows->size() != 1 || cols->size() != 1 || (*rows)[0] < 1 || (*cols)[0] < 1)
    throw Error("DICOM file '" + f + "' is truncated or corrupt (no valid Rows and Columns); remove or replace it");
  if (!hasPixelData)
    throw Error("DICOM file '" + f + "' is truncated or corrupt (an image without pixel data); remove or replace it");
  // Checked before GDCM decodes the pixels: its pixmap reader asserts (aborts the process) on a
  // photometric interpretation it does not know (found by fuzz_dicom).
  const std::string photometric = trim(tagText(scanner, f, kPhotometric));
  if (photometric != "MONOCHROME1" && photometric != "MONOCHROME2")
    throw Error("DICOM file '" + f + "' has photometric interpretation '" + photometric +
                "': only grayscale images (MONOCHROME1, MONOCHROME2) can be read as a CT or MR volume");
  // GDCM asserts on these too (SamplesPerPixel over 4, found by fuzz_dicom): one grayscale sample
  // of 8, 16 or 32 bits, stored bits and high bit within it, signed or unsigned.
  auto number = [&](const gdcm::Tag& tag) -> std::optional<double> {
    const auto v = parseNumbers(tagText(scanner, f, tag));
    return v && v->size() == 1 ? std::optional<double>((*v)[0]) : std::nullopt;
  };
  const auto spp = number(kSamplesPerPixel), allocated = number(kBitsAllocated), stored = number(kBitsStored),
             high = number(kHighBit), representation = number(kPixelRepresentation);
  // A SamplesPerPixel that is there but is not one number is refused too: GDCM reads it its own way
  // and asserts when it takes it as more than 4 (found by fuzz_dicom).
  const bool unreadableSpp = scanner.GetValue(f.c_str(), kSamplesPerPixel) && !spp;
  if (unreadableSpp || (spp && *spp != 1) || !allocated || (*allocated != 8 && *allocated != 16 && *allocated != 32) ||
      (stored && (*stored < 1 || *stored > *allocated)) || (high && (*high < 0 || *high >= *allocated)) ||
      (representation && *representation != 0 && *representation != 1))
    throw Error("DICOM file '" + f + "' has a pixel format this reader does not take (samples per pixel " +
                tagText(scanner, f, kSamplesPerPixel) + ", bits allocated " + tagText(scanner, f, kBitsAllocated) + ", stored " +
                tagText(scanner, f, kBitsStored) + ", high bit " + tagText(scanner, f, kHighBit) +
                "): one grayscale sample of 8, 16 or 32 bits is expected");
  // And on an ACR-NEMA recognition code it does not know (found by fuzz_dicom).
  if (scanner.GetValue(f.c_str(), kRecognitionCode)) {
    const std::string code = trim(tagText(scanner, f, kRecognitionCode));
    if (code.rfind("ACR-NEMA", 0) != 0 && code.rfind("ACRNEMA", 0) != 0 && code.rfind("MIPS 2.0", 0) != 0)
      throw Error("DICOM file '" + f + "' has an unknown ACR-NEMA recognition code '" + code + "'");
  }
  h.rows = int((*rows)[0]);
  h.columns = int((*cols)[0]);
  if (representation) h.pixelRepresentation = int(*representation);
  if (stored) h.bitsStored = int(*stored);
  h.seriesUid = tagText(scanner, f, kSeriesInstanceUid);
  h.sopUid = tagText(scanner, f, kSopInstanceUid);
  if (const auto fr = parseNumbers(tagText(scanner, f, kNumberOfFrames)); fr && fr->size() == 1 && (*fr)[0] >= 1)
    h.frames = int((*fr)[0]);
  h.pixelSpacing = parseNumbers(tagText(scanner, f, kPixelSpacing));
  h.orientation = parseNumbers(tagText(scanner, f, kImageOrientation));
  h.position = parseNumbers(tagText(scanner, f, kImagePosition));
  return h;
}

// The scanned image files grouped by SeriesInstanceUID (with each series' description), their
// headers checked; non-images count as skipped. One file given (`seriesOf`): files of other series
// this reader cannot take are left out with a warning; the given file's own series must be sound.
SeriesGroups groupBySeries(const gdcm::Scanner& scanner, DicomCandidates& c, const DicomSource& src) {
  SeriesGroups groups;
  const std::vector<std::string>& candidates = c.files;
  const std::string& seriesOf = src.seriesOf;
  int& skipped = c.skipped;
  std::optional<std::string> wantedUid;  // the series of the file given, if one was
  if (!seriesOf.empty())
    for (const std::string& f : candidates)
      if (fileName(f) == fileName(seriesOf) && scanner.IsKey(f.c_str())) wantedUid = tagText(scanner, f, kSeriesInstanceUid);
  for (const std::string& f : candidates) {
    if (!scanner.IsKey(f.c_str())) {
      ++skipped;
      continue;
    }
    const std::string rowsText = tagText(scanner, f, kRows), colsText = tagText(scanner, f, kColumns);
    if (rowsText.empty() && colsText.empty()) {
      ++skipped;  // DICOM, but not an image (DICOMDIR, structured report, ...)
      continue;
    }
    try {
      SliceHeader h = sliceHeaderOf(scanner, f, rowsText, colsText, c.withPixelData.count(f) > 0);
      if (!groups.descriptions.count(h.seriesUid)) groups.descriptions[h.seriesUid] = tagText(scanner, f, kSeriesDescription);
      groups.bySeries[h.seriesUid].push_back(std::move(h));
    } catch (const Error& e) {
      if (!wantedUid || tagText(scanner, f, kSeriesInstanceUid) == *wantedUid) throw;
      src.report.warnings.push_back(std::string(e.what()) + " (another series than the file's: left out)");
      continue;
    }
  }
  return groups;
}

// The slices' pixel data, read by GDCM one file at a time, signedness as the header says, rescaled
// into the volume of grid `geom` (int16 while every value fits, then float32).
Volume readPixels(const std::vector<SliceHeader>& slices, const VolumeGeometry& geom, GdcmTraceCapture& quiet, const std::string& directory,
                  DicomReadReport& report, const ProgressFn& progress) {
  const std::size_t sliceVoxels = std::size_t(geom.dims.x()) * std::size_t(geom.dims.y());
  const std::size_t voxels = geom.voxelCount();
  checkAllocation(voxels, voxels * sizeof(std::int16_t), "DICOM series in '" + directory + "'");
  Volume volume(geom, ScalarType::Int16);

  // --- Read and rescale the pixel data slice by slice.
  std::vector<char> buffer;
  bool warnedMono1 = false, warnedMixedSyntax = false, warnedSignedness = false;
  const int n = int(slices.size());
  for (int s = 0; s < n; ++s) {
    const std::string& path = slices[s].path;
    gdcm::ImageReader reader;
    reader.SetFileName(path.c_str());
    quiet.take();
    if (!reader.Read())
      throw Error("cannot read DICOM file '" + path + "': the file is corrupt or truncated");
    const bool incomplete = quiet.take().find("Incomplete Pixel Data") != std::string::npos;
    const DecodedSlice d = decodeSlice(reader, path, incomplete, geom.dims.x(), geom.dims.y(), buffer);
    const gdcm::Image& image = reader.GetImage();
    const std::string& syntax = d.syntax;
    if (s == 0) {
      report.transferSyntax = syntax;
    } else if (syntax != report.transferSyntax && !warnedMixedSyntax) {
      report.warnings.push_back("DICOM slices use different transfer syntaxes (" + report.transferSyntax + ", " +
                                syntax + ")");
      warnedMixedSyntax = true;
    }
    if (d.monochrome1 && !warnedMono1) {
      report.warnings.push_back("DICOM series is MONOCHROME1 (low values display white); values are kept as stored");
      warnedMono1 = true;
    }
    const gdcm::PixelFormat::ScalarType pixelType = d.pixelType;
    const std::size_t pixelSize = pixelTypeSize(pixelType);

    // Signedness: the header's PixelRepresentation decides (a codestream that disagrees is re-read).
    gdcm::PixelFormat::ScalarType decodedType = pixelType;
    const int rep = slices[s].pixelRepresentation;
    if (image.GetTransferSyntax().IsEncapsulated() && (rep == 0 || rep == 1)) {
      const int bitsStored = slices[s].bitsStored >= 1 ? slices[s].bitsStored : int(8 * pixelSize);
      bool changed = false;
      decodedType = applyHeaderSignedness(pixelType, buffer.data(), sliceVoxels, rep == 1, bitsStored, changed);
      if (changed && !warnedSignedness) {
        report.warnings.push_back("DICOM file '" + fileName(path) + "': the compressed pixel data decode as " +
                                  (rep == 1 ? "unsigned" : "signed") + " values, the header (PixelRepresentation) says " +
                                  (rep == 1 ? "signed" : "unsigned") + "; read as the header says (" + std::to_string(bitsStored) +
                                  "-bit stored values)");
        warnedSignedness = true;
      }
    }

    const double slope = d.slope, intercept = d.intercept;

    const std::size_t offset = std::size_t(s) * sliceVoxels;
    bool stored = false;
    if (volume.type() == ScalarType::Int16)
      stored = convertSlice(decodedType, buffer.data(), sliceVoxels, slope, intercept,
                            volume.data<std::int16_t>() + offset);
    if (!stored) {
      if (volume.type() == ScalarType::Int16) {
        // A value that does not fit int16: switch to float32, keeping the slices read so far.
        checkAllocation(voxels, voxels * (sizeof(float) + sizeof(std::int16_t)),
                        "DICOM series in '" + directory + "' (as float32)");
        Volume promoted(geom, ScalarType::Float32);
        const std::int16_t* src = volume.data<std::int16_t>();
        float* dst = promoted.data<float>();
        for (std::size_t v = 0; v < offset; ++v) dst[v] = float(src[v]);
        volume = std::move(promoted);
      }
      convertSlice(decodedType, buffer.data(), sliceVoxels, slope, intercept, volume.data<float>() + offset);
    }
    reportProgress(progress, double(s + 1) / double(n), "reading DICOM slices");
  }
  return volume;
}

// The directory's files; refuses a missing path, a file given for the directory, an empty one.
DirectoryListing listDicomDirectory(const std::string& directory, const ProgressFn& progress) {
  std::error_code ec;
  const fs::file_status st = fs::status(directory, ec);
  if (directory.empty() || ec || !fs::exists(st)) throw Error("DICOM directory '" + directory + "' does not exist");
  if (!fs::is_directory(st))
    throw Error("'" + directory + "' is not a directory: give the directory that holds the DICOM series' slice files, not a single file");
  reportProgress(progress, 0.0, "scanning DICOM directory");
  DirectoryListing listing = listDirectory(directory);
  if (listing.files.empty())
    throw Error("DICOM directory '" + directory + "' holds no files: no DICOM images found" + subdirectoryHint(listing));
  return listing;
}

[[noreturn]] void noImagesFound(const std::string& directory, const DirectoryListing& listing, const char* why) {
  std::ostringstream msg;
  msg << "no DICOM images found in '" << directory << "' (" << listing.files.size() << " file" << (listing.files.size() == 1 ? "" : "s")
      << " checked, " << why << ")" << subdirectoryHint(listing);
  throw Error(msg.str());
}

// The pixel grid's in-plane frame: spacing (DICOM gives "row spacing \ column spacing") and the
// row and column directions, converted to RAS right away (dot and cross products are unaffected).
struct InPlaneFrame {
  double rowSpacing = 1.0, columnSpacing = 1.0;
  Eigen::Vector3d rowDir{-1, 0, 0}, colDir{0, -1, 0};  // RAS of LPS identity
};

InPlaneFrame inPlaneFrameOf(const SliceHeader& ref, std::size_t slices, const std::string& directory, DicomReadReport& report) {
  InPlaneFrame f;
  if (ref.pixelSpacing && ref.pixelSpacing->size() == 2 && (*ref.pixelSpacing)[0] > 0 && (*ref.pixelSpacing)[1] > 0) {
    f.rowSpacing = (*ref.pixelSpacing)[0];
    f.columnSpacing = (*ref.pixelSpacing)[1];
  } else {
    report.warnings.push_back("DICOM series has no valid PixelSpacing (0028,0030); assuming 1 mm pixels");
  }
  if (ref.orientation && ref.orientation->size() == 6) {
    const auto& o = *ref.orientation;
    Eigen::Vector3d r = lpsToRas({o[0], o[1], o[2]}), c = lpsToRas({o[3], o[4], o[5]});
    if (r.norm() < 0.5 || c.norm() < 0.5 || std::abs(r.normalized().dot(c.normalized())) > 1e-2)
      throw Error("DICOM ImageOrientationPatient of '" + fileName(ref.path) + "' is not a pair of perpendicular unit vectors");
    f.rowDir = r.normalized();
    f.colDir = c.normalized();
  } else if (slices > 1) {
    throw Error("DICOM series in '" + directory + "' has no valid ImageOrientationPatient (0020,0037): the slices cannot be placed in space");
  } else {
    report.warnings.push_back("DICOM image has no valid ImageOrientationPatient; assuming axial orientation");
  }
  return f;
}

// A single slice's spacing along the normal: its SliceThickness, else SpacingBetweenSlices, else 1 mm.
double singleSliceSpacing(const gdcm::Scanner& scanner, const SliceHeader& slice, DicomReadReport& report) {
  const auto thick = parseNumbers(tagText(scanner, slice.path, kSliceThickness));
  const auto between = parseNumbers(tagText(scanner, slice.path, kSpacingBetweenSlices));
  double spacing = 1.0;
  std::string source = "no slice thickness given; using 1 mm";
  if (thick && thick->size() == 1 && (*thick)[0] > 0) {
    spacing = (*thick)[0];
    source = "using its SliceThickness " + formatMm(spacing) + " mm as the slice spacing";
  } else if (between && between->size() == 1 && (*between)[0] > 0) {
    spacing = (*between)[0];
    source = "using its SpacingBetweenSlices " + formatMm(spacing) + " mm as the slice spacing";
  }
  report.sliceStepMm = report.minStepMm = report.maxStepMm = spacing;
  report.warnings.push_back("DICOM series has a single slice; " + source);
  return spacing;
}

// The chosen series' slices from the directory's files (structures checked, headers scanned,
// grouped by series, one chosen).
std::vector<SliceHeader> chosenSeriesSlices(const DirectoryListing& listing, gdcm::Scanner& scanner, const DicomSource& src) {
  // --- Check each file's structure first: GDCM aborts on some truncated headers.
  DicomCandidates candidates = checkStructures(listing.files, src);
  if (candidates.files.empty()) noImagesFound(src.directory, listing, "none is a DICOM file");
  // --- Scan headers and group the image files by series.
  for (const gdcm::Tag& t : {kSeriesInstanceUid, kSeriesDescription, kSopInstanceUid, kImagePosition, kImageOrientation, kRows, kColumns,
                             kPixelSpacing, kNumberOfFrames, kSliceThickness, kSpacingBetweenSlices, kPhotometric, kSamplesPerPixel,
                             kBitsAllocated, kBitsStored, kHighBit, kPixelRepresentation, kRecognitionCode})
    scanner.AddTag(t);
  scanner.Scan(candidates.files);
  SeriesGroups groups = groupBySeries(scanner, candidates, src);
  if (groups.bySeries.empty()) noImagesFound(src.directory, listing, "none is a readable DICOM image");
  chooseSeries(groups.bySeries, groups.descriptions, src.seriesOf, src.directory, src.report);
  const int skipped = candidates.skipped;
  if (skipped > 0)
    src.report.warnings.push_back(std::to_string(skipped) + " file" + (skipped == 1 ? "" : "s") + " in '" + src.directory + "' ignored: not DICOM images");
  return std::move(groups.bySeries[src.report.chosen.seriesInstanceUid]);
}

Volume readDicomSeriesInProcess(const std::string& directory, DicomReadReport* reportOut, const ProgressFn& progress,
                                 const std::string& seriesOf) {
  DicomReadReport report;
  const DirectoryListing listing = listDicomDirectory(directory, progress);
  GdcmTraceCapture quiet;  // from here on GDCM's own messages are taken, not printed
  gdcm::Scanner scanner;
  std::vector<SliceHeader> slices = chosenSeriesSlices(listing, scanner, {directory, seriesOf, report});

  // --- Check the slices agree on size, pixel spacing and orientation.
  const SliceHeader ref = slices.front();  // a copy: `slices` is rebuilt below
  checkSlicesAgree(slices, directory);
  const InPlaneFrame frame = inPlaneFrameOf(ref, slices.size(), directory, report);
  const Eigen::Vector3d normal = frame.rowDir.cross(frame.colDir).normalized();

  // --- Sort by position along the normal; the slice spacing and the k axis.
  sortSlicesAlong(slices, normal, directory, report);
  std::vector<Eigen::Vector3d> positions;
  const int n = int(slices.size());
  for (const SliceHeader& h : slices) positions.push_back(lpsToRas({(*h.position)[0], (*h.position)[1], (*h.position)[2]}));
  SliceAxis axis{normal, 1.0, 0.0};  // regularStep > 0: resample the slices onto this step along the normal (mm)
  if (n > 1) axis = sliceAxisOf(slices, positions, normal, std::min(frame.rowSpacing, frame.columnSpacing), directory, report);
  else axis.spacing = singleSliceSpacing(scanner, slices[0], report);
  report.slices = n;

  VolumeGeometry geom;
  geom.dims = Eigen::Vector3i(ref.columns, ref.rows, n);
  geom.spacing = Eigen::Vector3d(frame.columnSpacing, frame.rowSpacing, axis.spacing);
  geom.origin = positions.front();
  geom.direction.col(0) = frame.rowDir;
  geom.direction.col(1) = frame.colDir;
  geom.direction.col(2) = axis.direction;
  geom.validate();

  Volume volume = readPixels(slices, geom, quiet, directory, report, progress);
  if (axis.regularStep > 0) {
    std::vector<double> keys;
    for (const SliceHeader& h : slices) keys.push_back(h.key);
    volume = regularizeSlices(volume, keys, axis.regularStep);
  }
  report.slices = volume.dims().z();
  if (reportOut) *reportOut = std::move(report);
  return volume;
}

// --- The child process -------------------------------------------------------------------------
//
// The child runs readDicomSeriesInProcess() and writes frames to a pipe: [kind u8][length u64][bytes].
// Progress frames as it goes, then either one failure frame (the handson::Error message) or one
// result frame (report and geometry) followed by the voxel bytes. The parent reads until the pipe
// closes, then reaps the child: a child killed by a signal, or one that ended without a result,
// is reported as DicomParserAborted.
namespace {

enum class FrameKind : std::uint8_t { Progress = 1, Failure = 2, Result = 3 };

void writeSeriesInfo(bin::Writer& w, const DicomSeriesInfo& s) {
  w.string(s.seriesInstanceUid);
  w.string(s.description);
  w.pod(std::int32_t(s.fileCount));
}

DicomSeriesInfo readSeriesInfo(bin::Reader& r) {
  DicomSeriesInfo s;
  s.seriesInstanceUid = r.string();
  s.description = r.string();
  s.fileCount = r.pod<std::int32_t>();
  return s;
}

std::string encodeResult(const DicomReadReport& report, const Volume& volume) {
  std::ostringstream os(std::ios::binary);
  bin::Writer w{os};
  w.pod(std::uint64_t(report.seriesFound.size()));
  for (const DicomSeriesInfo& s : report.seriesFound) writeSeriesInfo(w, s);
  writeSeriesInfo(w, report.chosen);
  w.pod(std::int32_t(report.slices));
  w.pod(report.sliceStepMm);
  w.pod(std::uint8_t(report.spacingGaps));
  w.pod(report.minStepMm);
  w.pod(report.maxStepMm);
  w.string(report.transferSyntax);
  w.pod(std::uint64_t(report.warnings.size()));
  for (const std::string& s : report.warnings) w.string(s);
  const VolumeGeometry& g = volume.geometry();
  w.pod(g.dims);
  w.pod(g.spacing);
  w.pod(g.origin);
  w.pod(g.direction);
  w.pod(std::uint8_t(volume.type()));
  return os.str();
}

struct DecodedResult {
  DicomReadReport report;
  VolumeGeometry geometry;
  ScalarType type = ScalarType::Int16;
};

DecodedResult decodeResult(const std::string& payload) {
  std::istringstream is(payload, std::ios::binary);
  bin::Reader r{is, payload.size()};
  DecodedResult out;
  const auto series = r.pod<std::uint64_t>();
  for (std::uint64_t k = 0; k < series; ++k) out.report.seriesFound.push_back(readSeriesInfo(r));
  out.report.chosen = readSeriesInfo(r);
  out.report.slices = r.pod<std::int32_t>();
  out.report.sliceStepMm = r.pod<double>();
  out.report.spacingGaps = r.pod<std::uint8_t>() != 0;
  out.report.minStepMm = r.pod<double>();
  out.report.maxStepMm = r.pod<double>();
  out.report.transferSyntax = r.string();
  const auto warnings = r.pod<std::uint64_t>();
  for (std::uint64_t k = 0; k < warnings; ++k) out.report.warnings.push_back(r.string());
  out.geometry.dims = r.pod<Eigen::Vector3i>();
  out.geometry.spacing = r.pod<Eigen::Vector3d>();
  out.geometry.origin = r.pod<Eigen::Vector3d>();
  out.geometry.direction = r.pod<Eigen::Matrix3d>();
  const auto type = r.pod<std::uint8_t>();
  if (type > std::uint8_t(ScalarType::Float32)) throw Error("DICOM reader: corrupt result from its child process");
  out.type = ScalarType(type);
  return out;
}

int runChild(ChildWriter& out, const std::string& directory, const std::string& seriesOf) {
  try {
    DicomReadReport report;
    const Volume volume = readDicomSeriesInProcess(directory, &report, [&out](double fraction, const std::string& stage) {
      std::ostringstream os(std::ios::binary);
      bin::Writer w{os};
      w.pod(fraction);
      w.string(stage);
      out.frame(std::uint8_t(FrameKind::Progress), os.str());
    }, seriesOf);
    if (!out.frame(std::uint8_t(FrameKind::Result), encodeResult(report, volume)) || !out.raw(volume.bytes(), volume.byteSize())) return 3;
  } catch (const std::exception& e) {
    const bool ours = dynamic_cast<const Error*>(&e) != nullptr;
    out.frame(std::uint8_t(FrameKind::Failure), ours ? std::string(e.what()) : std::string("DICOM reader failed: ") + e.what());
  } catch (...) {
    out.frame(std::uint8_t(FrameKind::Failure), "DICOM reader failed with an unknown exception");
  }
  return 0;
}

}  // namespace

Volume readDicomSeries(const std::string& directory, DicomReadReport* reportOut, const ProgressFn& progress, const std::string& seriesOf) {
  std::optional<std::string> failure;
  std::optional<DecodedResult> result;
  Volume volume;
  bool volumeComplete = false;
  const ChildEnd end = runInChild([&](ChildWriter& w) { return runChild(w, directory, seriesOf); },
                                  [&](ChildReader& r) {
                                    std::uint8_t kind = 0;
                                    std::string payload;
                                    while (r.frame(kind, payload)) {
                                      if (kind == std::uint8_t(FrameKind::Progress)) {
                                        std::istringstream is(payload, std::ios::binary);
                                        bin::Reader br{is, payload.size()};
                                        const double fraction = br.pod<double>();
                                        reportProgress(progress, fraction, br.string());
                                      } else if (kind == std::uint8_t(FrameKind::Failure)) {
                                        failure = payload;
                                      } else if (kind == std::uint8_t(FrameKind::Result)) {
                                        result = decodeResult(payload);
                                        volume = Volume(result->geometry, result->type);  // checks the allocation first
                                        volumeComplete = r.raw(volume.bytes(), volume.byteSize());
                                        return;
                                      } else {
                                        return;
                                      }
                                    }
                                  },
                                  0.0, "cannot read DICOM series in '" + directory + "'");
  if (end.signal) {
    throw DicomParserAborted("cannot read DICOM series in '" + directory +
                                 "': GDCM, the DICOM library, stopped on a malformed file (" + signalName(end.signal) +
                                 "); the series cannot be read: check its files with a DICOM validator or export "
                                 "them again",
                             end.signal);
  }
  if (failure) throw Error(*failure);
  if (!result || !volumeComplete || end.exitCode != 0)
    throw DicomParserAborted("cannot read DICOM series in '" + directory + "': the reader process ended without a result (exit status " +
                                 std::to_string(end.exitCode) + ")",
                             0);
  if (reportOut) *reportOut = std::move(result->report);
  return volume;
}

}  // namespace handson
