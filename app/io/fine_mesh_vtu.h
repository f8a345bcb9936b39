#pragma once
// The fine mesh as the app's session export and `deform --mesh-out` write it, for ParaView: rest
// positions; point data displacement and dirichlet (1: a handle's or a held node); cell data
// youngs_modulus (kPa), poisson_ratio, coarse_element, strain (the largest principal stretch - 1, as
// shown: 0 on a sliding handle's own tets) and strain_over_limit (strain / the tet's band's limit,
// 0 where it has none: the limit highlight's value, past the limit above 1).
#include <string>
#include <vector>

#include "sim/sim_scene.h"

namespace handson {

struct FineMeshFields {
  const SimScene& scene;
  const std::vector<Eigen::Vector3d>& x;      ///< deformed fine nodes (world mm), one per scene node
  const std::vector<float>& strain;           ///< per fine tet, as shown (hideRigidStrain)
  const std::vector<float>& limits;           ///< per fine tet (tetStrainLimits)
  const std::vector<double>& coarseElement;   ///< per fine tet: the coarse model's element holding it
};

/// Writes atomically. Throws handson::Error on size mismatches or I/O failure.
void writeFineMeshVtu(const std::string& path, const FineMeshFields& f);

}  // namespace handson
