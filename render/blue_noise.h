#pragma once
// A blue-noise dither tile for the raymarch's ray-start jitter (docs/frame.md, "Ray jitter").
//
// With every ray's samples at the same fractions of the step, a volume whose slices are thicker
// than the step shows "wood-grain" bands on surfaces: neighbouring rays cross a thin shell at the
// same sample phase. Offsetting each pixel's first sample by a fraction of the step from a
// blue-noise tile turns the bands into fine noise with no low-frequency structure (which the eye
// does not see as pattern), and shifting all offsets by the golden ratio per refinement frame lets
// the still frame average it away (render/raymarch_reference.cpp, shaders/raymarch.comp).
//
// The tile: the ranks 0 .. kBlueNoiseSize² - 1 of a kBlueNoiseSize² dither array by Ulichney's
// void-and-cluster method (1993), Gaussian energy (sigma 1.5 pixels) on the torus, so the tile
// repeats without seams. Deterministic: the same ranks on every run.
#include <cstdint>
#include <vector>

namespace handson {

inline constexpr int kBlueNoiseSize = 64;

/// The tile's ranks, row-major (y * kBlueNoiseSize + x); a permutation of 0 .. kBlueNoiseSize² - 1.
/// Computed once per process (tens of milliseconds), then shared.
const std::vector<std::uint32_t>& blueNoiseRanks();

/// Void-and-cluster ranks of an n x n tile (n >= 4), for tests and other sizes.
std::vector<std::uint32_t> voidAndClusterRanks(int n, double sigma = 1.5);

}  // namespace handson
