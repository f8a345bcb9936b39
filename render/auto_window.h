#pragma once
// The automatic window: a CT preset's ramps placed on the soft tissue of the region in view.
//
// The values the clip leaves (the whole volume without one) are histogrammed over the soft-tissue
// range, -50..300 HU in 2 HU bins (at most 4 M voxels, sampled on a regular stride), smoothed with
// a Gaussian of 5 HU; the soft-tissue peak is the smoothed histogram's highest bin in -20..250 HU
// (fat, at -100, below; bone above) and its spread the peak's half width at half maximum (the mean
// of its two sides, at least 5 HU: reported, not used). A preset drawn for a known peak (its
// tissuePeak: the organs it was designed to show) is then shifted so that its reference lands on
// the region's peak: with v' = v + shift (TransferFunction::windowed at scale 1),
//   shift = peak - tissuePeak.
// A non-contrast CT's organs (30-60 HU) then sit where the contrast preset's enhanced organs
// (110 HU) were, and a contrast CT's under the soft-tissue preset where its unenhanced ones were.
// Widening the ramps by the spread as well was measured worse (docs/results.md, 2026-12-06): a
// region's spread is that of a mixture of tissues, not of one.
#include <cstddef>
#include <optional>

#include "render/render_params.h"
#include "render/transfer_function.h"
#include "sim/volume.h"

namespace handson {

struct TissuePeak {
  double value = 0.0;       ///< the soft-tissue peak (image units: HU)
  double halfWidth = 0.0;   ///< its half width at half maximum
  std::size_t samples = 0;  ///< voxels of the region in the soft-tissue range
};

/// The region's soft-tissue peak; nullopt when fewer than 500 of its sampled voxels lie in the
/// soft-tissue range (an MRI, a region of air or bone).
std::optional<TissuePeak> softTissuePeak(const Volume& volume, const ClipRegion& clip);

/// The level shift that puts tf's reference peak on `peak` (above); nullopt when tf has no
/// reference (a relative preset, one loaded from a file, the bone preset).
std::optional<double> autoWindowShift(const TransferFunction& tf, const TissuePeak& peak);

/// The automatic window for tf on what the clip leaves: the region's peak and the shift that puts
/// tf's reference on it; nullopt where either is missing (above).
struct AutoWindow {
  TissuePeak peak;
  double shift = 0.0;
};
std::optional<AutoWindow> autoWindowFor(const Volume& volume, const TransferFunction& tf, const ClipRegion& clip);

/// Whether a world point (RAS mm) lies in what the clip keeps (inside the box, on the plane's kept side).
bool clipKeeps(const ClipRegion& clip, const glm::dvec3& world);

}  // namespace handson
