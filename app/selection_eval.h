#pragma once
// Accuracy of region growing against organ labels: seeds at the voxel farthest from each organ's
// boundary, several extents, both criteria; precision = selected voxels inside the organ / selected
// voxels; recall = selected organ voxels inside the extent's ball / organ voxels inside that ball.
#include <string>
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

/// Grows from the deepest typical voxel of each organ (labels on the CT's grid) for each extent and
/// criterion. Organs missing from the label map are skipped.
std::vector<SelectionAccuracy> evaluateSelection(const std::string& dataset, const Volume& ct, const Volume& labels,
                                                 const std::vector<OrganLabel>& organs, const std::vector<double>& extentsMm,
                                                 const std::vector<GrowCriterion>& criteria, double hMax = 1.1);

/// The voxel of `label` farthest (in mm) from any voxel of another label, among those whose 3x3x3
/// mean CT value lies within the organ's interquartile range (label maps include tissue that is
/// not the organ's own, e.g. renal sinus fat inside the kidney label); (-1,-1,-1) if absent.
Eigen::Vector3i deepestVoxel(const Volume& labels, int label, const Volume& ct);

}  // namespace handson
