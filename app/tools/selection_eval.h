#pragma once
// Accuracy of region growing against organ labels: seeds at the voxel farthest from each organ's
// boundary, several extents, any criteria; precision = selected voxels inside the organ / selected
// voxels; recall = selected organ voxels inside the extent's ball / organ voxels inside that ball.
#include <cstddef>
#include <string>
#include <utility>
#include <vector>

#include "interaction/region_grow.h"
#include "sim/volume.h"

namespace handson {

struct OrganLabel {
  int label;
  std::string name;
};

struct SelectionAccuracy {
  std::string dataset, organ;
  GrowCriterion criterion;
  double extentMm;
  Eigen::Vector3i seed;
  std::size_t selected, organInBall;
  double precision, recall, milliseconds;
};

/// A labelled CT to measure on: its name, the CT, its label map (on the CT's grid) and the organs.
struct LabelledCt {
  std::string dataset;
  const Volume& ct;
  const Volume& labels;
  const std::vector<OrganLabel>& organs;
};

/// Grows from the deepest typical voxel of each organ for each extent and criterion, under the ball
/// bound (recall is counted inside the extent's ball). Organs missing from the label map are skipped.
std::vector<SelectionAccuracy> evaluateSelection(const LabelledCt& data, const std::vector<double>& extentsMm, const std::vector<GrowCriterion>& criteria,
                                                 double hMax = 1.1);

/// Whole-organ accuracy of one criterion as the extent sweeps, as a user spreads the fingers: the
/// extents are fractions of the organ's radius, the 95th percentile of its voxels' distances (mm)
/// from the seed. Dice = 2|S n O| / (|S| + |O|) against the whole labelled organ O.
struct SweepPoint {
  double fraction, extentMm;
  std::size_t selected;
  double dice, precision, recall, milliseconds;
};
struct OrganSweep {
  std::string dataset, organ;
  GrowCriterion criterion;
  bool rim = false;  ///< the selections end with their boundary rim (withBoundaryRim)
  Eigen::Vector3i seed;
  double radiusMm;
  std::size_t organVoxels;
  std::vector<SweepPoint> points;  // in the order of the fractions
  const SweepPoint& best() const;
};
/// What a sweep grows: per criterion one sweep of the grown selections and, with `rim`, one of the
/// same selections with their boundary rim (the grown ones are its baseline, from the same growth).
struct SweepSettings {
  std::vector<double> fractions;  ///< of the organ's radius, increasing
  std::vector<GrowCriterion> criteria;
  bool rim = true;
  RegionStatistics statistics = RegionStatistics::Robust;  ///< how the smoothed criteria refine theirs (GrowParams::statistics)
  GrowBound bound = GrowParams{}.bound;                    ///< how the extent bounds them (GrowParams::bound)
};
std::vector<OrganSweep> sweepSelection(const LabelledCt& data, const SweepSettings& settings);
/// "core", "core+rim", ...
std::string sweepVariantName(GrowCriterion c, bool rim);

/// The organ's radius from a seed: the 95th percentile of its voxels' distances (mm) from it, at
/// least the smallest spacing; and its voxel count (0, radius 0: no such label).
std::pair<double, std::size_t> organRadiusMm(const Volume& labels, int label, const Eigen::Vector3i& seed);

/// The voxel of `label` farthest (in mm) from any voxel of another label, among those whose 3x3x3
/// mean CT value lies within the organ's interquartile range (label maps include tissue that is
/// not the organ's own, e.g. renal sinus fat inside the kidney label); (-1,-1,-1) if absent.
Eigen::Vector3i deepestVoxel(const Volume& labels, int label, const Volume& ct);

}  // namespace handson
