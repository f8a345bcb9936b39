#pragma once
// How well an organ can be seen and picked in a rendering (#47's measure): the organ's box as a
// clip, the side of the body the organ is nearest, and how different the organ's pixels look from
// the rest (CIELAB colour differences).
#include <array>
#include <cstdint>
#include <optional>
#include <vector>

#include <Eigen/Core>

#include "sim/volume.h"

namespace handson {

/// An sRGB colour (8 bits a channel, D65 white) in CIELAB (L* 0..100).
std::array<double, 3> srgbToLab(std::uint8_t r, std::uint8_t g, std::uint8_t b);
/// The CIE76 colour difference: the Euclidean distance in CIELAB (about 2: just noticeable).
double deltaE76(const std::array<double, 3>& a, const std::array<double, 3>& b);
/// The mean of deltaE76 over every pair (one of a, one of b); 0 when either is empty.
double meanPairwiseDeltaE(const std::vector<std::array<double, 3>>& a, const std::vector<std::array<double, 3>>& b);

/// The label at a world point (RAS mm; the nearest voxel of the label map's own grid); -1 outside it.
int labelAt(const Volume& labels, const Eigen::Vector3d& world);

/// The world box (RAS mm, voxel edges included) of the voxels with `label`; nullopt when none has it.
struct WorldBox {
  Eigen::Vector3d lo, hi;
};
std::optional<WorldBox> labelBox(const Volume& labels, int label);

/// The azimuth (degrees: 0 anterior, 90 the patient's right, 180 posterior, -90 left; elevation 0)
/// of the side of the body the point is nearest: along each of the four directions the distance
/// from the point to the last voxel at or above `skinHu` (the skin; the volume's edge when none),
/// the smallest winning, ties in that order.
double nearestSideAzimuth(const Volume& ct, const Eigen::Vector3d& point, double skinHu = -500.0);

}  // namespace handson
