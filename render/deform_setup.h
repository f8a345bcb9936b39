#pragma once
// The checks and derived values of a deformation setup, apart from GpuDeformer's passes: what the
// device, the source images and the mesh records must satisfy before anything is uploaded.
#include <array>
#include <cstdint>
#include <vector>

#include "deform_pass.h"
#include "render/frame_graph.h"
#include "shaders/shared.h"

namespace handson::vk {

class Context;

/// A setup that passed validateDeformSetup, with what the passes need from it.
struct ValidatedDeformSetup {
  std::vector<std::array<std::uint32_t, 4>> tets;  ///< the fine tets' node indices, checked in range
  gpu::DeformParams params{};                      ///< the passes' parameter block
  std::uint64_t ownerBytes = 0;                    ///< the owner buffer: one uint per voxel of the region's box
};

/// Checks `setup` against the device and the source volume and mask descriptions; throws Error with
/// the first problem: no mesh data, a device without 16-bit storage images or subgroup arithmetic,
/// volume (R16) and mask (R8) not on one grid, empty or inconsistent counts, a tet, a fine node's
/// record, a handle block or a coarse element out of range, more workgroups than the device
/// dispatches, a region outside the volume or beyond the device's storage-buffer range.
ValidatedDeformSetup validateDeformSetup(const Context& ctx, const fg::ImageDesc& source, const fg::ImageDesc& mask, const DeformSetup& setup);

}  // namespace handson::vk
