#pragma once
// The coarse model's fine reconstruction (docs/simulation-model.md) packed for the GPU's
// interpolation pass (shaders/deform_interpolate.comp), and its CPU reference in the same float
// arithmetic. Static data (uploaded once per selection): a record per fine node and its
// reconstruction blocks. Per frame only the coarse state goes to the GPU: coarse node positions,
// one rotation (a unit quaternion) per coarse element, one rigid transform per handle.
//
// A fine node is one of:
//   Rest      held at rest (the region's fixed faces, the skeleton) x = X
//   Handle    moved by handle k                               x = R_k X + t_k
//   Corner    a coarse node v                                  x = x_v
//   Boundary  on coarse element e's faces or edges             x = sum_c N_c x_c
//   Interior  inside coarse element e                          x = R_e (X + sum_c H_c (R_e^T x_c - X_c)
//                                                                    + sum_k [sum_j A_kj (R_e^T R_k - I)_j + B_k R_e^T t_k])
// with H_c, A_kj (column j of the matrix) and B_k 3x3 blocks; c runs over the element's n corners
// (n = 4 for tet elements, 8 for cell elements, see sim/coarsening.h).
#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <vector>

namespace handson {

struct RigidTransform;

struct FineInterpolationData {
  enum Kind : std::uint32_t { Rest = 0, Handle = 1, Corner = 2, Boundary = 3, Interior = 4 };
  /// Per fine node: kind, reference (handle, coarse node or coarse element), offset into `blocks`
  /// (vec4 units), number of handle blocks (Interior).
  std::vector<std::array<std::uint32_t, 4>> node;
  std::vector<Eigen::Vector4f> rest;    ///< per fine node: world rest position, w = 1
  /// Boundary: n/4 vec4 (N). Interior: 3n vec4 (H_c for c = 0..n-1, three columns each, xyz), then
  /// per handle block one vec4 (x = handle index, -1 for the anchored skeleton: the identity) and 12 vec4 (A_k0, A_k1, A_k2, B_k, three columns each).
  std::vector<Eigen::Vector4f> blocks;
  /// Two uvec4 per coarse element: its corner nodes (the first cornersPerElement count).
  std::vector<std::array<std::uint32_t, 4>> elementCorners;
  std::uint32_t cornersPerElement = 4;  ///< n: 4 or 8
  std::vector<Eigen::Vector4f> coarseRest;  ///< world, w = 1
  std::uint32_t handleCount = 0;

  std::size_t elementCount() const { return elementCorners.size() / 2; }
  std::size_t staticBytes() const;
  /// vec4 blocks of an Interior record with `handleBlocks` handle blocks.
  std::size_t interiorBlocks(std::uint32_t handleBlocks) const { return 3 * std::size_t(cornersPerElement) + 13 * std::size_t(handleBlocks); }
};

/// What goes to the GPU each frame.
struct CoarseFrameState {
  std::vector<Eigen::Vector4f> positions;  ///< per coarse node, world, w = 1
  std::vector<Eigen::Vector4f> rotations;  ///< per coarse element: unit quaternion (x, y, z, w)
  std::vector<Eigen::Matrix4f> handles;    ///< per handle: world rigid transform
  std::size_t bytes() const;
};

CoarseFrameState packFrameState(const std::vector<Eigen::Vector3d>& coarsePositions, const std::vector<Eigen::Matrix3d>& elementRotations,
                                const std::vector<RigidTransform>& handles);

/// CPU reference of deform_interpolate.comp: every fine node's position in voxel index space
/// (worldToIndex applied), w = 1. Throws handson::Error when the state does not fit the data.
std::vector<Eigen::Vector4f> interpolateFineReference(const FineInterpolationData& data, const CoarseFrameState& state,
                                                      const Eigen::Matrix4f& worldToIndex);

/// The rotation matrix of a (not necessarily normalized) quaternion stored as (x, y, z, w), in
/// the float arithmetic the shader uses.
Eigen::Matrix3f quaternionMatrix(const Eigen::Vector4f& q);

}  // namespace handson
