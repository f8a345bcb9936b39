#pragma once
// Embedded SPIR-V of the compute passes (compiled from shaders/*.comp at build time).
#include <cstddef>
#include <cstdint>
#include <span>

namespace handson::shaders {

std::span<const std::uint32_t> raymarch();
std::span<const std::uint32_t> pick();
std::span<const std::uint32_t> brickMinMax();
std::span<const std::uint32_t> regionGrow();
std::span<const std::uint32_t> regionCompact();
std::span<const std::uint32_t> liveMask();
std::span<const std::uint32_t> deformInterpolate();
std::span<const std::uint32_t> deformBounds();
std::span<const std::uint32_t> deformArgs();
std::span<const std::uint32_t> deformBricks();
std::span<const std::uint32_t> deformClear();
std::span<const std::uint32_t> deformClaim();
std::span<const std::uint32_t> deformResolve();
std::span<const std::uint32_t> deformStrain();
std::span<const std::uint32_t> deformStrainRaster();

}  // namespace handson::shaders
