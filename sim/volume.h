#pragma once
// A scalar 3D image in the style of ITK's Image: an extent (voxel counts), a spacing (mm), an origin
// (the physical position of voxel (0,0,0)'s centre) and a direction matrix whose columns are the
// physical directions of the i, j and k axes. Physical coordinates are NIfTI world coordinates
// (RAS+, millimetres).
//
//   world = origin + direction * diag(spacing) * index          (index may be fractional)
//
// Values keep the file's type (uint8 labels, int16 Hounsfield units, float32 otherwise) and are
// stored x-fastest: linear = i + nx * (j + ny * k).
#include <Eigen/Core>
#include <cstddef>
#include <cstdint>
#include <string>
#include <utility>
#include <optional>
#include <vector>

namespace handson {

enum class ScalarType : std::uint8_t { UInt8, Int16, Float32 };

const char* scalarTypeName(ScalarType t);
std::size_t scalarTypeSize(ScalarType t);

/// Placement of a voxel grid in physical space.
struct VolumeGeometry {
  Eigen::Vector3i dims{0, 0, 0};
  Eigen::Vector3d spacing{1, 1, 1};
  Eigen::Vector3d origin{0, 0, 0};
  Eigen::Matrix3d direction = Eigen::Matrix3d::Identity();

  std::size_t voxelCount() const;
  /// 4x4 affine taking homogeneous voxel index to world (mm).
  Eigen::Matrix4d indexToWorld() const;
  /// Inverse of indexToWorld(). Throws handson::Error if the direction is singular.
  Eigen::Matrix4d worldToIndex() const;
  Eigen::Vector3d toWorld(const Eigen::Vector3d& index) const;
  Eigen::Vector3d toIndex(const Eigen::Vector3d& world) const;
  bool contains(const Eigen::Vector3i& index) const;
  /// The same voxels in space: equal dims, spacing within 1e-3 and origin within 1e-2 of the
  /// smallest spacing, directions within 1e-4 (masks and label maps written beside an image).
  bool sameGrid(const VolumeGeometry& other) const;
  /// Voxel index of a linear (x-fastest) index.
  Eigen::Vector3i voxelOf(std::size_t linear) const {
    const std::size_t nx = std::size_t(dims.x()), ny = std::size_t(dims.y());
    return {int(linear % nx), int((linear / nx) % ny), int(linear / (nx * ny))};
  }
  /// Physical centre of the grid (midpoint of the first and last voxel centres).
  Eigen::Vector3d center() const;
  /// Length of the grid's bounding box diagonal in mm (voxel edges included).
  double diagonalMm() const;
  /// Throws handson::Error if dims, spacing or direction are unusable (zero, NaN, singular...).
  void validate() const;
};

/// Upper bound on voxels we accept in one volume (2^31, ~4 GiB as int16). Larger is refused.
constexpr std::size_t kMaxVoxels = std::size_t{1} << 31;

/// What this process may still allocate: the least of 80 % of physical memory, the memory the
/// system has available now (MemAvailable), a container's cgroup limit less its usage, and the
/// HANDSON_MEMORY_LIMIT_MB environment variable (a user's cap on a shared machine).
struct MemoryBudget {
  double bytes = 1e300;
  std::string limitedBy = "no limit found";  ///< which of the above is the least
};
MemoryBudget memoryBudget();

/// Throws handson::Error if `bytes` exceed memoryBudget() (naming the limit and what to do) or
/// `voxels` exceeds kMaxVoxels: a volume larger than memory is refused before it is allocated,
/// never swapped to a standstill or killed for memory. `what` names the request.
void checkAllocation(std::size_t voxels, std::size_t bytes, const std::string& what);

class Volume {
 public:
  Volume() = default;
  /// Zero-filled volume. Throws handson::Error on invalid geometry or an impossible allocation.
  Volume(const VolumeGeometry& geometry, ScalarType type);

  const VolumeGeometry& geometry() const { return geometry_; }
  VolumeGeometry& geometry() { return geometry_; }
  const Eigen::Vector3i& dims() const { return geometry_.dims; }
  std::size_t voxelCount() const { return geometry_.voxelCount(); }
  ScalarType type() const { return type_; }
  bool empty() const { return storage_.empty(); }

  std::size_t linearIndex(int i, int j, int k) const {
    return static_cast<std::size_t>(i) +
           static_cast<std::size_t>(geometry_.dims.x()) *
               (static_cast<std::size_t>(j) + static_cast<std::size_t>(geometry_.dims.y()) * static_cast<std::size_t>(k));
  }

  /// Value at a voxel as float, whatever the stored type. No bounds check.
  float value(std::size_t linear) const;
  float value(int i, int j, int k) const { return value(linearIndex(i, j, k)); }
  /// Stores v (rounded and clamped for integer types). No bounds check.
  void setValue(std::size_t linear, float v);
  void setValue(int i, int j, int k, float v) { setValue(linearIndex(i, j, k), v); }
  /// Value with indices clamped to the grid (edge extension).
  float valueClamped(int i, int j, int k) const;
  /// Trilinear interpolation at a fractional index, clamped to the grid.
  float sampleLinear(const Eigen::Vector3d& index) const;

  /// Typed access. Throws handson::Error if T does not match type().
  template <class T> T* data();
  template <class T> const T* data() const;
  std::byte* bytes() { return storage_.data(); }
  const std::byte* bytes() const { return storage_.data(); }
  std::size_t byteSize() const { return storage_.size(); }

  /// (min, max) over all voxels; NaN voxels are ignored. (0,0) for an empty volume.
  std::pair<float, float> valueRange() const;

 private:
  VolumeGeometry geometry_;
  ScalarType type_ = ScalarType::Float32;
  std::vector<std::byte> storage_;
};

template <class T> constexpr ScalarType scalarTypeOf();
template <> constexpr ScalarType scalarTypeOf<std::uint8_t>() { return ScalarType::UInt8; }
template <> constexpr ScalarType scalarTypeOf<std::int16_t>() { return ScalarType::Int16; }
template <> constexpr ScalarType scalarTypeOf<float>() { return ScalarType::Float32; }

/// Linear indices of the voxels whose value equals `label` (a label map's organ), in order.
std::vector<std::uint32_t> voxelsLabelled(const Volume& labels, double label);

/// The voxel whose centre is nearest `world` (RAS mm), if it lies in the grid; nullopt for a point
/// outside it or a non-finite one.
inline std::optional<Eigen::Vector3i> nearestVoxel(const VolumeGeometry& g, const Eigen::Vector3d& world) {
  const Eigen::Vector3d idx = g.toIndex(world).array().round();
  if (!idx.allFinite() || (idx.array().abs() > 1e9).any()) return std::nullopt;
  const Eigen::Vector3i v = idx.cast<int>();
  if (!g.contains(v)) return std::nullopt;
  return v;
}

/// The linear (x-fastest) index of a voxel in the grid.
inline std::size_t linearIndex(const VolumeGeometry& g, const Eigen::Vector3i& v) {
  return std::size_t(v.x()) + std::size_t(g.dims.x()) * (std::size_t(v.y()) + std::size_t(g.dims.y()) * std::size_t(v.z()));
}


}  // namespace handson
