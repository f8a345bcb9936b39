#include "fine_mesh_vtu.h"

#include <cmath>

#include "app/io/vtu_io.h"
#include "sim/base/error.h"

namespace handson {

void writeFineMeshVtu(const std::string& path, const FineMeshFields& f) {
  const SimScene& sc = f.scene;
  if (f.x.size() != sc.meshes.fine.nodes.size()) throw Error("vtu: the deformed nodes do not match the fine mesh");
  if (f.limits.size() != f.strain.size()) throw Error("vtu: the strain limits do not match the strain");
  std::vector<Eigen::Vector3d> disp(f.x.size());
  std::vector<double> dir(f.x.size()), strain(f.strain.begin(), f.strain.end()), overLimit(f.strain.size(), 0.0);
  for (std::size_t i = 0; i < f.x.size(); ++i) {
    disp[i] = f.x[i] - sc.meshes.fine.nodes[i];
    dir[i] = (sc.constraints.fixed[i] || sc.constraints.handleOf[i] >= 0) ? 1.0 : 0.0;
  }
  for (std::size_t t = 0; t < overLimit.size(); ++t)
    if (f.limits[t] > 0.0f && std::isfinite(f.limits[t]) && std::isfinite(f.strain[t])) overLimit[t] = f.strain[t] / f.limits[t];
  VtuArrays a;
  a.pointVectors = {{"displacement", &disp}};
  a.pointScalars = {{"dirichlet", &dir}};
  a.cellScalars = {{"youngs_modulus", &sc.youngs},     {"poisson_ratio", &sc.poisson}, {"coarse_element", &f.coarseElement},
                   {"strain", &strain},                {"strain_over_limit", &overLimit}};
  writeVtu(path, sc.meshes.fine, a);
}

}  // namespace handson
