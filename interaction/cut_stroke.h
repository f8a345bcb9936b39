#pragma once
// A cut drawn by one finger (docs/cutting.md, "The stroke"): each sample of the stroke is the view
// ray under the finger and the distance along it to the surface the pick found there. The cut is the
// ruled surface of the rays between the picked surface and a depth below the surface the stroke
// started on: along each ray from its surface point A = o + s d to its bottom B = o + (s0 + depth) d,
// s0 the first sample's surface distance. Two consecutive rays from one eye (or parallel ones) span a
// plane, so each pair of kept samples gives one planar quad A_i, A_j, B_j, B_i (sim/tissue_cut.h),
// convex since both segments run the same way along their rays.
#include <Eigen/Core>
#include <cstddef>
#include <string>
#include <string_view>
#include <vector>

#include "sim/tissue_cut.h"

namespace handson {

struct StrokeSample {
  Eigen::Vector3d origin{0, 0, 0};     ///< the view ray's origin (world mm)
  Eigen::Vector3d direction{0, 0, 1};  ///< its unit direction
  double surfaceMm = 0.0;              ///< distance along it to the picked surface; NaN: the pick missed
};

struct CutStrokeOptions {
  double depthMm = 15.0;      ///< the cut's bottom below the surface the stroke starts on
  /// Samples closer than this (their surface points) to the last one kept are skipped, so each quad
  /// spans at least a fine tet's faces (a narrower quad separates nothing): the stroke's end within
  /// it of the last kept sample is left uncut.
  double minSegmentMm = 4.0;
};

struct CutStroke {
  std::vector<CutQuad> quads;  ///< in the stroke's order
  /// Samples left out: one whose pick missed, or whose surface lies at or below the cut's bottom,
  /// has no cut beneath it (the samples within minSegmentMm before such a gap are left uncut too);
  /// and one whose ray spans no plane with the last kept sample's (no common eye): the next may.
  std::size_t skipped = 0;
};

/// The stroke's cut. Throws handson::Error for fewer than two samples, a stroke whose first pick
/// missed, a depth or segment length that is not a positive finite number, a sample that is not
/// finite, whose direction is not unit or whose surface distance is negative, and a stroke that
/// leaves no quad (it did not move, or
/// nothing under it lies above the cut's bottom).
CutStroke cutAlongStroke(const std::vector<StrokeSample>& samples, const CutStrokeOptions& options = {});

/// A cut's quads as a session script records them (the "cut" action's value): each quad's twelve
/// corner coordinates (RAS mm, X0,Y0,Z0,...,Z3) separated by commas, quads by semicolons, every
/// number written to round-trip exactly (replays are bit-identical).
std::string formatCutQuads(const std::vector<CutQuad>& quads);
/// Reads that form back. Throws handson::Error for no quad, a quad of other than twelve numbers, a
/// number that is not one, or a quad checkCutQuad refuses (not planar and convex, no area).
std::vector<CutQuad> parseCutQuads(std::string_view text);

}  // namespace handson
