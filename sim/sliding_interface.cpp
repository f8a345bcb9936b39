#include "sim/sliding_interface.h"

#include <algorithm>
#include <cmath>
#include <string>

#include "sim/distance_transform.h"
#include "sim/base/error.h"

namespace handson {

std::vector<char> slidingHandles(const std::vector<SlideNode>& slide, std::size_t handleCount) {
  std::vector<char> out(handleCount, 0);
  for (const SlideNode& n : slide) out.at(std::size_t(n.handle)) = 1;
  return out;
}

std::vector<NormalSpring> slideSprings(const TetMesh& fine, const std::vector<SlideNode>& slide, const std::vector<RigidTransform>& handles) {
  std::vector<NormalSpring> out;
  out.reserve(slide.size());
  for (const SlideNode& s : slide) {
    if (s.handle < 0 || std::size_t(s.handle) >= handles.size()) throw Error("sliding interface: a slide node names handle " + std::to_string(s.handle + 1) + " of " + std::to_string(handles.size()));
    if (s.node < 0 || std::size_t(s.node) >= fine.nodes.size()) throw Error("sliding interface: a slide node outside the fine mesh");
    const RigidTransform& T = handles[std::size_t(s.handle)];
    out.push_back({s.node, s.stiffness, T.R * s.normal, T.apply(fine.nodes[std::size_t(s.node)])});
  }
  return out;
}

void addSpringForces(const std::vector<NormalSpring>& springs, const std::vector<Eigen::Vector3d>& x, std::vector<Eigen::Vector3d>& f) {
  for (const NormalSpring& s : springs) f[std::size_t(s.node)] -= s.stiffness * s.normal.dot(x[std::size_t(s.node)] - s.anchor) * s.normal;
}

double springEnergy(const std::vector<NormalSpring>& springs, const std::vector<Eigen::Vector3d>& x) {
  double e = 0.0;
  for (const NormalSpring& s : springs) {
    const double gap = s.normal.dot(x[std::size_t(s.node)] - s.anchor);
    e += 0.5 * s.stiffness * gap * gap;
  }
  return e;
}

void projectOntoSpringPlanes(const std::vector<NormalSpring>& springs, std::vector<Eigen::Vector3d>& x) {
  for (const NormalSpring& s : springs) x[std::size_t(s.node)] -= s.normal.dot(x[std::size_t(s.node)] - s.anchor) * s.normal;
}

void removeNormalParts(const std::vector<NormalSpring>& springs, std::vector<Eigen::Vector3d>& v) {
  for (const NormalSpring& s : springs) v[std::size_t(s.node)] -= s.normal.dot(v[std::size_t(s.node)]) * s.normal;
}

std::size_t claimEnclosedTissue(const TetMesh& fine, std::vector<int>& claimed, const std::vector<char>& fixed) {
  const std::size_t n = fine.nodes.size();
  if (claimed.size() != n || fixed.size() != n) throw Error("sliding interface: one role per fine node expected");
  // Node to tets, then a flood fill over unclaimed nodes from the held ones.
  std::vector<int> start(n + 1, 0), tetsOf;
  for (const auto& t : fine.tets)
    for (int v : t) ++start[std::size_t(v) + 1];
  for (std::size_t i = 0; i < n; ++i) start[i + 1] += start[i];
  tetsOf.resize(std::size_t(start[n]));
  std::vector<int> fill(start.begin(), start.end() - 1);
  for (std::size_t t = 0; t < fine.tets.size(); ++t)
    for (int v : fine.tets[t]) tetsOf[std::size_t(fill[std::size_t(v)]++)] = int(t);
  std::vector<char> reached(n, 0);
  std::vector<int> stack;
  for (std::size_t i = 0; i < n; ++i)
    if (fixed[i]) {  // held: the outer boundary wins over a handle on it
      reached[i] = 1;
      stack.push_back(int(i));
    }
  while (!stack.empty()) {
    const int v = stack.back();
    stack.pop_back();
    for (int k = start[std::size_t(v)]; k < start[std::size_t(v) + 1]; ++k)
      for (int w : fine.tets[std::size_t(tetsOf[std::size_t(k)])])
        if (!reached[std::size_t(w)] && claimed[std::size_t(w)] < 0) {
          reached[std::size_t(w)] = 1;
          stack.push_back(w);
        }
  }
  // Unreached tissue: claimed, from the outside in (each pass takes the nodes beside a claimed one).
  std::size_t count = 0;
  for (bool grew = true; grew;) {
    grew = false;
    for (std::size_t i = 0; i < n; ++i) {
      if (reached[i] || claimed[i] >= 0) continue;
      for (int k = start[i]; k < start[i + 1] && claimed[i] < 0; ++k)
        for (int w : fine.tets[std::size_t(tetsOf[std::size_t(k)])])
          if (claimed[std::size_t(w)] >= 0 && !fixed[std::size_t(w)]) {
            claimed[i] = claimed[std::size_t(w)];
            ++count;
            grew = true;
            break;
          }
    }
  }
  return count;
}

InterfaceNodes findInterfaceNodes(const TetMesh& fine, const std::vector<int>& claimed, const std::vector<char>& fixed) {
  if (claimed.size() != fine.nodes.size() || fixed.size() != fine.nodes.size()) throw Error("sliding interface: one role per fine node expected");
  InterfaceNodes out;
  out.handleTet.assign(fine.tets.size(), 0);
  std::vector<char> slide(fine.nodes.size(), 0);
  for (std::size_t t = 0; t < fine.tets.size(); ++t) {
    const auto& v = fine.tets[t];
    const int h = claimed[std::size_t(v[0])];
    const bool own = h >= 0 && std::all_of(v.begin(), v.end(), [&](int n) { return claimed[std::size_t(n)] == h; });
    if (own) {
      out.handleTet[t] = 1;
      continue;
    }
    for (int n : v)
      if (claimed[std::size_t(n)] >= 0 && !fixed[std::size_t(n)]) slide[std::size_t(n)] = 1;
  }
  for (std::size_t n = 0; n < slide.size(); ++n)
    if (slide[n]) {
      out.slideNodes.push_back(int(n));
      out.slideHandle.push_back(claimed[n]);
    }
  return out;
}

namespace {

std::size_t boxIndex(const HandleMask& m, const Eigen::Vector3i& l) {
  return std::size_t(l.x()) + std::size_t(m.dims.x()) * (std::size_t(l.y()) + std::size_t(m.dims.y()) * std::size_t(l.z()));
}

}  // namespace

bool HandleMask::contains(const Eigen::Vector3i& v) const {
  const Eigen::Vector3i l = v - lo;
  if ((l.array() < 0).any() || (l.array() >= dims.array()).any()) return false;
  return inside[boxIndex(*this, l)] != 0;
}

double HandleMask::depthAt(const VolumeGeometry& grid, const Eigen::Vector3d& p) const {
  const Eigen::Vector3i l = grid.toIndex(p).array().round().cast<int>().matrix() - lo;
  if ((l.array() < 0).any() || (l.array() >= dims.array()).any()) return 0.0;
  // The surface lies half a voxel beyond the last voxel inside (whose distance is one voxel).
  return std::max(0.0, double(depthMm[boxIndex(*this, l)]) - 0.5 * grid.spacing.minCoeff());
}

HandleMask handleMask(const VolumeGeometry& grid, const std::vector<std::uint32_t>& voxels) {
  if (voxels.empty()) throw Error("sliding interface: a handle with no voxels");
  HandleMask m;
  Eigen::Vector3i lo = Eigen::Vector3i::Constant(INT32_MAX), hi = Eigen::Vector3i::Constant(INT32_MIN);
  for (std::uint32_t v : voxels) {
    if (v >= grid.voxelCount()) throw Error("sliding interface: a handle voxel outside the image");
    const Eigen::Vector3i i = grid.voxelOf(v);
    lo = lo.cwiseMin(i);
    hi = hi.cwiseMax(i);
  }
  // One voxel of margin: the box's rim is outside, so every depth is measured to the mask's surface.
  m.lo = lo - Eigen::Vector3i::Ones();
  m.dims = hi - lo + Eigen::Vector3i::Constant(3);
  m.inside.assign(std::size_t(m.dims.x()) * std::size_t(m.dims.y()) * std::size_t(m.dims.z()), 0);
  for (std::uint32_t v : voxels) {
    m.inside[boxIndex(m, grid.voxelOf(v) - m.lo)] = 1;
    m.centroid += grid.toWorld(grid.voxelOf(v).cast<double>());
  }
  m.centroid /= double(voxels.size());
  m.depthMm = squaredDistanceToOutside(m.inside, m.dims, grid.spacing);
  for (float& d : m.depthMm) d = std::sqrt(d);
  return m;
}

Eigen::Vector3d maskNormal(const VolumeGeometry& grid, const HandleMask& mask, const Eigen::Vector3d& p, double radiusMm) {
  // A point below the surface (a slide node of a coarse mesh can lie a tet deep) reaches as far past
  // the surface as one on it: the neighbourhood's centroid then still lies along the normal.
  radiusMm += mask.depthAt(grid, p);
  const Eigen::Vector3d q = grid.toIndex(p);
  const Eigen::Matrix3d step = grid.direction * grid.spacing.asDiagonal();  // world offset of one index step per axis
  Eigen::Vector3i a, b;
  for (int k = 0; k < 3; ++k) {
    const double r = radiusMm / grid.spacing[k];
    a[k] = std::max(int(std::ceil(q[k] - r)), mask.lo[k]);
    b[k] = std::min(int(std::floor(q[k] + r)), mask.lo[k] + mask.dims[k] - 1);
  }
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  double count = 0;
  for (int z = a.z(); z <= b.z(); ++z)
    for (int y = a.y(); y <= b.y(); ++y)
      for (int x = a.x(); x <= b.x(); ++x) {
        const Eigen::Vector3d d = step * (Eigen::Vector3d(x, y, z) - q);
        if (d.squaredNorm() > radiusMm * radiusMm || !mask.contains({x, y, z})) continue;
        sum += d;
        count += 1;
      }
  Eigen::Vector3d n = count > 0 ? Eigen::Vector3d(-sum / count) : Eigen::Vector3d::Zero();
  if (!(n.norm() > 1e-6 * radiusMm)) n = p - mask.centroid;
  if (!(n.norm() > 0)) n = Eigen::Vector3d::UnitZ();
  return n.normalized();
}

}  // namespace handson
