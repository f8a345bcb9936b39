#include "volume_import.h"

#include <cmath>
#include <cstdint>
#include <string>

#include "app/io/volume_io.h"
#include "sim/base/error.h"

namespace handson {

VolumeGeometry geometryFromAxes(const Eigen::Matrix3d& axes, const Eigen::Vector3d& origin, const Eigen::Vector3i& dims) {
  if (!axes.allFinite() || !origin.allFinite()) throw Error("its axes or origin are not finite");
  VolumeGeometry g;
  g.dims = dims;
  for (int c = 0; c < 3; ++c) {
    const double n = axes.col(c).norm();
    if (!(n > 0)) throw Error("axis " + std::to_string(c + 1) + " has zero length");
    g.spacing[c] = n;
    g.direction.col(c) = axes.col(c) / n;
  }
  g.origin = origin;
  g.validate();
  return g;
}

Volume volumeFromValues(const VolumeGeometry& g, bool uint8, bool integral, const std::function<double(std::size_t)>& value) {
  const std::size_t count = g.voxelCount();
  if (uint8) {
    Volume v(g, ScalarType::UInt8);
    for (std::size_t i = 0; i < count; ++i) v.data<std::uint8_t>()[i] = std::uint8_t(value(i));
    return v;
  }
  bool fitsInt16 = integral;
  for (std::size_t i = 0; fitsInt16 && i < count; ++i) {
    const double x = value(i);
    fitsInt16 = x >= -32768.0 && x <= 32767.0;
  }
  Volume v(g, fitsInt16 ? ScalarType::Int16 : ScalarType::Float32);
  for (std::size_t i = 0; i < count; ++i) {
    const double x = value(i);
    if (fitsInt16) v.data<std::int16_t>()[i] = std::int16_t(x);
    else v.data<float>()[i] = std::isfinite(x) && std::abs(x) > 3.4e38 ? float(std::copysign(3.4e38, x)) : float(x);
  }
  return v;
}

void reportFrames(LoadReport& report, const std::string& path, std::int64_t frames, std::int64_t frame) {
  report.frames = frames;
  report.frame = frame;
  if (frames > 1)
    report.warnings.push_back("'" + path + "' holds " + std::to_string(frames) + " volumes; volume " + std::to_string(frame) +
                              " is loaded (choose another with --frame N)");
}

}  // namespace handson
