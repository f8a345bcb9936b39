#include "tet_raster.h"

#include <Eigen/Dense>
#include <algorithm>
#include <array>
#include <climits>
#include <cmath>

#include "sim/base/error.h"

namespace handson {

void regionVoxelBox(const VolumeGeometry& g, const Eigen::Vector3d& lo, const Eigen::Vector3d& hi, Eigen::Vector3i& ilo, Eigen::Vector3i& ihi) {
  regionVoxelBox(g.worldToIndex(), g.dims, lo, hi, ilo, ihi);
}

void regionVoxelBox(const Eigen::Matrix4d& w2i, const Eigen::Vector3i& dims, const Eigen::Vector3d& lo, const Eigen::Vector3d& hi, Eigen::Vector3i& ilo,
                    Eigen::Vector3i& ihi) {
  Eigen::Vector3d a = Eigen::Vector3d::Constant(1e300), b = -a;
  for (int c = 0; c < 8; ++c) {
    const Eigen::Vector3d w((c & 1) ? hi.x() : lo.x(), (c & 2) ? hi.y() : lo.y(), (c & 4) ? hi.z() : lo.z());
    const Eigen::Vector3d i = (w2i * w.homogeneous()).head<3>();
    a = a.cwiseMin(i);
    b = b.cwiseMax(i);
  }
  // A conservative index box (one voxel of margin); voxels are then tested in world space.
  for (int k = 0; k < 3; ++k) {
    ilo[k] = std::max(0, int(std::floor(std::clamp(a[k], -2.0, double(dims[k]) + 2.0))) - 1);
    ihi[k] = std::min(dims[k] - 1, int(std::ceil(std::clamp(b[k], -2.0, double(dims[k]) + 2.0))) + 1);
  }
}

std::uint64_t defaultMaxTetVoxels(const TetMesh& mesh, const Eigen::Matrix4d& w2i) {
  std::uint64_t most = 0;
  for (const auto& t : mesh.tets) {
    Eigen::Vector3d a = Eigen::Vector3d::Constant(1e300), b = -a;
    for (int c : t) {
      const Eigen::Vector3d p = (w2i * mesh.nodes[std::size_t(c)].homogeneous()).head<3>();
      a = a.cwiseMin(p);
      b = b.cwiseMax(p);
    }
    const Eigen::Vector3d e = (b - a).array().ceil() + 1.0;
    most = std::max<std::uint64_t>(most, std::uint64_t(std::min(e.prod(), 1e15)));
  }
  return std::max<std::uint64_t>(4096, 64 * most);
}

std::size_t takeRegionFromQuantized(Volume& image, const QuantizedVolume& q, const std::vector<std::uint16_t>& values, const Eigen::Vector3d& lo,
                                    const Eigen::Vector3d& hi) {
  if (values.size() != image.voxelCount()) throw Error("deformation: the deformed copy does not match the image");
  return forEachRegionVoxel(image.geometry(), lo, hi, [&](std::size_t lin) { image.setValue(lin, q.toValue(values[lin] / 65535.0f)); });
}

std::vector<RigidDraw> rigidDraws(const VolumeGeometry& g, const std::vector<std::uint32_t>& ids, const std::vector<RigidTransform>& T) {
  if (ids.size() != T.size()) throw Error("rasterization: one pose per handle drawn rigidly expected");
  const Eigen::Matrix4d w2i = g.worldToIndex();
  std::vector<RigidDraw> out;
  for (std::size_t h = 0; h < ids.size(); ++h) {
    if (ids[h] == 0) continue;
    if (ids[h] > 255) throw Error("rasterization: a handle id beyond the mask's 255");
    out.push_back({std::uint8_t(ids[h]), indexSpacePose(T[h].matrix(), w2i).inverse()});
  }
  return out;
}

std::array<Eigen::Vector3i, 2> voxelIndexBox(const VolumeGeometry& g, const std::vector<std::uint32_t>& voxels) {
  std::array<Eigen::Vector3i, 2> b{Eigen::Vector3i::Constant(INT_MAX), Eigen::Vector3i::Constant(INT_MIN)};
  for (std::uint32_t v : voxels) {
    const Eigen::Vector3i p = g.voxelOf(v);
    b[0] = b[0].cwiseMin(p);
    b[1] = b[1].cwiseMax(p);
  }
  return b;
}

namespace {

// The per-voxel rules of rasterizeDeformed's options: handles drawn rigidly, and the value of the
// tissue that slid onto their rest voxels (deform_resolve.comp is the GPU's copy).
class VoxelSource {
 public:
  VoxelSource(const Volume& src, const RasterOptions& o) : src_(src), o_(o), d_(src.geometry().dims) {
    for (const auto& r : o.rigid) {
      if (r.id == 0) throw Error("rasterization: a handle drawn rigidly needs an id above 0");
      rigidId_[r.id] = true;
    }
  }
  struct Sample {
    float value = 0.0f;
    std::uint8_t id = 0;
    bool rigid = false;
  };
  // The voxel (i, j, k) whose rest position in its tet is `ri` (index space).
  Sample at(const Eigen::Vector3i& v, const Eigen::Vector3d& ri) const {
    for (const auto& r : o_.rigid) {
      const Eigen::Vector3d p = (r.currentToRest * v.cast<double>().homogeneous()).head<3>();
      if ((p.array() < -0.5).any() || (p.array() >= d_.cast<double>().array() - 0.5).any()) continue;
      if (maskAt(nearest(p)) == r.id) return {src_.sampleLinear(p), r.id, true};
    }
    if (!o_.restMask) return {src_.sampleLinear(ri), 0, false};
    const std::uint8_t id = maskAt(nearest(ri));
    if (rigidId_[id]) return {nearestTissue(ri), 0, false};
    return {src_.sampleLinear(ri), id, false};
  }

 private:
  Eigen::Vector3i nearest(const Eigen::Vector3d& r) const {
    Eigen::Vector3i n;
    for (int a = 0; a < 3; ++a) n[a] = std::clamp(int(std::floor(r[a] + 0.5)), 0, d_[a] - 1);
    return n;
  }
  std::uint8_t maskAt(const Eigen::Vector3i& n) const { return (*o_.restMask)[src_.linearIndex(n.x(), n.y(), n.z())]; }
  // The value of the voxel nearest to r (within 2 voxels along each axis of its nearest voxel)
  // outside the handles drawn rigidly: the tissue beside a rest position on a handle's rim; the
  // plain trilinear when there is none (the first of equally near voxels, z, y, x ascending).
  float nearestTissue(const Eigen::Vector3d& r) const {
    const Eigen::Vector3i n = nearest(r);
    double best = 1e30;
    float value = src_.sampleLinear(r);
    for (int dz = -2; dz <= 2; ++dz)
      for (int dy = -2; dy <= 2; ++dy)
        for (int dx = -2; dx <= 2; ++dx) {
          const Eigen::Vector3i i = n + Eigen::Vector3i(dx, dy, dz);
          if ((i.array() < 0).any() || (i.array() >= d_.array()).any()) continue;
          const double d2 = (i.cast<double>() - r).squaredNorm();
          if (d2 >= best || rigidId_[maskAt(i)]) continue;
          best = d2;
          value = src_.value(src_.linearIndex(i.x(), i.y(), i.z()));
        }
    return value;
  }
  const Volume& src_;
  const RasterOptions& o_;
  Eigen::Vector3i d_;
  std::array<bool, 256> rigidId_{};
};

}  // namespace

RasterStats rasterizeDeformed(const Volume& src, const TetMesh& mesh, const std::vector<Eigen::Vector3d>& deformed, const RasterRegion& region,
                              Volume& out, const RasterOptions& options) {
  const Eigen::Vector3d& lo = region.lo;
  const Eigen::Vector3d& hi = region.hi;
  const float background = region.background;
  if (deformed.size() != mesh.nodes.size()) throw Error("rasterization: one deformed position per node expected");
  for (const auto& p : deformed)
    if (!p.allFinite()) throw Error("rasterization: a deformed node position is not finite");
  const std::vector<std::uint8_t>* restMask = options.restMask;
  std::vector<std::uint8_t>* outMask = options.outMask;
  std::vector<std::int32_t>* tetOf = options.tetOf;
  const std::uint64_t maxTetVoxels = options.maxTetVoxels;
  if (outMask && !restMask) throw Error("rasterization: a mask needs both its input and its output");
  if (!options.rigid.empty() && !restMask) throw Error("rasterization: handles drawn rigidly need the handles' mask");
  if (restMask && restMask->size() != src.voxelCount()) throw Error("rasterization: the mask does not match the image");
  const VoxelSource voxel(src, options);
  const VolumeGeometry& g = src.geometry();
  out = src;
  if (outMask) *outMask = *restMask;
  if (tetOf) tetOf->assign(src.voxelCount(), -1);
  if (mesh.tets.size() > std::size_t(INT32_MAX)) throw Error("rasterization: too many tets");
  RasterStats st;
  const Eigen::Matrix4d w2i = g.worldToIndex();
  auto toIndex = [&](const Eigen::Vector3d& w) -> Eigen::Vector3d { return (w2i * w.homogeneous()).head<3>(); };
  Eigen::Vector3i rlo, rhi;
  regionVoxelBox(g, lo, hi, rlo, rhi);
  // 1 where the voxel centre lies in the region (and may be written), 2 once written.
  std::vector<char> state(src.voxelCount(), 0);
  st.regionVoxels = forEachRegionVoxel(g, lo, hi, [&](std::size_t lin) {
    out.setValue(lin, background);
    if (outMask) (*outMask)[lin] = 0;
    state[lin] = 1;
  });
  for (std::size_t t = 0; t < mesh.tets.size(); ++t) {
    const auto& tet = mesh.tets[t];
    Eigen::Vector3d v[4];
    for (int c = 0; c < 4; ++c) v[c] = toIndex(deformed[std::size_t(tet[std::size_t(c)])]);
    Eigen::Matrix3d D;
    D << v[1] - v[0], v[2] - v[0], v[3] - v[0];
    const double det = D.determinant();
    if (!(std::abs(det) > 1e-12)) continue;  // collapsed: covers no voxel centre reliably
    const Eigen::Matrix3d Dinv = D.inverse();
    Eigen::Vector3d bmin = v[0], bmax = v[0];
    for (int c = 1; c < 4; ++c) {
      bmin = bmin.cwiseMin(v[c]);
      bmax = bmax.cwiseMax(v[c]);
    }
    const double m = kRasterBoxMargin;
    const int i0 = std::max(rlo.x(), int(std::ceil(std::max(bmin.x(), -2.0) - m))), i1 = std::min(rhi.x(), int(std::floor(std::min(bmax.x(), 1e9) + m)));
    const int j0 = std::max(rlo.y(), int(std::ceil(std::max(bmin.y(), -2.0) - m))), j1 = std::min(rhi.y(), int(std::floor(std::min(bmax.y(), 1e9) + m)));
    const int k0 = std::max(rlo.z(), int(std::ceil(std::max(bmin.z(), -2.0) - m))), k1 = std::min(rhi.z(), int(std::floor(std::min(bmax.z(), 1e9) + m)));
    if (i0 > i1 || j0 > j1 || k0 > k1) continue;
    if (std::uint64_t(i1 - i0 + 1) * std::uint64_t(j1 - j0 + 1) * std::uint64_t(k1 - k0 + 1) > maxTetVoxels) {
      ++st.skipped;  // as deform_claim.comp: a torn tet is not looped over
      continue;
    }
    for (int k = k0; k <= k1; ++k)
      for (int j = j0; j <= j1; ++j)
        for (int i = i0; i <= i1; ++i) {
          const Eigen::Vector3d l = Dinv * (Eigen::Vector3d(i, j, k) - v[0]);
          const double l0 = 1.0 - l.sum();
          if (l.minCoeff() < -kRasterTolerance || l0 < -kRasterTolerance) continue;
          const std::size_t lin = src.linearIndex(i, j, k);
          if (state[lin] == 0) continue;  // outside the region
          if (state[lin] == 2) {
            ++st.overlaps;
            continue;
          }
          state[lin] = 2;
          ++st.covered;
          const Eigen::Vector3d rest = l0 * mesh.nodes[std::size_t(tet[0])] + l.x() * mesh.nodes[std::size_t(tet[1])] + l.y() * mesh.nodes[std::size_t(tet[2])] +
                                       l.z() * mesh.nodes[std::size_t(tet[3])];
          const VoxelSource::Sample sm = voxel.at(Eigen::Vector3i(i, j, k), toIndex(rest));
          if (tetOf) (*tetOf)[lin] = sm.rigid ? kRigidVoxel : std::int32_t(t);
          out.setValue(lin, sm.value);
          if (outMask) (*outMask)[lin] = sm.id;
        }
  }
  return st;
}

}  // namespace handson
