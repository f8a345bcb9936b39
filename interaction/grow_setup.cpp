#include "interaction/grow_setup.h"

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

const char* growBoundName(GrowBound b) { return b == GrowBound::Path ? "path" : "ball"; }

bool parseGrowBound(const std::string& s, GrowBound& out) {
  if (s == "ball") out = GrowBound::Ball;
  else if (s == "path") out = GrowBound::Path;
  else return false;
  return true;
}

std::array<std::uint32_t, 8> growStepCosts(const Eigen::Vector3f& spacingMm) {
  std::array<std::uint32_t, 8> cost{};
  for (int mask = 1; mask < 8; ++mask) {
    double l2 = 0;
    for (int a = 0; a < 3; ++a)
      if (mask & (1 << a)) l2 += double(spacingMm[a]) * double(spacingMm[a]);
    cost[std::size_t(mask)] = std::uint32_t(std::clamp(std::floor(std::sqrt(l2) * kPathUnitsPerMm + 0.5), 1.0, 4e9));
  }
  return cost;
}

std::uint32_t growKeyBound(GrowCriterion c, GrowBound b, double extentMm, const Eigen::Vector3d& spacing) {
  if (!(extentMm >= 0.0)) return 0;
  if (c == GrowCriterion::Paper) return std::uint32_t(std::min(1e9, std::floor(extentMm / spacing.minCoeff() + 1e-9)));
  if (b == GrowBound::Path) return std::uint32_t(std::min(4e9, std::floor(extentMm * kPathUnitsPerMm)));
  const float d2 = float(extentMm) * float(extentMm);
  std::uint32_t bits;
  std::memcpy(&bits, &d2, 4);
  return bits;
}

Eigen::Vector3i growReach(GrowCriterion c, GrowBound b, double extentMm, const Eigen::Vector3d& spacing) {
  if (c == GrowCriterion::Paper) return Eigen::Vector3i::Constant(int(growKeyBound(c, b, extentMm, spacing)));
  if (b == GrowBound::Path) {  // whole steps of the axis within the bound
    const std::uint32_t bound = growKeyBound(c, b, extentMm, spacing);
    const auto cost = growStepCosts(spacing.cast<float>());
    Eigen::Vector3i r;
    for (int a = 0; a < 3; ++a) r[a] = int(std::min<std::uint32_t>(bound / cost[std::size_t(1) << a], 1u << 30));
    return r;
  }
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
