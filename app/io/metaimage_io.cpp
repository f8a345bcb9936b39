#include "metaimage_io.h"

#include <metaImage.h>
#include <metaUtils.h>
#include <zlib.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <cctype>
#include <cerrno>
#include <cstdio>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <limits>
#include <sstream>
#include <vector>

#include "sim/base/atomic_file.h"
#include "app/io/isolated_call.h"
#include "app/io/volume_import.h"
#include "sim/base/binary_io.h"
#include "sim/base/error.h"

namespace handson {

namespace {

[[noreturn]] void fail(const std::string& path, const std::string& what) { throw Error("Cannot read MetaImage file '" + path + "': " + what); }

// MetaIO reports problems on std::cerr; while one of these lives, what it writes is kept for our
// message instead. (std::cerr is process-wide: a line another thread writes meanwhile lands here.)
class CerrCapture {
 public:
  CerrCapture() : old_(std::cerr.rdbuf(text_.rdbuf())) {}
  ~CerrCapture() { std::cerr.rdbuf(old_); }
  CerrCapture(const CerrCapture&) = delete;
  CerrCapture& operator=(const CerrCapture&) = delete;
  /// The lines written so far, joined with "; ".
  std::string text() const {
    std::string s = text_.str(), out;
    std::istringstream lines(s);
    for (std::string line; std::getline(lines, line);) {
      while (!line.empty() && std::isspace(static_cast<unsigned char>(line.back()))) line.pop_back();
      if (!line.empty()) out += (out.empty() ? "" : "; ") + line;
    }
    return out;
  }

 private:
  std::ostringstream text_;
  std::streambuf* old_;
};

// What the reader needs of a header, as MetaIO parsed it (in a child process: MetaIO 5.2 loops for
// ever on a negative NDims and overflows a buffer on a field name over 255 characters, both found
// by fuzzing, and guarding each from outside does not end).
struct Header {
  int nDims = 0;
  std::array<int, 4> dims{};
  std::array<double, 4> spacing{}, position{};
  std::array<double, 16> transform{};  // [4 c + r]: component r of axis c's direction
  int type = MET_NONE, channels = 1, headerSize = 0;
  bool msb = false, compressed = false;
  std::int64_t headerEnd = 0;  // where LOCAL data begin
  std::string dataFile;
};

std::string encodeHeader(const Header& h) {
  std::ostringstream os(std::ios::binary);
  bin::Writer w{os};
  w.pod(h.nDims);
  w.pod(h.dims);
  w.pod(h.spacing);
  w.pod(h.position);
  w.pod(h.transform);
  w.pod(h.type);
  w.pod(h.channels);
  w.pod(h.headerSize);
  w.pod(h.msb);
  w.pod(h.compressed);
  w.pod(h.headerEnd);
  w.string(h.dataFile);
  return os.str();
}

Header decodeHeader(const std::string& payload) {
  std::istringstream is(payload, std::ios::binary);
  bin::Reader r{is, payload.size()};
  Header h;
  h.nDims = r.pod<int>();
  h.dims = r.pod<std::array<int, 4>>();
  h.spacing = r.pod<std::array<double, 4>>();
  h.position = r.pod<std::array<double, 4>>();
  h.transform = r.pod<std::array<double, 16>>();
  h.type = r.pod<int>();
  h.channels = r.pod<int>();
  h.headerSize = r.pod<int>();
  h.msb = r.pod<bool>();
  h.compressed = r.pod<bool>();
  h.headerEnd = r.pod<std::int64_t>();
  h.dataFile = r.string();
  return h;
}

// MetaIO sizes the header's arrays by NDims and loops for ever on a negative one: each NDims line
// (up to ElementDataFile, which ends the header; "=" or ":" after the name, as MetaIO reads it) must
// give 1 to 10, MetaIO's own limit, before MetaIO sees the file - a clear message at once rather
// than the child process's time-out.
void checkDimensionCount(const std::string& path) {
  // A header is text of a few kilobytes: the first MiB is looked at, no more.
  std::ifstream in(path, std::ios::binary);
  std::string head(std::size_t{1} << 20, '\0');
  in.read(head.data(), std::streamsize(head.size()));
  head.resize(std::size_t(std::max<std::streamsize>(0, in.gcount())));
  std::istringstream lines(head);
  for (std::string line; std::getline(lines, line);) {
    const std::size_t sep = line.find_first_of("=:");
    if (sep == std::string::npos) continue;
    std::string key = line.substr(0, sep);
    key.erase(0, std::min(key.size(), key.find_first_not_of(" \t\r")));
    while (!key.empty() && std::isspace(static_cast<unsigned char>(key.back()))) key.pop_back();
    if (key == "ElementDataFile") return;
    if (key != "NDims") continue;
    const std::string value = line.substr(sep + 1);
    char* end = nullptr;
    const long n = std::strtol(value.c_str(), &end, 10);
    if (end == value.c_str() || n < 1 || n > 10) fail(path, "NDims =" + value.substr(0, 40) + " (1 to 10 dimensions)");
  }
}

// Runs in the child: MetaIO parses the header (the data are read by the parent).
Header parseHeader(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) fail(path, "it cannot be opened");
  MetaImage m;
  std::string messages;
  bool ok = false;
  {
    CerrCapture capture;
    ok = m.ReadStream(0, &in, false);
    messages = capture.text();
  }
  if (!ok) fail(path, messages.empty() ? "MetaIO could not parse its header" : messages);
  Header h;
  h.headerEnd = std::int64_t(in.tellg());
  if (h.headerEnd < 0) fail(path, "its header does not end");
  h.nDims = m.NDims();
  for (int c = 0; c < std::min(h.nDims, 4); ++c) {
    h.dims[std::size_t(c)] = m.DimSize(c);
    h.spacing[std::size_t(c)] = m.ElementSpacing(c);
    h.position[std::size_t(c)] = m.Position(c);
    for (int r = 0; r < std::min(h.nDims, 4); ++r) h.transform[std::size_t(4 * c + r)] = m.TransformMatrix(c, r);
  }
  h.type = m.ElementType();
  h.channels = m.ElementNumberOfChannels();
  h.headerSize = m.HeaderSize();
  h.msb = m.BinaryDataByteOrderMSB();
  h.compressed = m.CompressedData();
  h.dataFile = m.ElementDataFileName();
  return h;
}

struct Layout {
  int nDims = 0;                 // 2, 3 or 4
  Eigen::Vector3i dims{1, 1, 1};  // the spatial axes (z = 1 for a 2D image)
  std::int64_t channels = 1, frames = 1;
  MET_ValueEnumType type = MET_NONE;
  std::size_t typeSize = 0;
  std::size_t elements = 0;  // in the whole data block: voxels x frames
};

Layout layoutOf(const Header& m, const std::string& path) {
  Layout l;
  l.nDims = m.nDims;
  if (l.nDims < 2 || l.nDims > 4) fail(path, std::to_string(l.nDims) + " dimensions (NDims): only 2D, 3D and 4D images can be read");
  double elements = 1;
  for (int c = 0; c < l.nDims; ++c) {
    const int size = m.dims[std::size_t(c)];
    if (size < 1) fail(path, "DimSize " + std::to_string(size) + " on axis " + std::to_string(c) + " (at least 1 is needed)");
    if (c < 3) l.dims[c] = size;
    elements *= double(size);
  }
  l.channels = m.channels;
  if (l.channels < 1) fail(path, "ElementNumberOfChannels = " + std::to_string(l.channels));
  l.frames = (l.nDims == 4 ? std::int64_t(m.dims[3]) : 1) * l.channels;
  elements *= double(l.channels);
  l.type = MET_ValueEnumType(m.type);
  int size = 0;
  if (l.type < MET_CHAR || l.type > MET_DOUBLE || !MET_SizeOfType(l.type, &size) || size <= 0)
    fail(path, "its ElementType is not a number type (MET_CHAR to MET_DOUBLE are read)");
  l.typeSize = std::size_t(size);
  const std::size_t voxels = std::size_t(l.dims.x()) * std::size_t(l.dims.y()) * std::size_t(l.dims.z());
  try {
    checkAllocation(voxels, std::size_t(std::min(elements * double(size), 1e18)), "the MetaImage image");
  } catch (const Error& e) {
    fail(path, e.what());
  }
  l.elements = std::size_t(elements);
  return l;
}

// RAS+ grid: axis c is ElementSpacing(c) times TransformMatrix's row c, in LPS (x and y negated).
VolumeGeometry geometryOf(const Header& m, const Layout& l, const std::string& path) {
  const int spatial = std::min(l.nDims, 3);
  Eigen::Matrix3d a = Eigen::Matrix3d::Zero();
  Eigen::Vector3d origin = Eigen::Vector3d::Zero();
  for (int c = 0; c < spatial; ++c) {
    for (int r = 0; r < spatial; ++r) a(r, c) = m.transform[std::size_t(4 * c + r)] * m.spacing[std::size_t(c)];
    origin[c] = m.position[std::size_t(c)];
  }
  if (spatial == 2) {
    const Eigen::Vector3d normal = Eigen::Vector3d(a.col(0)).cross(Eigen::Vector3d(a.col(1)));
    a.col(2) = normal.norm() > 0 ? Eigen::Vector3d(normal.normalized()) : Eigen::Vector3d::UnitZ();
  }
  const Eigen::Vector3d lps(-1, -1, 1);
  try {
    return geometryFromAxes(lps.asDiagonal() * a, lps.cwiseProduct(origin) + Eigen::Vector3d::Zero(), l.dims);  // + 0: no -0
  } catch (const Error& e) {
    fail(path, e.what());
  }
}

bool sameText(std::string a, const char* b) {
  std::transform(a.begin(), a.end(), a.begin(), [](unsigned char c) { return char(std::toupper(c)); });
  return a == b;
}

// Inflates a zlib or gzip stream from `in` into exactly `out.size()` bytes.
void inflateExactly(std::ifstream& in, std::vector<unsigned char>& out, const std::string& path) {
  z_stream z{};
  if (inflateInit2(&z, 15 + 32) != Z_OK) fail(path, "zlib could not be initialised");
  std::array<unsigned char, 1 << 16> chunk{};
  z.next_out = out.data();
  z.avail_out = uInt(std::min<std::size_t>(out.size(), std::numeric_limits<uInt>::max()));
  const auto produced = [&] { return std::size_t(z.next_out - out.data()); };
  int rc = Z_OK;
  for (;;) {
    if (z.avail_in == 0) {
      in.read(reinterpret_cast<char*>(chunk.data()), std::streamsize(chunk.size()));
      z.avail_in = uInt(in.gcount());
      z.next_in = chunk.data();
      if (z.avail_in == 0) break;  // the file ended inside the stream
    }
    if (z.avail_out == 0) z.avail_out = uInt(std::min<std::size_t>(out.size() - produced(), std::numeric_limits<uInt>::max()));
    const uInt inBefore = z.avail_in;
    const std::size_t outBefore = produced();
    rc = inflate(&z, Z_NO_FLUSH);
    if (rc == Z_STREAM_END) break;
    if (rc == Z_BUF_ERROR && produced() == out.size() && z.avail_in == inBefore && produced() == outBefore) {
      inflateEnd(&z);  // full, and the stream goes on
      fail(path, "its compressed data hold more than the " + std::to_string(out.size()) + " bytes its header describes");
    }
    if (rc != Z_OK && rc != Z_BUF_ERROR) {
      const std::string why = z.msg ? z.msg : "error " + std::to_string(rc);
      inflateEnd(&z);
      fail(path, "its compressed data do not inflate (" + why + ")");
    }
  }
  const std::size_t got = produced();
  inflateEnd(&z);
  if (rc != Z_STREAM_END || got != out.size())
    fail(path, "its compressed data inflate to " + std::string(rc == Z_STREAM_END ? "" : "at least ") + std::to_string(got) + " bytes, " +
                   std::to_string(out.size()) + " expected" + (rc == Z_STREAM_END ? "" : " (the stream is truncated)"));
}

// The data block: after the header (LOCAL) or in the named file, raw or compressed.
std::vector<unsigned char> readData(const Header& m, const Layout& l, const std::string& path) {
  const std::string& name = m.dataFile;
  std::string file = path;
  std::streamoff start = m.headerEnd;
  if (!sameText(name, "LOCAL")) {
    if (sameText(name.substr(0, std::min<std::size_t>(name.size(), 4)), "LIST") || name.find('%') != std::string::npos)
      fail(path, "its data are a list of slice files (ElementDataFile = " + name + "), which is not read: join them into one file, e.g. with ITK");
    if (name.empty()) fail(path, "it names no data file (ElementDataFile)");
    const std::filesystem::path p(name);
    file = (p.is_absolute() ? p : std::filesystem::path(path).parent_path() / p).string();
    start = m.headerSize > 0 ? std::streamoff(m.headerSize) : 0;
  }
  std::error_code ec;
  if (!std::filesystem::is_regular_file(file, ec)) fail(path, "its data file '" + file + "' is missing or not a regular file");
  std::ifstream in(file, std::ios::binary);
  if (!in) fail(path, "its data file '" + file + "' cannot be opened");
  in.seekg(0, std::ios::end);
  const std::streamoff size = in.tellg();
  const std::size_t bytes = l.elements * l.typeSize;
  if (file != path && m.headerSize == -1 && !m.compressed) start = size - std::streamoff(bytes);  // the data end the file
  if (start < 0 || start > size) fail(path, "its data would start outside the data file '" + file + "'");
  in.seekg(start);
  std::vector<unsigned char> data(bytes);
  if (m.compressed) {
    inflateExactly(in, data, path);
  } else {
    if (size - start < std::streamoff(bytes))
      fail(path, "its data are truncated: " + std::to_string(bytes) + " bytes expected, " + std::to_string(size - start) + " present");
    in.read(reinterpret_cast<char*>(data.data()), std::streamsize(bytes));
    if (in.gcount() != std::streamsize(bytes)) fail(path, "its data could not be read completely");
  }
  if (m.msb && l.typeSize > 1)  // big-endian file, little-endian host
    for (std::size_t i = 0; i < l.elements; ++i) std::reverse(data.begin() + std::ptrdiff_t(i * l.typeSize), data.begin() + std::ptrdiff_t((i + 1) * l.typeSize));
  return data;
}

}  // namespace

Volume readMetaImage(const std::string& path, std::int64_t frame, MetaImageInfo* info) {
  checkDimensionCount(path);
  const Header m = decodeHeader(runIsolated([&] { return encodeHeader(parseHeader(path)); }, 10.0,
                                            "Cannot read MetaImage file '" + path + "' (MetaIO, parsing its header)"));
  const Layout l = layoutOf(m, path);
  const VolumeGeometry g = geometryOf(m, l, path);
  if (frame < 0 || frame >= l.frames)
    fail(path, "volume " + std::to_string(frame) + " was asked for, but the image holds " + std::to_string(l.frames) + " volume" +
                   (l.frames == 1 ? "" : "s") + (l.frames > 1 ? " (--frame takes 0 to " + std::to_string(l.frames - 1) + ")" : ""));
  const std::vector<unsigned char> data = readData(m, l, path);
  if (info) {
    info->frames = l.frames;
    info->dataFile = m.dataFile;
    info->compressed = m.compressed;
  }
  // Frame f is channel f % channels of the fourth axis's sample f / channels.
  const std::size_t voxels = g.voxelCount(), channels = std::size_t(l.channels);
  const std::size_t base = std::size_t(frame) / channels * voxels * channels + std::size_t(frame) % channels;
  const bool real = l.type == MET_FLOAT || l.type == MET_DOUBLE;
  return volumeFromValues(g, l.type == MET_UCHAR, !real, [&](std::size_t i) {
    double v = 0;
    MET_ValueToDouble(l.type, data.data(), std::streamoff(base + i * channels), &v);
    return v;
  });
}

void writeMetaImage(const Volume& volume, const std::string& path) {
  if (volume.empty()) throw Error("Cannot write MetaImage file '" + path + "': the volume is empty");
  AtomicFile out(path);
  const VolumeGeometry& g = volume.geometry();
  const MET_ValueEnumType type = volume.type() == ScalarType::UInt8 ? MET_UCHAR : volume.type() == ScalarType::Int16 ? MET_SHORT : MET_FLOAT;
  const int dims[3] = {g.dims.x(), g.dims.y(), g.dims.z()};
  const double spacing[3] = {g.spacing.x(), g.spacing.y(), g.spacing.z()};
  // MetaIO writes from our buffer without taking it.
  MetaImage m(3, dims, spacing, type, 1, const_cast<std::byte*>(volume.bytes()));
  const Eigen::Vector3d lps(-1, -1, 1);
  for (int c = 0; c < 3; ++c) {
    const Eigen::Vector3d d = lps.cwiseProduct(g.direction.col(c));
    for (int r = 0; r < 3; ++r) m.TransformMatrix(c, r, d[r]);
    m.Position(c, lps[c] * g.origin[c]);
  }
  m.BinaryDataByteOrderMSB(false);
  m.CompressedData(true);
  // MetaIO appends ".mha" to a name without a MetaImage extension: it writes beside the temporary
  // file under that name, moved over it once complete.
  const std::string written = out.tempPath() + ".mha";
  bool ok = false;
  std::string messages;
  {
    CerrCapture capture;
    ok = m.Write(written.c_str(), "LOCAL", true);
    messages = capture.text();
  }
  if (ok && std::rename(written.c_str(), out.tempPath().c_str()) != 0) messages = std::strerror(errno), ok = false;
  if (!ok) {
    std::remove(written.c_str());
    throw Error("Cannot write MetaImage file '" + path + "': " + (messages.empty() ? "MetaIO failed" : messages));
  }
  out.commit();
}

}  // namespace handson
