#include "volume.h"

#include <unistd.h>

#include <Eigen/LU>
#include <algorithm>
#include <cmath>
#include <limits>
#include <cstdlib>
#include <fstream>
#include <iomanip>
#include <optional>
#include <sstream>

#include "sim/base/error.h"

namespace handson {

const char* scalarTypeName(ScalarType t) {
  switch (t) {
    case ScalarType::UInt8: return "uint8";
    case ScalarType::Int16: return "int16";
    case ScalarType::Float32: return "float32";
  }
  return "?";
}

std::size_t scalarTypeSize(ScalarType t) {
  switch (t) {
    case ScalarType::UInt8: return 1;
    case ScalarType::Int16: return 2;
    case ScalarType::Float32: return 4;
  }
  return 0;
}

std::size_t VolumeGeometry::voxelCount() const {
  if (dims.x() <= 0 || dims.y() <= 0 || dims.z() <= 0) return 0;
  return static_cast<std::size_t>(dims.x()) * static_cast<std::size_t>(dims.y()) * static_cast<std::size_t>(dims.z());
}

Eigen::Matrix4d VolumeGeometry::indexToWorld() const {
  Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
  m.block<3, 3>(0, 0) = direction * spacing.asDiagonal();
  m.block<3, 1>(0, 3) = origin;
  return m;
}

Eigen::Matrix4d VolumeGeometry::worldToIndex() const {
  const Eigen::Matrix3d a = direction * spacing.asDiagonal();
  const double det = a.determinant();
  if (!std::isfinite(det) || std::abs(det) < 1e-12) throw Error("volume orientation matrix is singular");
  Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
  const Eigen::Matrix3d inv = a.inverse();
  m.block<3, 3>(0, 0) = inv;
  m.block<3, 1>(0, 3) = -inv * origin;
  return m;
}

Eigen::Vector3d VolumeGeometry::toWorld(const Eigen::Vector3d& index) const {
  return origin + direction * spacing.cwiseProduct(index);
}

Eigen::Vector3d VolumeGeometry::toIndex(const Eigen::Vector3d& world) const {
  const Eigen::Matrix3d a = direction * spacing.asDiagonal();
  return a.partialPivLu().solve(world - origin);
}

bool VolumeGeometry::contains(const Eigen::Vector3i& index) const {
  return (index.array() >= 0).all() && (index.array() < dims.array()).all();
}

bool VolumeGeometry::sameGrid(const VolumeGeometry& o) const {
  return dims == o.dims && (spacing - o.spacing).cwiseAbs().maxCoeff() <= 1e-3 * o.spacing.minCoeff() &&
         (origin - o.origin).norm() <= 1e-2 * o.spacing.minCoeff() && (direction - o.direction).cwiseAbs().maxCoeff() <= 1e-4;
}

Eigen::Vector3d VolumeGeometry::center() const {
  return toWorld(0.5 * (dims.cast<double>() - Eigen::Vector3d::Ones()));
}

double VolumeGeometry::diagonalMm() const {
  return (dims.cast<double>().cwiseProduct(spacing)).norm();
}

void VolumeGeometry::validate() const {
  std::ostringstream msg;
  if ((dims.array() <= 0).any()) {
    msg << "invalid volume dimensions " << dims.x() << "x" << dims.y() << "x" << dims.z() << " (each must be >= 1)";
    throw Error(msg.str());
  }
  const double count = double(dims.x()) * double(dims.y()) * double(dims.z());
  if (count > double(kMaxVoxels)) {
    msg << "volume of " << dims.x() << "x" << dims.y() << "x" << dims.z() << " voxels is larger than the supported "
        << kMaxVoxels << " voxels";
    throw Error(msg.str());
  }
  for (int a = 0; a < 3; ++a) {
    if (!std::isfinite(spacing[a]) || spacing[a] <= 0.0 || spacing[a] > 1e6) {
      msg << "invalid voxel spacing " << spacing.transpose() << " mm (each must be finite and > 0)";
      throw Error(msg.str());
    }
  }
  if (!origin.allFinite()) throw Error("volume origin is not finite");
  if (!direction.allFinite() || std::abs(direction.determinant()) < 1e-6)
    throw Error("volume direction matrix is singular or not finite");
}

namespace {

/// A number of bytes from the first line of a file ("max" and unreadable files: none).
std::optional<double> readBytesFile(const char* path) {
  std::ifstream in(path);
  std::string word;
  if (!(in >> word) || word == "max") return std::nullopt;
  try {
    std::size_t used = 0;
    const double v = std::stod(word, &used);
    return used == word.size() && v >= 0 ? std::optional<double>(v) : std::nullopt;
  } catch (const std::exception&) {
    return std::nullopt;
  }
}

/// MemAvailable from /proc/meminfo, in bytes.
std::optional<double> memAvailable() {
  std::ifstream in("/proc/meminfo");
  std::string key;
  double kib = 0;
  std::string unit;
  while (in >> key >> kib >> unit)
    if (key == "MemAvailable:") return kib * 1024.0;
  return std::nullopt;
}

std::string mib(double bytes) {
  std::ostringstream s;
  s << std::fixed << std::setprecision(0) << bytes / double(1u << 20) << " MiB";
  return s.str();
}

}  // namespace

MemoryBudget memoryBudget() {
  MemoryBudget b;
  auto limit = [&](double bytes, const std::string& what) {
    if (bytes < b.bytes) {
      b.bytes = bytes;
      b.limitedBy = what;
    }
  };
  const long pages = sysconf(_SC_PHYS_PAGES), pageSize = sysconf(_SC_PAGE_SIZE);
  if (pages > 0 && pageSize > 0) limit(0.8 * double(pages) * double(pageSize), "80 % of this machine's physical memory");
  if (const auto avail = memAvailable()) limit(*avail, "the memory available now (MemAvailable)");
  // A container's memory limit (cgroup v2), less what the group already uses.
  if (const auto max = readBytesFile("/sys/fs/cgroup/memory.max")) {
    const double used = readBytesFile("/sys/fs/cgroup/memory.current").value_or(0.0);
    limit(std::max(0.0, *max - used), "the container's memory limit (cgroup memory.max)");
  }
  if (const char* env = std::getenv("HANDSON_MEMORY_LIMIT_MB"); env && *env) {
    char* end = nullptr;
    const double mb = std::strtod(env, &end);
    if (end && *end == '\0' && mb > 0 && std::isfinite(mb)) limit(mb * double(1u << 20), "HANDSON_MEMORY_LIMIT_MB");
  }
  return b;
}

void checkAllocation(std::size_t voxels, std::size_t bytes, const std::string& what) {
  if (voxels > kMaxVoxels) {
    std::ostringstream msg;
    msg << what << ": " << voxels << " voxels exceeds the supported maximum of " << kMaxVoxels;
    throw Error(msg.str());
  }
  const MemoryBudget budget = memoryBudget();
  if (double(bytes) > budget.bytes)
    throw Error(what + ": needs " + mib(double(bytes)) + ", more than the " + mib(budget.bytes) + " this process may use (" +
                budget.limitedBy + "); resample the volume to fewer voxels (handson resample --voxels N) or free memory");
}

Volume::Volume(const VolumeGeometry& geometry, ScalarType type) : geometry_(geometry), type_(type) {
  geometry_.validate();
  const std::size_t n = geometry_.voxelCount();
  const std::size_t bytes = n * scalarTypeSize(type);
  checkAllocation(n, bytes, "volume allocation");
  storage_.assign(bytes, std::byte{0});
}

float Volume::value(std::size_t linear) const {
  switch (type_) {
    case ScalarType::UInt8: return float(reinterpret_cast<const std::uint8_t*>(storage_.data())[linear]);
    case ScalarType::Int16: return float(reinterpret_cast<const std::int16_t*>(storage_.data())[linear]);
    case ScalarType::Float32: return reinterpret_cast<const float*>(storage_.data())[linear];
  }
  return 0.0f;
}

void Volume::setValue(std::size_t linear, float v) {
  switch (type_) {
    case ScalarType::UInt8: {
      const float c = std::isfinite(v) ? std::clamp(std::nearbyint(v), 0.0f, 255.0f) : 0.0f;
      reinterpret_cast<std::uint8_t*>(storage_.data())[linear] = static_cast<std::uint8_t>(c);
      return;
    }
    case ScalarType::Int16: {
      const float c = std::isfinite(v) ? std::clamp(std::nearbyint(v), -32768.0f, 32767.0f) : 0.0f;
      reinterpret_cast<std::int16_t*>(storage_.data())[linear] = static_cast<std::int16_t>(c);
      return;
    }
    case ScalarType::Float32: reinterpret_cast<float*>(storage_.data())[linear] = v; return;
  }
}

float Volume::valueClamped(int i, int j, int k) const {
  i = std::clamp(i, 0, geometry_.dims.x() - 1);
  j = std::clamp(j, 0, geometry_.dims.y() - 1);
  k = std::clamp(k, 0, geometry_.dims.z() - 1);
  return value(i, j, k);
}

float Volume::sampleLinear(const Eigen::Vector3d& index) const {
  const Eigen::Vector3d p = index.cwiseMax(Eigen::Vector3d::Zero()).cwiseMin((geometry_.dims.cast<double>().array() - 1.0).matrix());
  const int i0 = int(std::floor(p.x())), j0 = int(std::floor(p.y())), k0 = int(std::floor(p.z()));
  const double fx = p.x() - i0, fy = p.y() - j0, fz = p.z() - k0;
  double acc = 0.0;
  for (int dz = 0; dz < 2; ++dz)
    for (int dy = 0; dy < 2; ++dy)
      for (int dx = 0; dx < 2; ++dx) {
        const double w = (dx ? fx : 1 - fx) * (dy ? fy : 1 - fy) * (dz ? fz : 1 - fz);
        if (w != 0.0) acc += w * valueClamped(i0 + dx, j0 + dy, k0 + dz);
      }
  return float(acc);
}

template <class T> T* Volume::data() {
  if (scalarTypeOf<T>() != type_) throw Error(std::string("volume holds ") + scalarTypeName(type_) + " values");
  return reinterpret_cast<T*>(storage_.data());
}
template <class T> const T* Volume::data() const {
  if (scalarTypeOf<T>() != type_) throw Error(std::string("volume holds ") + scalarTypeName(type_) + " values");
  return reinterpret_cast<const T*>(storage_.data());
}
template std::uint8_t* Volume::data<std::uint8_t>();
template std::int16_t* Volume::data<std::int16_t>();
template float* Volume::data<float>();
template const std::uint8_t* Volume::data<std::uint8_t>() const;
template const std::int16_t* Volume::data<std::int16_t>() const;
template const float* Volume::data<float>() const;

std::pair<float, float> Volume::valueRange() const {
  const std::size_t n = voxelCount();
  if (storage_.empty() || n == 0) return {0.0f, 0.0f};
  float lo = std::numeric_limits<float>::infinity(), hi = -lo;
  for (std::size_t i = 0; i < n; ++i) {
    const float v = value(i);
    if (std::isnan(v)) continue;
    lo = std::min(lo, v);
    hi = std::max(hi, v);
  }
  if (lo > hi) return {0.0f, 0.0f};
  return {lo, hi};
}

std::vector<std::uint32_t> voxelsLabelled(const Volume& labels, double label) {
  std::vector<std::uint32_t> out;
  for (std::size_t i = 0; i < labels.voxelCount(); ++i)
    if (labels.value(i) == label) out.push_back(std::uint32_t(i));
  return out;
}

}  // namespace handson
