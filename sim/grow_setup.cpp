#include "grow_setup.h"

#include <algorithm>
#include <cmath>
#include <cstring>

namespace handson {

const char* growCriterionName(GrowCriterion c) {
  switch (c) {
    case GrowCriterion::Paper: return "paper";
    case GrowCriterion::Smoothed: return "smoothed";
    case GrowCriterion::Core: return "core";
  }
  return "?";
}

bool parseGrowCriterion(const std::string& s, GrowCriterion& out) {
  if (s == "paper") out = GrowCriterion::Paper;
  else if (s == "smoothed") out = GrowCriterion::Smoothed;
  else if (s == "core") out = GrowCriterion::Core;
  else return false;
  return true;
}

std::uint32_t growKeyBound(GrowCriterion c, double extentMm, const Eigen::Vector3d& spacing) {
  if (!(extentMm >= 0.0)) return 0;
  if (c == GrowCriterion::Paper) return std::uint32_t(std::min(1e9, std::floor(extentMm / spacing.minCoeff() + 1e-9)));
  const float d2 = float(extentMm) * float(extentMm);
  std::uint32_t bits;
  std::memcpy(&bits, &d2, 4);
  return bits;
}

Eigen::Vector3i growReach(GrowCriterion c, double extentMm, const Eigen::Vector3d& spacing) {
  if (c == GrowCriterion::Paper) return Eigen::Vector3i::Constant(int(growKeyBound(c, extentMm, spacing)));
  return (Eigen::Vector3d::Constant(std::max(0.0, extentMm)).array() / spacing.array()).ceil().cast<int>();
}

float growDistance2(const Eigen::Vector3i& v, const Eigen::Vector3i& s, const Eigen::Vector3f& sp) {
  // The same operations, in the same order, as region_grow.comp (whose result is `precise`).
  const float dx = float(v.x() - s.x()) * sp.x();
  const float dy = float(v.y() - s.y()) * sp.y();
  const float dz = float(v.z() - s.z()) * sp.z();
  const float xx = dx * dx, yy = dy * dy, zz = dz * dz;
  return (xx + yy) + zz;
}

}  // namespace handson
