#include "distance_transform.h"

#include <algorithm>
#include <limits>

namespace handson {

namespace {

// 1D squared distance transform of f (sampled every `step` mm) into d: d[q] = min_p (q-p)^2 step^2 + f[p].
void edt1d(const std::vector<double>& f, std::vector<double>& d, double step, std::vector<int>& v, std::vector<double>& z) {
  const int n = int(f.size());
  const double inf = std::numeric_limits<double>::infinity();
  int k = 0;
  v[0] = 0;
  z[0] = -inf;
  z[1] = inf;
  auto sep = [&](int p, int q) {  // abscissa where the parabolas from p and q intersect
    return ((f[q] + q * q * step * step) - (f[p] + p * p * step * step)) / (2.0 * step * step * (q - p));
  };
  for (int q = 1; q < n; ++q) {
    if (f[q] == inf) continue;
    if (f[v[k]] == inf) {  // only infinite parabolas so far: replace
      v[k] = q;
      continue;
    }
    double s = sep(v[k], q);
    while (k > 0 && s <= z[k]) {
      --k;
      s = sep(v[k], q);
    }
    ++k;
    v[k] = q;
    z[k] = s;
    z[k + 1] = inf;
  }
  k = 0;
  for (int q = 0; q < n; ++q) {
    while (z[k + 1] < q) ++k;
    const double dq = (q - v[k]) * step;
    d[q] = f[v[k]] == inf ? inf : dq * dq + f[v[k]];
  }
}

// edt1d for a binary line (f 0 outside, infinite inside), in two scans: d[q] = ((q - p) step)^2 for
// the nearest p with f[p] = 0, infinite when there is none - the expression edt1d evaluates for the
// parabola it picks (the nearest zero; ties give the same value), so the same bits.
void edt1dBinary(const std::vector<double>& f, std::vector<double>& d, double step) {
  const int n = int(f.size());
  const double inf = std::numeric_limits<double>::infinity();
  int last = -1;
  for (int q = 0; q < n; ++q) {
    if (f[q] != inf) last = q;
    const double dq = (q - last) * step;
    d[q] = last < 0 ? inf : dq * dq;
  }
  int next = -1;
  for (int q = n - 1; q >= 0; --q) {
    if (f[q] != inf) next = q;
    if (next < 0) continue;
    const double dq = (q - next) * step;
    d[q] = std::min(d[q], dq * dq);
  }
}

bool allZero(const std::vector<double>& f) { return std::all_of(f.begin(), f.end(), [](double x) { return x == 0.0; }); }

}  // namespace

std::vector<float> squaredDistanceToOutside(const std::vector<std::uint8_t>& inside, const Eigen::Vector3i& dims,
                                            const Eigen::Vector3d& spacing) {
  const std::size_t nx = std::size_t(dims.x()), ny = std::size_t(dims.y()), nz = std::size_t(dims.z());
  const double inf = std::numeric_limits<double>::infinity();
  std::vector<double> g(inside.size());
  for (std::size_t i = 0; i < inside.size(); ++i) g[i] = inside[i] ? inf : 0.0;
  const std::size_t maxn = std::max({nx, ny, nz});
  std::vector<double> f(maxn), d(maxn), z(maxn + 1);
  std::vector<int> v(maxn);
  // The first pass sees the binary input (edt1dBinary); a later line of zeros (no voxel inside on
  // it, in the passes before) stays zeros, as edt1d would leave it. The y and z passes take up to
  // kBlock lines side by side in x, so that each cache line they read serves them all.
  constexpr std::size_t kBlock = 16;
  std::vector<double> lines(kBlock * maxn);
  bool first = true;
  auto pass = [&](std::size_t n, std::size_t stride, double step, auto&& blocks) {
    f.resize(n);
    d.resize(n);
    blocks([&](std::size_t base, std::size_t count) {  // lines base .. base + count - 1, each q * stride along
      for (std::size_t q = 0; q < n; ++q)
        for (std::size_t b = 0; b < count; ++b) lines[b * n + q] = g[base + b + q * stride];
      for (std::size_t b = 0; b < count; ++b) {
        std::copy_n(lines.begin() + std::ptrdiff_t(b * n), n, f.begin());
        if (first) edt1dBinary(f, d, step);
        else if (allZero(f)) continue;
        else edt1d(f, d, step, v, z);
        std::copy_n(d.begin(), n, lines.begin() + std::ptrdiff_t(b * n));
      }
      for (std::size_t q = 0; q < n; ++q)
        for (std::size_t b = 0; b < count; ++b) g[base + b + q * stride] = lines[b * n + q];
    });
    first = false;
  };
  pass(nx, 1, spacing.x(), [&](auto&& block) {
    for (std::size_t k = 0; k < nz; ++k)
      for (std::size_t j = 0; j < ny; ++j) block(nx * (j + ny * k), 1);
  });
  pass(ny, nx, spacing.y(), [&](auto&& block) {
    for (std::size_t k = 0; k < nz; ++k)
      for (std::size_t i = 0; i < nx; i += kBlock) block(i + nx * ny * k, std::min(kBlock, nx - i));
  });
  pass(nz, nx * ny, spacing.z(), [&](auto&& block) {
    for (std::size_t j = 0; j < ny; ++j)
      for (std::size_t i = 0; i < nx; i += kBlock) block(i + nx * j, std::min(kBlock, nx - i));
  });
  std::vector<float> out(g.size());
  for (std::size_t i = 0; i < g.size(); ++i) out[i] = g[i] == inf ? std::numeric_limits<float>::max() : float(g[i]);
  return out;
}

RegionDistance regionDistance(const std::vector<std::uint32_t>& region, const VolumeGeometry& g) {
  Eigen::Vector3i lo = Eigen::Vector3i::Constant(std::numeric_limits<int>::max()), hi = Eigen::Vector3i::Constant(std::numeric_limits<int>::min());
  for (std::uint32_t v : region) {
    lo = lo.cwiseMin(g.voxelOf(v));
    hi = hi.cwiseMax(g.voxelOf(v));
  }
  RegionDistance d{lo - Eigen::Vector3i::Ones(), hi - lo + Eigen::Vector3i::Constant(3), {}};
  std::vector<std::uint8_t> inside(std::size_t(d.dims.x()) * std::size_t(d.dims.y()) * std::size_t(d.dims.z()), 0);
  for (std::uint32_t v : region) inside[d.index(g.voxelOf(v))] = 1;
  d.d2 = squaredDistanceToOutside(inside, d.dims, g.spacing);
  return d;
}

std::uint32_t deepestVoxelOf(const std::vector<std::uint32_t>& region, const RegionDistance& d, const VolumeGeometry& g) {
  std::uint32_t best = region.front();
  float bestD = -1.0f;
  for (std::uint32_t v : region)
    if (d.at(g, v) > bestD) {
      bestD = d.at(g, v);
      best = v;
    }
  return best;
}

}  // namespace handson
