#include "spirv.h"

#include "brick_minmax.spv.h"
#include "deform_args.spv.h"
#include "deform_bounds.spv.h"
#include "deform_bricks.spv.h"
#include "deform_claim.spv.h"
#include "deform_clear.spv.h"
#include "deform_interpolate.spv.h"
#include "deform_resolve.spv.h"
#include "deform_strain.spv.h"
#include "deform_strain_raster.spv.h"
#include "live_mask.spv.h"
#include "pick.spv.h"
#include "raymarch.spv.h"
#include "region_compact.spv.h"
#include "region_grow.spv.h"

namespace handson::shaders {

std::span<const std::uint32_t> raymarch() { return spirv::raymarch; }
std::span<const std::uint32_t> pick() { return spirv::pick; }
std::span<const std::uint32_t> brickMinMax() { return spirv::brick_minmax; }
std::span<const std::uint32_t> regionGrow() { return spirv::region_grow; }
std::span<const std::uint32_t> regionCompact() { return spirv::region_compact; }
std::span<const std::uint32_t> liveMask() { return spirv::live_mask; }
std::span<const std::uint32_t> deformInterpolate() { return spirv::deform_interpolate; }
std::span<const std::uint32_t> deformBounds() { return spirv::deform_bounds; }
std::span<const std::uint32_t> deformArgs() { return spirv::deform_args; }
std::span<const std::uint32_t> deformBricks() { return spirv::deform_bricks; }
std::span<const std::uint32_t> deformClear() { return spirv::deform_clear; }
std::span<const std::uint32_t> deformClaim() { return spirv::deform_claim; }
std::span<const std::uint32_t> deformResolve() { return spirv::deform_resolve; }
std::span<const std::uint32_t> deformStrain() { return spirv::deform_strain; }
std::span<const std::uint32_t> deformStrainRaster() { return spirv::deform_strain_raster; }

}  // namespace handson::shaders
