#include "sim/tissue_limits.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <functional>
#include <limits>
#include <queue>
#include <utility>

#include "sim/base/error.h"

namespace handson {

NearestHandle nearestHandleOfNodes(const TetMesh& mesh, const FineConstraints& constraints, const std::vector<char>& moving) {
  const std::size_t n = mesh.nodes.size();
  if (constraints.handleOf.size() != n) throw Error("tissue limits: one handle role per fine node expected");
  if (!moving.empty() && moving.size() != std::size_t(std::max(constraints.handleCount, 0)))
    throw Error("tissue limits: one moving flag per handle expected");
  // Node adjacency: the six edges of every tet, as sorted, deduplicated neighbour lists.
  std::vector<std::vector<int>> adjacent(n);
  for (const auto& t : mesh.tets)
    for (int a = 0; a < 4; ++a)
      for (int b = a + 1; b < 4; ++b) {
        adjacent[std::size_t(t[std::size_t(a)])].push_back(t[std::size_t(b)]);
        adjacent[std::size_t(t[std::size_t(b)])].push_back(t[std::size_t(a)]);
      }
  for (auto& a : adjacent) {
    std::sort(a.begin(), a.end());
    a.erase(std::unique(a.begin(), a.end()), a.end());
  }
  NearestHandle out;
  out.handle.assign(n, -1);
  out.distance.assign(n, std::numeric_limits<double>::infinity());
  using Item = std::pair<double, int>;  // (distance, node)
  std::priority_queue<Item, std::vector<Item>, std::greater<Item>> queue;
  for (std::size_t i = 0; i < n; ++i)
    if (const int h = constraints.handleOf[i]; h >= 0 && (moving.empty() || (std::size_t(h) < moving.size() && moving[std::size_t(h)]))) {
      out.handle[i] = constraints.handleOf[i];
      out.distance[i] = 0.0;
      queue.push({0.0, int(i)});
    }
  while (!queue.empty()) {
    const auto [d, i] = queue.top();
    queue.pop();
    if (d > out.distance[std::size_t(i)]) continue;  // a stale entry
    for (int j : adjacent[std::size_t(i)]) {
      const double dj = d + (mesh.nodes[std::size_t(j)] - mesh.nodes[std::size_t(i)]).norm();
      if (dj < out.distance[std::size_t(j)]) {
        out.distance[std::size_t(j)] = dj;
        out.handle[std::size_t(j)] = out.handle[std::size_t(i)];
        queue.push({dj, j});
      }
    }
  }
  return out;
}

std::vector<float> tetStrainLimits(const std::vector<int>& bandOfTet, const MaterialTable& table) {
  std::vector<float> out(bandOfTet.size());
  for (std::size_t t = 0; t < bandOfTet.size(); ++t) {
    const int b = bandOfTet[t];
    if (b == kExteriorBand) {  // tissue beyond the region: no limit
      out[t] = std::numeric_limits<float>::infinity();
      continue;
    }
    if (b == kRigidBand) {  // a sliding handle's own: no limit, no strain shown
      out[t] = kRigidStrainLimit;
      continue;
    }
    if (b < 0 || std::size_t(b) >= table.bands().size()) throw Error("tissue limits: a tet names a material band the table does not have");
    out[t] = float(table.band(b).strainLimit);
  }
  return out;
}

void hideRigidStrain(std::vector<float>& strain, const std::vector<float>& limits) {
  if (strain.size() != limits.size()) throw Error("tissue limits: one strain limit per fine tet expected");
  for (std::size_t t = 0; t < strain.size(); ++t)
    if (limits[t] == kRigidStrainLimit) strain[t] = 0.0f;
}

Volume strainOverLimitVolume(const VolumeGeometry& grid, const std::vector<std::int32_t>& tetOf, const std::vector<float>& strain,
                             const std::vector<float>& limits) {
  if (tetOf.size() != grid.voxelCount()) throw Error("tissue limits: the tet map does not match the grid");
  if (limits.size() != strain.size()) throw Error("tissue limits: one strain limit per fine tet expected");
  Volume v(grid, ScalarType::Float32);
  for (std::size_t i = 0; i < tetOf.size(); ++i) {
    const std::int32_t t = tetOf[i];
    if (t < 0) continue;
    if (std::size_t(t) >= strain.size()) throw Error("tissue limits: a voxel names a tet that does not exist");
    const float s = strain[std::size_t(t)], l = limits[std::size_t(t)];
    if (std::isfinite(s) && s != 0.0f && std::isfinite(l) && l > 0.0f) v.setValue(i, s / l);
  }
  return v;
}

TissueLimitReport tissueLimits(const TetMesh& mesh, const std::vector<float>& strain, const std::vector<int>& bandOfTet,
                               const MaterialTable& table, const NearestHandle& nearest, int handleCount) {
  const std::size_t nt = mesh.tets.size();
  if (strain.size() != nt || bandOfTet.size() != nt) throw Error("tissue limits: one strain and one band per fine tet expected");
  if (nearest.handle.size() != mesh.nodes.size() || nearest.distance.size() != mesh.nodes.size())
    throw Error("tissue limits: one nearest handle per fine node expected");
  TissueLimitReport r;
  r.volumeByHandle.assign(std::size_t(std::max(handleCount, 0)), 0.0);
  std::vector<TissueLimitBand> byBand(table.bands().size());
  const std::vector<float> limits = tetStrainLimits(bandOfTet, table);
  for (std::size_t t = 0; t < nt; ++t) {
    if (!(limits[t] > 0.0f) || !(strain[t] > limits[t])) continue;  // within the limit, no limit (inf, rigid), or NaN
    const double volume = std::abs(mesh.signedVolume(int(t)));
    TissueLimitBand& b = byBand[std::size_t(bandOfTet[t])];
    ++b.tets;
    b.volumeMm3 += volume;
    b.worstRatio = std::max(b.worstRatio, double(strain[t]) / double(limits[t]));
    ++r.tets;
    r.volumeMm3 += volume;
    int handle = -1;
    double best = std::numeric_limits<double>::infinity();
    for (int v : mesh.tets[t])
      if (nearest.distance[std::size_t(v)] < best) {
        best = nearest.distance[std::size_t(v)];
        handle = nearest.handle[std::size_t(v)];
      }
    if (handle >= 0 && handle < handleCount) r.volumeByHandle[std::size_t(handle)] += volume;
  }
  for (std::size_t i = 0; i < byBand.size(); ++i)
    if (byBand[i].tets > 0) {
      byBand[i].band = int(i);
      byBand[i].name = table.band(int(i)).name;
      byBand[i].limit = table.band(int(i)).strainLimit;
      r.bands.push_back(byBand[i]);
    }
  std::stable_sort(r.bands.begin(), r.bands.end(), [](const TissueLimitBand& a, const TissueLimitBand& b) { return a.volumeMm3 > b.volumeMm3; });
  return r;
}

std::string describeTissueLimits(const TissueLimitReport& r, const std::vector<int>& handleIds) {
  if (!r.any()) return "none";
  auto cm3 = [](double mm3) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.2f cm³", mm3 / 1000.0);
    return std::string(buf);
  };
  std::string s = cm3(r.volumeMm3) + " (";
  for (std::size_t i = 0; i < r.bands.size(); ++i) {
    const auto& b = r.bands[i];
    char buf[96];
    std::snprintf(buf, sizeof buf, " at up to %.2fx its %.3g %% limit", b.worstRatio, b.limit * 100.0);
    s += (i ? ", " : "") + b.name + " " + cm3(b.volumeMm3) + buf;
  }
  s += ")";
  std::string from;
  for (std::size_t h = 0; h < r.volumeByHandle.size(); ++h)
    if (r.volumeByHandle[h] > 0.0) {
      const int id = h < handleIds.size() ? handleIds[h] : int(h) + 1;
      from += (from.empty() ? "" : ", ") + std::string("handle ") + std::to_string(id) + " (" + cm3(r.volumeByHandle[h]) + ")";
    }
  if (!from.empty()) s += ", from " + from;
  return s;
}

}  // namespace handson
