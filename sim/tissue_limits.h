#pragma once
// Tissue past its limit (docs/simulation-outputs.md, "Tissue limits"): each fine tet's strain (the
// largest principal stretch - 1, sim/strain.h) against the strain limit of its material band (the
// band at its centroid, SimScene::band; the limits come from the material table), and the handle
// whose motion each such tet is put down to: the moving handle nearest to it along the fine mesh's
// edges at rest (in a scene of one moving handle, that handle; between two, the closer one; a held
// handle - a fixed mask - is never the cause).
#include <string>
#include <vector>

#include "sim/coarsening.h"  // FineConstraints
#include "sim/materials.h"
#include "sim/tet_mesh.h"
#include "sim/volume.h"

namespace handson {

/// Per fine node: the moving handle (0-based) nearest along the mesh's edges at rest, and that
/// distance (mm). Shortest paths from every node of a moving handle (Dijkstra over the tets' edges,
/// edge length as weight); nodes none reaches get -1 and +inf. `moving`: per handle, whether it
/// moves (held ones, 0, are no sources); empty: every handle moves.
struct NearestHandle {
  std::vector<int> handle;
  std::vector<double> distance;
};
NearestHandle nearestHandleOfNodes(const TetMesh& mesh, const FineConstraints& constraints, const std::vector<char>& moving = {});

/// The limit of a sliding handle's own tets (kRigidBand): they move rigidly with the handle, so they
/// have no limit, and their apparent strain (their outer nodes slide with the tissue) is not shown -
/// hideRigidStrain and the GPU strain pass show 0 there.
constexpr float kRigidStrainLimit = -1.0f;

/// Per fine tet: its band's strain limit (+inf where the band has none or in the exterior layer,
/// kRigidStrainLimit for a sliding handle's own tets). `bandOfTet`: indices into `table`, or those two.
std::vector<float> tetStrainLimits(const std::vector<int>& bandOfTet, const MaterialTable& table);

/// The strain as shown: 0 where the limit is kRigidStrainLimit. Throws handson::Error on a size mismatch.
void hideRigidStrain(std::vector<float>& strain, const std::vector<float>& limits);

/// The limit highlight's volume on the image's grid: each voxel the strain over its limit (float,
/// strain / limit) of the deformed tet that covers it (`tetOf` from rasterizeDeformed, -1: none), 0
/// where no tet does, where the tet's tissue has no limit (inf) or its strain is not finite; tissue
/// is past its limit where the value exceeds 1. The GPU's deform_strain_raster.comp writes the same.
Volume strainOverLimitVolume(const VolumeGeometry& grid, const std::vector<std::int32_t>& tetOf, const std::vector<float>& strain,
                             const std::vector<float>& limits);

struct TissueLimitBand {
  int band = 0;
  std::string name;
  double limit = 0.0;       ///< the band's strain limit (fraction)
  std::size_t tets = 0;     ///< fine tets of the band past it
  double volumeMm3 = 0.0;   ///< their rest volume
  double worstRatio = 0.0;  ///< largest strain / limit among them (> 1)
};

struct TissueLimitReport {
  std::vector<TissueLimitBand> bands;  ///< bands with tissue past their limit, most volume first
  std::vector<double> volumeByHandle;  ///< per handle: rest volume (mm³) past the limit put down to it
  std::size_t tets = 0;                ///< fine tets past their limit, all bands
  double volumeMm3 = 0.0;
  bool any() const { return tets > 0; }
};

/// The fine tets whose strain exceeds their limit (NaN strains are not counted), by band and by
/// handle: a tet is put down to the handle of its node nearest to a handle (`nearest`, from
/// nearestHandleOfNodes; tets no handle reaches count in the totals only). Throws handson::Error when
/// the sizes do not match the mesh.
TissueLimitReport tissueLimits(const TetMesh& mesh, const std::vector<float>& strain, const std::vector<int>& bandOfTet,
                               const MaterialTable& table, const NearestHandle& nearest, int handleCount);

/// One line for people: "none" or e.g. "2.40 cm³ (organ-and-blood 2.10 cm³ at up to 1.60x its 22 %
/// limit, fat 0.30 cm³ at up to 1.10x its 30 % limit), from handle 1 (2.40 cm³)". Handles are named
/// by `handleIds` (the app's ids, one per handle of the report) or, without them, 1, 2, ...
std::string describeTissueLimits(const TissueLimitReport& report, const std::vector<int>& handleIds = {});

}  // namespace handson
