#include "region_grow.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <string>
#include <utility>

#include "sim/volume.h"
#include "sim/base/error.h"

namespace handson {

namespace {
// Cached answers per voxel, as in the GPU pass: within the tolerance, within the core tolerance, core.
constexpr std::uint8_t kKnown = 1, kHomogeneous = 2, kTight = 4, kCoreKnown = 8, kCore = 16;

std::uint32_t floatKey(float f) {
  std::uint32_t b;
  std::memcpy(&b, &f, 4);
  return b;
}
}  // namespace

Eigen::Vector3i mostHomogeneousNear(const QuantizedVolume& volume, const Eigen::Vector3i& near, int radius) {
  const auto& d = volume.geometry.dims;
  auto at = [&](int i, int j, int k) {
    i = std::clamp(i, 0, d.x() - 1);
    j = std::clamp(j, 0, d.y() - 1);
    k = std::clamp(k, 0, d.z() - 1);
    return double(volume.data[std::size_t(i) + std::size_t(d.x()) * (std::size_t(j) + std::size_t(d.y()) * std::size_t(k))]);
  };
  Eigen::Vector3i best = near;
  double bestVar = std::numeric_limits<double>::infinity();
  int bestDist = 0;
  for (int dz = -radius; dz <= radius; ++dz)
    for (int dy = -radius; dy <= radius; ++dy)
      for (int dx = -radius; dx <= radius; ++dx) {
        const Eigen::Vector3i c = near + Eigen::Vector3i(dx, dy, dz);
        if (!volume.geometry.contains(c)) continue;
        double s1 = 0, s2 = 0;
        for (int z = -1; z <= 1; ++z)
          for (int y = -1; y <= 1; ++y)
            for (int x = -1; x <= 1; ++x) {
              const double u = at(c.x() + x, c.y() + y, c.z() + z);
              s1 += u;
              s2 += u * u;
            }
        const double var = s2 / 27.0 - (s1 / 27.0) * (s1 / 27.0);
        const int dist = dx * dx + dy * dy + dz * dz;
        if (var < bestVar - 1e-9 || (std::abs(var - bestVar) <= 1e-9 && dist < bestDist)) {
          bestVar = var;
          best = c;
          bestDist = dist;
        }
      }
  return best;
}

void GrowWorkspace::reserve(std::size_t voxels) {
  const std::lock_guard<std::mutex> lock(mutex_);
  if (lent_) throw Error("region growing: the workspace is lent to a grower");
  if (keys.size() != voxels) keys.assign(voxels, kUnreached);
  if (tests.size() != voxels) tests.assign(voxels, 0);
}

void GrowWorkspace::lend(std::vector<std::uint32_t>& k, std::vector<std::uint8_t>& t) {
  std::unique_lock<std::mutex> lock(mutex_);
  if (!returned_.wait_for(lock, lendWait, [this] { return !lent_; }))
    throw Error("region growing: the last selection still holds the grower's arrays (not finished in " + std::to_string(lendWait.count()) + " ms)");
  lent_ = true;
  std::swap(k, keys);
  std::swap(t, tests);
}

void GrowWorkspace::giveBack(std::vector<std::uint32_t>& k, std::vector<std::uint8_t>& t) {
  {
    const std::lock_guard<std::mutex> lock(mutex_);
    std::swap(keys, k);
    std::swap(tests, t);
    lent_ = false;
  }
  returned_.notify_all();
}

RegionGrower::~RegionGrower() { releaseWorkspace(); }

void RegionGrower::releaseWorkspace() {
  if (!workspace_) return;
  // Back to the workspace as it came: cleared where this grower wrote.
  for (std::size_t v : touched_) keys_[v] = kUnreached;
  for (std::size_t v : classified_) class_[v] = 0;
  if (!front_.empty()) front_.clear();
  std::exchange(workspace_, nullptr)->giveBack(keys_, class_);  // the last owner may free it after
}

std::vector<std::uint32_t> RegionGrower::selected(std::uint32_t bound) const {
  std::vector<std::uint32_t> out;
  for (std::size_t v : touched_)
    if (keys_[v] <= bound) out.push_back(std::uint32_t(v));
  return out;
}

RegionGrower::RegionGrower(const QuantizedVolume& volume, const Eigen::Vector3i& seed, const GrowParams& params, std::shared_ptr<GrowWorkspace> workspace)
    : vol_(volume), params_(params) {
  const auto& g = volume.geometry;
  if (!g.contains(seed)) throw Error("region growing: the seed voxel lies outside the volume");
  if (!(params.hMax > 0.0) || !std::isfinite(params.hMax)) throw Error("region growing: h_max must be a positive number");
  if (!(params.sigmaFloor >= 0.0) || !std::isfinite(params.sigmaFloor)) throw Error("region growing: the sigma floor must be >= 0");
  if (!(params.coreFraction > 0.0 && params.coreFraction <= 1.0)) throw Error("region growing: the core fraction must lie in (0, 1]");
  if (params.criterion != GrowCriterion::Paper &&
      (params.refinements < 0 || params.refinements > 10 || !(params.probeRadiusMm > 0.0) || !(params.hRegion > 0.0) ||
       !(params.thinShare >= 0.0 && params.thinShare <= 1.0) ||
       (params.statistics != RegionStatistics::Moments && params.statistics != RegionStatistics::Robust) ||
       (params.bound != GrowBound::Ball && params.bound != GrowBound::Path)))
    throw Error("region growing: invalid refinement parameters");
  if (params.criterion != GrowCriterion::Paper && params.bound == GrowBound::Path && !(g.spacing.maxCoeff() < 1e5))
    throw Error("region growing: path keys need voxel spacings below 100 m");  // a step < 2^26 units: keys cannot overflow
  if (workspace) {  // every check is above: from here the arrays are the grower's (given back by its destructor, or below)
    workspace->lend(keys_, class_);
    workspace_ = std::move(workspace);
  }
  try {
    begin(seed);
  } catch (...) {  // the arrays back as they came (the destructor does not run)
    releaseWorkspace();
    throw;
  }
}

// The seed statistics and the criterion's probes (docs/region-growing.md).
void RegionGrower::begin(const Eigen::Vector3i& seed) {
  const GrowParams& params = params_;
  const auto& g = vol_.geometry;
  setup_.seed = seed;
  setup_.criterion = params.criterion;
  setup_.spacing = g.spacing.cast<float>();
  steps_ = growStepCosts(setup_.spacing);
  // Seed statistics over the 3x3x3 neighbourhood (edges clamped).
  double sum = 0, sum2 = 0;
  for (int dz = -1; dz <= 1; ++dz)
    for (int dy = -1; dy <= 1; ++dy)
      for (int dx = -1; dx <= 1; ++dx) {
        const int i = std::clamp(seed.x() + dx, 0, g.dims.x() - 1), j = std::clamp(seed.y() + dy, 0, g.dims.y() - 1),
                  k = std::clamp(seed.z() + dz, 0, g.dims.z() - 1);
        const double u = vol_.data[std::size_t(i) + std::size_t(g.dims.x()) * (std::size_t(j) + std::size_t(g.dims.y()) * std::size_t(k))];
        sum += u;
        sum2 += u * u;
      }
  const double mean = sum / 27.0;
  const double sigma = std::max(std::sqrt(std::max(0.0, sum2 / 27.0 - mean * mean)), params.sigmaFloor * 65535.0);
  const double tol = params.hMax * sigma;
  seedLinear_ = std::size_t(seed.x()) + std::size_t(g.dims.x()) * (std::size_t(seed.y()) + std::size_t(g.dims.y()) * std::size_t(seed.z()));
  if (params.criterion == GrowCriterion::Paper) {
    setup_.seedValue = float(vol_.data[seedLinear_]);
    setup_.tolerance = float(tol);
    restart();
    return;
  }
  refine(sum, tol);
  if (setup_.criterion == GrowCriterion::Core) {
    // A structure too thin for a core near the seed (a vessel, a cortex a few voxels thick) grows
    // under the smoothed criterion instead; setup() tells which one runs.
    growTo(params.probeRadiusMm);
    const std::size_t core = count(params.probeRadiusMm);
    setup_.criterion = GrowCriterion::Smoothed;
    setTolerance(tolerance_);
    restart();
    growTo(params.probeRadiusMm);
    if (double(core) >= params.thinShare * double(count(params.probeRadiusMm))) {
      setup_.criterion = GrowCriterion::Core;
      setTolerance(tolerance_);
      restart();
    } else {
      refine(sum, tol);  // the statistics again, from the region the smoothed criterion grows
    }
  }
  if (params.bound == GrowBound::Path) {  // the probes above ran in the ball; the selection grows along paths
    setup_.bound = GrowBound::Path;
    restart();
  }
}

void RegionGrower::refine(double seedSum, double seedTolerance) {
  setup_.seedValue = float(seedSum);  // 3x3x3 sum: the mean times 27, exact in float
  setTolerance(27.0 * seedTolerance);
  restart();
  for (int r = 0; r < params_.refinements; ++r) {
    growTo(params_.probeRadiusMm);
    double centre = 0, spread = 0;
    if (!regionStatistics(bound(params_.probeRadiusMm), centre, spread)) break;  // too small a region to say more than the seed did
    setup_.seedValue = float(27.0 * centre);
    setTolerance(27.0 * std::max(params_.hRegion * spread, seedTolerance));
    restart();
  }
}

bool RegionGrower::regionStatistics(std::uint32_t probe, double& centre, double& spread) const {
  if (params_.statistics == RegionStatistics::Moments) {
    // Integer sums: exact.
    std::uint64_t n = 0, s1 = 0, s2 = 0;
    for (std::size_t v : touched_)
      if (keys_[v] <= probe) {
        const std::uint64_t u = vol_.data[v];
        ++n;
        s1 += u;
        s2 += u * u;
      }
    if (n < 27) return false;
    centre = double(s1) / double(n);
    spread = std::sqrt(std::max(0.0, double(s2) / double(n) - centre * centre));
    return true;
  }
  // Robust: the median and the median absolute deviation of the 16-bit values, by selection (exact
  // integers; the upper median of an even count, so both are values of the sample).
  std::vector<std::uint32_t> values;
  for (std::size_t v : touched_)
    if (keys_[v] <= probe) values.push_back(vol_.data[v]);
  if (values.size() < 27) return false;
  const auto mid = values.begin() + std::ptrdiff_t(values.size() / 2);
  std::nth_element(values.begin(), mid, values.end());
  const std::uint32_t median = *mid;
  for (std::uint32_t& x : values) x = x > median ? x - median : median - x;
  std::nth_element(values.begin(), mid, values.end());
  centre = double(median);
  spread = 1.4826 * double(*mid);
  return true;
}

const char* regionStatisticsName(RegionStatistics s) { return s == RegionStatistics::Robust ? "robust" : "moments"; }

bool parseRegionStatistics(const std::string& s, RegionStatistics& out) {
  if (s == "robust") out = RegionStatistics::Robust;
  else if (s == "moments") out = RegionStatistics::Moments;
  else return false;
  return true;
}

void RegionGrower::setTolerance(double tolerance) {
  tolerance_ = tolerance;
  setup_.tolerance = float(tolerance);
  setup_.coreTolerance = setup_.criterion == GrowCriterion::Core ? float(params_.coreFraction * tolerance) : setup_.tolerance;
  for (std::size_t v : classified_) class_[v] = 0;  // the tests' answers change with the statistics
  classified_.clear();
}

bool RegionGrower::homogeneous(std::size_t v, int i, int j, int k) {
  std::uint8_t& c = class_[v];
  if (!(c & kKnown)) {
    if (c == 0) classified_.push_back(v);
    const float deviation = std::abs(value(i, j, k) - setup_.seedValue);
    c |= std::uint8_t(kKnown | (deviation < setup_.tolerance ? kHomogeneous : 0) | (deviation < setup_.coreTolerance ? kTight : 0));
  }
  return c & kHomogeneous;
}

bool RegionGrower::passesOn(std::size_t v) { return passesOn(v, vol_.geometry.voxelOf(v)); }

bool RegionGrower::passesOn(std::size_t v, const Eigen::Vector3i& x) {
  if (setup_.criterion != GrowCriterion::Core || v == seedLinear_) return true;
  if (!(class_[v] & kCoreKnown)) {
    const auto& d = vol_.geometry.dims;
    bool core = homogeneous(v, x.x(), x.y(), x.z()) && (class_[v] & kTight);
    // The six neighbours, clamped to the volume as the 3x3x3 means are (the GPU pass does the same).
    for (int n = 0; n < 6 && core; ++n) {
      Eigen::Vector3i q = x;
      q[n / 2] = std::clamp(q[n / 2] + ((n & 1) ? 1 : -1), 0, d[n / 2] - 1);
      core = homogeneous(std::size_t(q.x()) + std::size_t(d.x()) * (std::size_t(q.y()) + std::size_t(d.y()) * std::size_t(q.z())), q.x(), q.y(), q.z());
    }
    if (class_[v] == 0) classified_.push_back(v);
    class_[v] |= std::uint8_t(kCoreKnown | (core ? kCore : 0));
  }
  return class_[v] & kCore;
}

void RegionGrower::restart() {
  if (keys_.size() != vol_.geometry.voxelCount()) keys_.assign(vol_.geometry.voxelCount(), kUnreached);
  if (class_.size() != vol_.geometry.voxelCount()) class_.assign(vol_.geometry.voxelCount(), 0);
  for (std::size_t v : touched_) keys_[v] = kUnreached;  // only what the last growth reached
  touched_.clear();
  front_.clear();
  grown_ = -1.0;
  const std::size_t s = seedLinear_;
  keys_[s] = 0;  // the seed is always selected (key 0 in every criterion: step 0, distance 0)
  touched_.push_back(s);
  front_.push(0, s);
}

float RegionGrower::value(int i, int j, int k) const { return growValue(vol_, setup_.criterion, i, j, k); }

float growValue(const QuantizedVolume& volume, GrowCriterion criterion, int i, int j, int k) {
  const auto& d = volume.geometry.dims;
  const std::size_t sy = std::size_t(d.x()), sz = std::size_t(d.x()) * std::size_t(d.y());
  if (criterion == GrowCriterion::Paper) return float(volume.data[std::size_t(i) + sy * std::size_t(j) + sz * std::size_t(k)]);
  std::uint32_t sum = 0;  // 27 values below 2^16: exact, and exact in float too (below 2^24)
  if (i > 0 && j > 0 && k > 0 && i < d.x() - 1 && j < d.y() - 1 && k < d.z() - 1) {
    const std::uint16_t* p = volume.data.data() + (std::size_t(i - 1) + sy * std::size_t(j - 1) + sz * std::size_t(k - 1));
    for (int dz = 0; dz < 3; ++dz, p += sz)
      for (int dy = 0; dy < 3; ++dy) {
        const std::uint16_t* row = p + sy * std::size_t(dy);
        sum += std::uint32_t(row[0]) + row[1] + row[2];
      }
    return float(sum);
  }
  for (int dz = -1; dz <= 1; ++dz)  // at the volume's faces: edges clamped
    for (int dy = -1; dy <= 1; ++dy)
      for (int dx = -1; dx <= 1; ++dx)
        sum += volume.data[std::size_t(std::clamp(i + dx, 0, d.x() - 1)) + sy * std::size_t(std::clamp(j + dy, 0, d.y() - 1)) +
                         sz * std::size_t(std::clamp(k + dz, 0, d.z() - 1))];
  return float(sum);
}

bool RegionGrower::accepts(std::size_t linear) const {
  const Eigen::Vector3i v = vol_.geometry.voxelOf(linear);
  return std::abs(value(v.x(), v.y(), v.z()) - setup_.seedValue) < setup_.tolerance;
}

bool BoundaryRimRule::accepts(std::size_t linear) const {
  const Eigen::Vector3i v = volume->geometry.voxelOf(linear);
  return std::abs(growValue(*volume, setup.criterion, v.x(), v.y(), v.z()) - setup.seedValue) < setup.tolerance;
}

std::uint32_t RegionGrower::bound(double extentMm) const { return growKeyBound(setup_.criterion, setup_.bound, extentMm, vol_.geometry.spacing); }

void RegionGrower::growTo(double extentMm) {
  if (!std::isfinite(extentMm) || extentMm < 0.0) throw Error("region growing: the extent must be a finite number >= 0");
  if (extentMm <= grown_) return;
  const std::uint32_t limit = bound(extentMm);
  const auto& d = vol_.geometry.dims;
  const std::size_t sx = 1, sy = std::size_t(d.x()), sz = std::size_t(d.x()) * std::size_t(d.y());
  // Label-setting search (Dijkstra; for unit steps it is breadth-first): entries come out in key
  // order, so a voxel's first settled key is final. Entries beyond the limit wait for a later call.
  while (!front_.empty() && front_.top().first <= limit) {
    const auto [key, v] = front_.top();
    front_.pop();
    if (key != keys_[v]) continue;  // superseded
    const Eigen::Vector3i vox = vol_.geometry.voxelOf(v);
    if (!passesOn(v, vox)) continue;  // joins, but passes nothing on
    if (setup_.bound == GrowBound::Path) {  // never set under the paper criterion
      relaxPathSteps(key, vox);
      continue;
    }
    const int i = vox.x(), j = vox.y(), k = vox.z();
    const int ni[6] = {i - 1, i + 1, i, i, i, i}, nj[6] = {j, j, j - 1, j + 1, j, j}, nk[6] = {k, k, k, k, k - 1, k + 1};
    for (int n = 0; n < 6; ++n) {
      if (ni[n] < 0 || nj[n] < 0 || nk[n] < 0 || ni[n] >= d.x() || nj[n] >= d.y() || nk[n] >= d.z()) continue;
      const std::size_t u = std::size_t(ni[n]) * sx + std::size_t(nj[n]) * sy + std::size_t(nk[n]) * sz;
      std::uint32_t nkey;
      if (setup_.criterion == GrowCriterion::Paper) {
        nkey = key + 1;
      } else {
        nkey = std::max(key, floatKey(growDistance2(Eigen::Vector3i(ni[n], nj[n], nk[n]), setup_.seed, setup_.spacing)));
      }
      if (nkey >= keys_[u]) continue;
      if (!homogeneous(u, ni[n], nj[n], nk[n])) continue;
      push(u, nkey);
    }
  }
  grown_ = extentMm;
}

bool RegionGrower::passesThrough(const Eigen::Vector3i& w) {
  if (!vol_.geometry.contains(w)) return false;
  const std::size_t l = linearIndex(vol_.geometry, w);
  return l == seedLinear_ || (homogeneous(l, w.x(), w.y(), w.z()) && passesOn(l, w));
}

void RegionGrower::relaxPathSteps(std::uint32_t key, const Eigen::Vector3i& vox) {
  // The 26 neighbours; a step across an edge or a corner only where face steps through voxels that
  // pass growth on join the two too (one of the orders of its axes), so the 6-connected region is
  // the same as the ball's and only the lengths change.
  for (int dz = -1; dz <= 1; ++dz)
    for (int dy = -1; dy <= 1; ++dy)
      for (int dx = -1; dx <= 1; ++dx) {
        const Eigen::Vector3i step(dx, dy, dz), u = vox + step;
        const int mask = (dx != 0) | ((dy != 0) << 1) | ((dz != 0) << 2);
        if (mask == 0 || !vol_.geometry.contains(u)) continue;
        const std::size_t ul = linearIndex(vol_.geometry, u);
        const std::uint32_t nkey = key + steps_[std::size_t(mask)];  // key <= 4e9, a step < 2^26 (spacing < 100 m): no overflow
        if (nkey >= keys_[ul] || !homogeneous(ul, u.x(), u.y(), u.z())) continue;
        bool joined = mask == 1 || mask == 2 || mask == 4;
        if (!joined && (mask == 3 || mask == 5 || mask == 6)) {  // an edge: through either face neighbour
          const int a = mask == 6 ? 1 : 0, b = mask == 3 ? 1 : 2;
          Eigen::Vector3i wa = vox, wb = vox;
          wa[a] += step[a];
          wb[b] += step[b];
          joined = passesThrough(wa) || passesThrough(wb);
        }
        if (!joined && mask == 7) {  // a corner: through two voxels, in one of the six orders of the axes
          const int orders[6][2] = {{0, 1}, {0, 2}, {1, 0}, {1, 2}, {2, 0}, {2, 1}};
          for (const auto& o : orders) {
            Eigen::Vector3i w1 = vox;
            w1[o[0]] += step[o[0]];
            Eigen::Vector3i w2 = w1;
            w2[o[1]] += step[o[1]];
            if (passesThrough(w1) && passesThrough(w2)) {
              joined = true;
              break;
            }
          }
        }
        if (joined) push(ul, nkey);
      }
}

void RegionGrower::push(std::size_t v, std::uint32_t key) {
  if (keys_[v] == kUnreached) touched_.push_back(v);
  keys_[v] = key;
  front_.push(key, v);
}

std::vector<std::uint8_t> RegionGrower::mask(double extentMm) const {
  const std::uint32_t b = bound(extentMm);
  std::vector<std::uint8_t> m(keys_.size());
  for (std::size_t i = 0; i < keys_.size(); ++i) m[i] = keys_[i] <= b ? 1 : 0;
  return m;
}

std::size_t RegionGrower::count(double extentMm) const {
  const std::uint32_t b = bound(extentMm);
  return std::size_t(std::count_if(touched_.begin(), touched_.end(), [&](std::size_t v) { return keys_[v] <= b; }));
}

}  // namespace handson
