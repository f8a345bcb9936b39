#include "metaimage_io.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <vector>

#include "app/volume_import.h"
#include "sim/error.h"
#ifdef HANDSON_HAVE_ITK
#include "app/metaimage_itk.h"
#endif

namespace handson {

namespace {

[[noreturn]] void fail(const std::string& path, const std::string& what) { throw Error("Cannot read MetaImage file '" + path + "': " + what); }

}  // namespace

#ifndef HANDSON_HAVE_ITK
Volume readMetaImage(const std::string& path, std::int64_t, MetaImageInfo*) {
  fail(path, "this build has no MetaImage support (ITK's headers, which it needs, build with GCC only; this is a clang build)");
}
#else
namespace {

template <class T> double load(const std::vector<char>& b, std::size_t i) {
  T v;
  std::memcpy(&v, b.data() + i * sizeof(T), sizeof(T));
  return double(v);
}

double valueAt(metaio::Component type, const std::vector<char>& b, std::size_t i) {
  using C = metaio::Component;
  switch (type) {
    case C::Int8: return load<std::int8_t>(b, i);
    case C::UInt8: return load<std::uint8_t>(b, i);
    case C::Int16: return load<std::int16_t>(b, i);
    case C::UInt16: return load<std::uint16_t>(b, i);
    case C::Int32: return load<std::int32_t>(b, i);
    case C::UInt32: return load<std::uint32_t>(b, i);
    case C::Int64: return load<std::int64_t>(b, i);
    case C::UInt64: return load<std::uint64_t>(b, i);
    case C::Float32: return load<float>(b, i);
    case C::Float64: return load<double>(b, i);
    default: return std::nan("");
  }
}

// The grid: ITK's LPS to RAS+ (x and y negated); a 2D image is one slice thick.
VolumeGeometry geometryOf(const metaio::Header& h, const std::string& path) {
  VolumeGeometry g;
  Eigen::Matrix3d a = Eigen::Matrix3d::Zero();
  Eigen::Vector3d origin = Eigen::Vector3d::Zero();
  const unsigned spatial = std::min(h.dimensions, 3u);
  for (unsigned c = 0; c < spatial; ++c) {
    if (h.size[c] > std::uint64_t(std::numeric_limits<int>::max())) fail(path, "an axis is too large");
    g.dims[c] = int(h.size[c]);
    for (unsigned r = 0; r < spatial && r < h.direction[c].size(); ++r) a(r, c) = h.direction[c][r] * h.spacing[c];
    origin[c] = h.origin[c];
  }
  if (spatial == 2) {
    g.dims.z() = 1;
    a.col(2) = Eigen::Vector3d(a.col(0)).cross(Eigen::Vector3d(a.col(1))).normalized();
  }
  const Eigen::Vector3d flip(-1, -1, 1);
  try {
    return geometryFromAxes(flip.asDiagonal() * a, flip.cwiseProduct(origin), g.dims);
  } catch (const Error& e) {
    fail(path, e.what());
  }
}

}  // namespace

Volume readMetaImage(const std::string& path, std::int64_t frame, MetaImageInfo* info) {
  metaio::Header h;
  std::string error;
  if (!metaio::readHeader(path, h, error)) fail(path, error);
  if (h.dimensions < 2 || h.dimensions > 4) fail(path, std::to_string(h.dimensions) + " dimensions: only 2D, 3D and 4D images can be read");
  if (h.components != 1) fail(path, std::to_string(h.components) + " components per pixel: only scalar images can be read");
  if (h.component == metaio::Component::Other || h.componentBytes == 0 || h.componentBytes > 8) fail(path, "an unsupported pixel type");
  const std::int64_t frames = h.dimensions == 4 ? std::int64_t(std::min<std::uint64_t>(h.size[3], std::uint64_t(1) << 40)) : 1;
  if (frame < 0 || frame >= frames)
    fail(path, "volume " + std::to_string(frame) + " was asked for, but the image holds " + std::to_string(frames) + " volume" +
                   (frames == 1 ? "" : "s") + (frames > 1 ? " (--frame takes 0 to " + std::to_string(frames - 1) + ")" : ""));
  const VolumeGeometry g = geometryOf(h, path);
  const std::size_t count = g.voxelCount();
  const double bytes = double(count) * double(frames) * double(h.componentBytes);
  try {
    checkAllocation(count, std::size_t(std::min(bytes, 1e18)), "the MetaImage");
  } catch (const Error& e) {
    fail(path, e.what());
  }
  // The data: all volumes (MetaIO reads the whole image), the chosen one kept.
  std::vector<char> buffer(static_cast<std::size_t>(bytes));
  if (!metaio::readData(path, h, buffer.data(), error)) fail(path, error);
  if (info) info->frames = frames;
  const std::size_t base = std::size_t(frame) * count;
  return volumeFromValues(g, h.component == metaio::Component::UInt8,
                          h.component != metaio::Component::Float32 && h.component != metaio::Component::Float64,
                          [&](std::size_t i) { return valueAt(h.component, buffer, base + i); });
}
#endif

}  // namespace handson
