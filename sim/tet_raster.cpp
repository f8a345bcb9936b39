#include "tet_raster.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>

#include "sim/error.h"

namespace handson {

RasterStats rasterizeDeformed(const Volume& src, const TetMesh& mesh, const std::vector<Eigen::Vector3d>& deformed, const Eigen::Vector3d& lo,
                              const Eigen::Vector3d& hi, float background, Volume& out) {
  if (deformed.size() != mesh.nodes.size()) throw Error("rasterization: one deformed position per node expected");
  for (const auto& p : deformed)
    if (!p.allFinite()) throw Error("rasterization: a deformed node position is not finite");
  const VolumeGeometry& g = src.geometry();
  out = src;
  RasterStats st;
  const Eigen::Matrix4d w2i = g.worldToIndex();
  auto toIndex = [&](const Eigen::Vector3d& w) -> Eigen::Vector3d { return (w2i * w.homogeneous()).head<3>(); };
  const Eigen::Vector3i& d = g.dims;
  std::vector<char> written(src.voxelCount(), 0);
  // Clear the region's voxels (the rest box, in index space an oriented box: test each voxel of its
  // index bounding box).
  {
    Eigen::Vector3d ilo = Eigen::Vector3d::Constant(1e300), ihi = -ilo;
    for (int c = 0; c < 8; ++c) {
      const Eigen::Vector3d w((c & 1) ? hi.x() : lo.x(), (c & 2) ? hi.y() : lo.y(), (c & 4) ? hi.z() : lo.z());
      ilo = ilo.cwiseMin(toIndex(w));
      ihi = ihi.cwiseMax(toIndex(w));
    }
    const double eps = 1e-6;
    for (int k = std::max(0, int(std::ceil(ilo.z() - eps))); k <= std::min(d.z() - 1, int(std::floor(ihi.z() + eps))); ++k)
      for (int j = std::max(0, int(std::ceil(ilo.y() - eps))); j <= std::min(d.y() - 1, int(std::floor(ihi.y() + eps))); ++j)
        for (int i = std::max(0, int(std::ceil(ilo.x() - eps))); i <= std::min(d.x() - 1, int(std::floor(ihi.x() + eps))); ++i) {
          const Eigen::Vector3d w = g.toWorld(Eigen::Vector3d(i, j, k));
          if (((w - lo).array() >= -eps).all() && ((hi - w).array() >= -eps).all()) {
            out.setValue(i, j, k, background);
            ++st.regionVoxels;
          }
        }
  }
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
    const int i0 = std::max(0, int(std::ceil(bmin.x() - 1e-9))), i1 = std::min(d.x() - 1, int(std::floor(bmax.x() + 1e-9)));
    const int j0 = std::max(0, int(std::ceil(bmin.y() - 1e-9))), j1 = std::min(d.y() - 1, int(std::floor(bmax.y() + 1e-9)));
    const int k0 = std::max(0, int(std::ceil(bmin.z() - 1e-9))), k1 = std::min(d.z() - 1, int(std::floor(bmax.z() + 1e-9)));
    for (int k = k0; k <= k1; ++k)
      for (int j = j0; j <= j1; ++j)
        for (int i = i0; i <= i1; ++i) {
          const Eigen::Vector3d l = Dinv * (Eigen::Vector3d(i, j, k) - v[0]);
          const double l0 = 1.0 - l.sum();
          if (l.minCoeff() < -1e-9 || l0 < -1e-9) continue;
          const std::size_t lin = src.linearIndex(i, j, k);
          if (written[lin]) {
            ++st.overlaps;
            continue;
          }
          written[lin] = 1;
          ++st.covered;
          const Eigen::Vector3d rest = l0 * mesh.nodes[std::size_t(tet[0])] + l.x() * mesh.nodes[std::size_t(tet[1])] + l.y() * mesh.nodes[std::size_t(tet[2])] +
                                       l.z() * mesh.nodes[std::size_t(tet[3])];
          out.setValue(lin, src.sampleLinear(toIndex(rest)));
        }
  }
  return st;
}

}  // namespace handson
