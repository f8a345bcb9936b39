#include "selection_eval.h"

#include <algorithm>
#include <chrono>
#include <cmath>

#include "sim/distance_transform.h"
#include "sim/base/error.h"
#include "sim/quantized_volume.h"

namespace handson {

Eigen::Vector3i deepestVoxel(const Volume& labels, int label, const Volume& ct) {
  // The organ's bounding box, with a one-voxel margin so the box edge counts as outside.
  const auto& d = labels.dims();
  Eigen::Vector3i lo = d, hi(-1, -1, -1);
  std::vector<float> values;
  for (int k = 0; k < d.z(); ++k)
    for (int j = 0; j < d.y(); ++j)
      for (int i = 0; i < d.x(); ++i)
        if (labels.value(i, j, k) == float(label)) {
          lo = lo.cwiseMin(Eigen::Vector3i(i, j, k));
          hi = hi.cwiseMax(Eigen::Vector3i(i, j, k));
          values.push_back(ct.value(i, j, k));
        }
  if (values.empty()) return {-1, -1, -1};
  std::sort(values.begin(), values.end());
  const float q1 = values[values.size() / 4], q3 = values[values.size() * 3 / 4];
  lo = (lo.array() - 1).max(0);
  hi = (hi.array() + 1).min(d.array() - 1);
  const Eigen::Vector3i bd = hi - lo + Eigen::Vector3i::Ones();
  std::vector<std::uint8_t> inside(std::size_t(bd.prod()));
  auto box = [&](int i, int j, int k) { return std::size_t(i) + std::size_t(bd.x()) * (std::size_t(j) + std::size_t(bd.y()) * std::size_t(k)); };
  for (int k = 0; k < bd.z(); ++k)
    for (int j = 0; j < bd.y(); ++j)
      for (int i = 0; i < bd.x(); ++i) inside[box(i, j, k)] = labels.value(lo.x() + i, lo.y() + j, lo.z() + k) == float(label) ? 1 : 0;
  // Voxels on the volume's own border have no outside neighbour in the box: that is as intended
  // (the scan ends there, the organ may not).
  const auto d2 = squaredDistanceToOutside(inside, bd, labels.geometry().spacing);
  std::size_t best = inside.size();
  Eigen::Vector3i bestVoxel(-1, -1, -1);
  for (int k = 0; k < bd.z(); ++k)
    for (int j = 0; j < bd.y(); ++j)
      for (int i = 0; i < bd.x(); ++i) {
        const std::size_t v = box(i, j, k);
        if (!inside[v] || (best < inside.size() && d2[v] <= d2[best])) continue;
        float sum = 0;
        for (int dz = -1; dz <= 1; ++dz)
          for (int dy = -1; dy <= 1; ++dy)
            for (int dx = -1; dx <= 1; ++dx) sum += ct.valueClamped(lo.x() + i + dx, lo.y() + j + dy, lo.z() + k + dz);
        const float mean = sum / 27.0f;
        if (mean >= q1 && mean <= q3) {
          best = v;
          bestVoxel = lo + Eigen::Vector3i(i, j, k);
        }
      }
  return bestVoxel;
}

std::pair<double, std::size_t> organRadiusMm(const Volume& labels, int label, const Eigen::Vector3i& seed) {
  const auto& g = labels.geometry();
  std::vector<double> dist;
  for (std::size_t v = 0; v < labels.voxelCount(); ++v)
    if (labels.value(v) == float(label)) dist.push_back((g.voxelOf(v) - seed).cast<double>().cwiseProduct(g.spacing).norm());
  if (dist.empty()) return {0.0, 0};
  const std::size_t at95 = std::min(dist.size() - 1, std::size_t(std::ceil(0.95 * double(dist.size()))) - 1);
  std::nth_element(dist.begin(), dist.begin() + std::ptrdiff_t(at95), dist.end());
  return {std::max(dist[at95], g.spacing.minCoeff()), dist.size()};
}

std::vector<SelectionAccuracy> evaluateSelection(const LabelledCt& data, const std::vector<double>& extentsMm, const std::vector<GrowCriterion>& criteria,
                                                 double hMax) {
  const std::string& dataset = data.dataset;
  const Volume &ct = data.ct, &labels = data.labels;
  const std::vector<OrganLabel>& organs = data.organs;
  if (ct.dims() != labels.dims()) throw Error("selection accuracy: the label map is not on the CT's grid");
  const QuantizedVolume q = quantizeVolume(ct);
  const auto& g = ct.geometry();
  std::vector<SelectionAccuracy> rows;
  for (const auto& organ : organs) {
    const Eigen::Vector3i seed = deepestVoxel(labels, organ.label, ct);
    if (seed.x() < 0) continue;
    for (GrowCriterion c : criteria) {
      GrowParams p;
      p.criterion = c;
      p.hMax = hMax;
      p.bound = GrowBound::Ball;  // recall is counted inside the extent's ball: the bound it is defined for
      RegionGrower grower(q, seed, p);
      for (double extent : extentsMm) {
        const auto t0 = std::chrono::steady_clock::now();
        grower.growTo(extent);
        const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
        const std::uint32_t bound = grower.bound(extent);
        const auto& keys = grower.keys();
        std::size_t selected = 0, selectedInOrgan = 0, organInBall = 0, selectedOrganInBall = 0;
        // Only voxels within the ball (smoothed, core: the path bound's geodesic ball lies inside
        // it) or within extent / smallest spacing steps (paper: a diamond that reaches past the
        // ball along coarser axes) can be selected: scan the box they can reach, which holds the ball.
        const Eigen::Vector3i r = growReach(grower.setup().criterion, grower.setup().bound, extent, g.spacing);
        const Eigen::Vector3i lo = (seed - r).cwiseMax(Eigen::Vector3i::Zero());
        const Eigen::Vector3i hi = (seed + r).cwiseMin(g.dims - Eigen::Vector3i::Ones());
        for (int k = lo.z(); k <= hi.z(); ++k)
          for (int j = lo.y(); j <= hi.y(); ++j)
            for (int i = lo.x(); i <= hi.x(); ++i) {
              const std::size_t v = ct.linearIndex(i, j, k);
              const bool sel = keys[v] <= bound;
              const bool in = labels.value(v) == float(organ.label);
              const Eigen::Vector3d dmm = (Eigen::Vector3d(i, j, k) - seed.cast<double>()).cwiseProduct(g.spacing);
              const bool inBall = dmm.squaredNorm() <= extent * extent;
              selected += sel;
              selectedInOrgan += sel && in;
              organInBall += in && inBall;
              selectedOrganInBall += sel && in && inBall;
            }
        rows.push_back({dataset, organ.name, c, extent, seed, selected, organInBall,
                        selected ? double(selectedInOrgan) / double(selected) : 0.0,
                        organInBall ? double(selectedOrganInBall) / double(organInBall) : 0.0, ms});
      }
    }
  }
  return rows;
}

std::string sweepVariantName(GrowCriterion c, bool rim) { return std::string(growCriterionName(c)) + (rim ? "+rim" : ""); }

const SweepPoint& OrganSweep::best() const {
  return *std::max_element(points.begin(), points.end(), [](const SweepPoint& a, const SweepPoint& b) { return a.dice < b.dice; });
}

std::vector<OrganSweep> sweepSelection(const LabelledCt& data, const SweepSettings& settings) {
  const std::string& dataset = data.dataset;
  const Volume &ct = data.ct, &labels = data.labels;
  const std::vector<OrganLabel>& organs = data.organs;
  const std::vector<double>& fractions = settings.fractions;
  const std::vector<GrowCriterion>& criteria = settings.criteria;
  const bool rim = settings.rim;
  const RegionStatistics statistics = settings.statistics;
  const GrowBound bound = settings.bound;
  if (ct.dims() != labels.dims()) throw Error("selection accuracy: the label map is not on the CT's grid");
  if (fractions.empty() || !std::is_sorted(fractions.begin(), fractions.end()))
    throw Error("selection accuracy: the extent fractions must be a non-empty increasing list");
  const QuantizedVolume q = quantizeVolume(ct);
  std::vector<OrganSweep> out;
  for (const auto& organ : organs) {
    const Eigen::Vector3i seed = deepestVoxel(labels, organ.label, ct);
    if (seed.x() < 0) continue;
    const auto radiusAndCount = organRadiusMm(labels, organ.label, seed);
    const double radius = radiusAndCount.first;
    const std::size_t organVoxels = radiusAndCount.second;  // (a named variable: lambdas below capture it)
    for (GrowCriterion c : criteria) {
      GrowParams p;
      p.criterion = c;
      p.statistics = statistics;
      p.bound = bound;
      RegionGrower grower(q, seed, p);
      OrganSweep s{dataset, organ.name, c, false, seed, radius, organVoxels, {}};
      OrganSweep r{dataset, organ.name, c, true, seed, radius, organVoxels, {}};
      auto point = [&](double f, double extent, const std::vector<std::uint32_t>& voxels, double ms) {
        std::size_t hit = 0;
        for (std::uint32_t v : voxels) hit += labels.value(v) == float(organ.label);
        const std::size_t selected = voxels.size();
        const double dice = 2.0 * double(hit) / double(selected + organVoxels);
        return SweepPoint{f, extent, selected, dice, selected ? double(hit) / double(selected) : 0.0, double(hit) / double(organVoxels), ms};
      };
      for (double f : fractions) {
        const double extent = f * radius;
        const auto t0 = std::chrono::steady_clock::now();
        grower.growTo(extent);
        const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
        const std::uint32_t keyBound = grower.bound(extent);
        std::vector<std::uint32_t> voxels;
        for (std::size_t v : grower.touched())
          if (grower.keys()[v] <= keyBound) voxels.push_back(std::uint32_t(v));
        std::sort(voxels.begin(), voxels.end());
        s.points.push_back(point(f, extent, voxels, ms));
        if (rim) {
          const auto t1 = std::chrono::steady_clock::now();
          const std::vector<std::uint32_t> withRim = withBoundaryRim(grower, voxels);
          r.points.push_back(point(f, extent, withRim, ms + std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t1).count()));
        }
      }
      out.push_back(std::move(s));
      if (rim) out.push_back(std::move(r));
    }
  }
  return out;
}

}  // namespace handson
