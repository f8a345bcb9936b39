#include "sim/strain.h"

#include <Eigen/Dense>
#include <cmath>
#include <limits>

#include "sim/base/error.h"

namespace handson {

std::vector<float> tetStrain(const TetMesh& mesh, const std::vector<Eigen::Vector3d>& x) {
  if (x.size() != mesh.nodes.size()) throw Error("strain: one position per node expected");
  std::vector<float> out(mesh.tets.size());
  for (std::size_t t = 0; t < mesh.tets.size(); ++t) {
    const auto& tet = mesh.tets[t];
    Eigen::Matrix3d Dm, Ds;
    for (int c = 0; c < 3; ++c) {
      Dm.col(c) = mesh.nodes[std::size_t(tet[std::size_t(c + 1)])] - mesh.nodes[std::size_t(tet[0])];
      Ds.col(c) = x[std::size_t(tet[std::size_t(c + 1)])] - x[std::size_t(tet[0])];
    }
    const double det = Dm.determinant();
    if (!(std::abs(det) > 1e-12 * std::pow(Dm.norm(), 3)) || !Ds.allFinite()) {
      out[t] = std::numeric_limits<float>::quiet_NaN();
      continue;
    }
    const Eigen::Matrix3d F = Ds * Dm.inverse();
    out[t] = float(Eigen::JacobiSVD<Eigen::Matrix3d>(F).singularValues()[0] - 1.0);
  }
  return out;
}

Volume strainVolume(const VolumeGeometry& grid, const std::vector<std::int32_t>& tetOf, const std::vector<float>& strain) {
  if (tetOf.size() != grid.voxelCount()) throw Error("strain: the tet map does not match the grid");
  Volume v(grid, ScalarType::Float32);
  for (std::size_t i = 0; i < tetOf.size(); ++i) {
    const std::int32_t t = tetOf[i];
    if (t < 0) continue;
    if (std::size_t(t) >= strain.size()) throw Error("strain: a voxel names a tet that does not exist");
    const float s = strain[std::size_t(t)];
    v.setValue(i, std::isfinite(s) ? s : 0.0f);
  }
  return v;
}

}  // namespace handson
