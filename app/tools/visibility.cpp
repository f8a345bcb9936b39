#include "app/tools/visibility.h"

#include <algorithm>
#include <cmath>

namespace handson {

std::array<double, 3> srgbToLab(std::uint8_t r8, std::uint8_t g8, std::uint8_t b8) {
  // sRGB -> linear -> XYZ (D65) -> L*a*b* (IEC 61966-2-1; CIE 1976).
  auto linear = [](std::uint8_t c) {
    const double v = c / 255.0;
    return v <= 0.04045 ? v / 12.92 : std::pow((v + 0.055) / 1.055, 2.4);
  };
  const double r = linear(r8), g = linear(g8), b = linear(b8);
  const double x = 0.4124564 * r + 0.3575761 * g + 0.1804375 * b;
  const double y = 0.2126729 * r + 0.7151522 * g + 0.0721750 * b;
  const double z = 0.0193339 * r + 0.1191920 * g + 0.9503041 * b;
  auto f = [](double t) { return t > 216.0 / 24389.0 ? std::cbrt(t) : (24389.0 / 27.0 * t + 16.0) / 116.0; };
  const double fx = f(x / 0.95047), fy = f(y / 1.0), fz = f(z / 1.08883);
  return {116.0 * fy - 16.0, 500.0 * (fx - fy), 200.0 * (fy - fz)};
}

double deltaE76(const std::array<double, 3>& a, const std::array<double, 3>& b) {
  return std::sqrt((a[0] - b[0]) * (a[0] - b[0]) + (a[1] - b[1]) * (a[1] - b[1]) + (a[2] - b[2]) * (a[2] - b[2]));
}

double meanPairwiseDeltaE(const std::vector<std::array<double, 3>>& a, const std::vector<std::array<double, 3>>& b) {
  if (a.empty() || b.empty()) return 0.0;
  double sum = 0.0;
  for (const auto& p : a)
    for (const auto& q : b) sum += deltaE76(p, q);
  return sum / (double(a.size()) * double(b.size()));
}

int labelAt(const Volume& labels, const Eigen::Vector3d& world) {
  const Eigen::Vector3d idx = labels.geometry().toIndex(world).array().round();
  const Eigen::Vector3i d = labels.dims();
  if (!idx.allFinite() || (idx.array() < 0.0).any() || idx.x() >= d.x() || idx.y() >= d.y() || idx.z() >= d.z()) return -1;
  return int(std::lround(labels.value(int(idx.x()), int(idx.y()), int(idx.z()))));
}

std::optional<WorldBox> labelBox(const Volume& labels, int label) {
  const Eigen::Vector3i d = labels.dims();
  Eigen::Vector3i lo = d, hi(-1, -1, -1);
  for (int k = 0; k < d.z(); ++k)
    for (int j = 0; j < d.y(); ++j)
      for (int i = 0; i < d.x(); ++i) {
        if (int(std::lround(labels.value(i, j, k))) != label) continue;
        lo = lo.cwiseMin(Eigen::Vector3i(i, j, k));
        hi = hi.cwiseMax(Eigen::Vector3i(i, j, k));
      }
  if (hi.x() < 0) return std::nullopt;
  // The world box of the index box's corners (voxel edges: +-0.5), oblique grids included.
  WorldBox box{Eigen::Vector3d::Constant(1e300), Eigen::Vector3d::Constant(-1e300)};
  for (int c = 0; c < 8; ++c) {
    const Eigen::Vector3d idx((c & 1) ? hi.x() + 0.5 : lo.x() - 0.5, (c & 2) ? hi.y() + 0.5 : lo.y() - 0.5, (c & 4) ? hi.z() + 0.5 : lo.z() - 0.5);
    const Eigen::Vector3d w = labels.geometry().toWorld(idx);
    box.lo = box.lo.cwiseMin(w);
    box.hi = box.hi.cwiseMax(w);
  }
  return box;
}

double nearestSideAzimuth(const Volume& ct, const Eigen::Vector3d& point, double skinHu) {
  const double step = 0.5 * ct.geometry().spacing.minCoeff();
  const Eigen::Vector3i d = ct.dims();
  if (!(step > 0.0) || !std::isfinite(step) || !point.allFinite() || ct.voxelCount() == 0) return 0.0;
  const double reach = ct.geometry().diagonalMm() + (point - ct.geometry().center()).norm();  // past every voxel
  double best = 1e300, bestAz = 0.0;
  for (const double az : {0.0, 180.0, 90.0, -90.0}) {
    const double a = az * 3.14159265358979323846 / 180.0;
    const Eigen::Vector3d dir(std::sin(a), std::cos(a), 0.0);
    double skin = 0.0;  // the distance to the last voxel at or above skinHu along the ray
    bool found = false;
    for (double t = 0.0; t <= reach + step; t += step) {
      const Eigen::Vector3d idx = ct.geometry().toIndex(point + t * dir).array().round();
      if ((idx.array() < 0.0).any() || idx.x() >= d.x() || idx.y() >= d.y() || idx.z() >= d.z()) {
        if (!found) skin = t;  // nothing but air: the volume's edge
        break;
      }
      if (ct.value(int(idx.x()), int(idx.y()), int(idx.z())) >= skinHu) {
        skin = t;
        found = true;
      }
    }
    if (skin < best) {
      best = skin;
      bestAz = az;
    }
  }
  return bestAz;
}

}  // namespace handson
