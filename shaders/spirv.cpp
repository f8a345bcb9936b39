#include "spirv.h"

#include "brick_minmax.spv.h"
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

}  // namespace handson::shaders
