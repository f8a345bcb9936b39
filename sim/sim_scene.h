#pragma once
// The simulated scene of an image and its handles: the region of interest (a padded box around the
// handles, the cells of that box near the handles, or the whole volume), the nested coarse and fine meshes over it, a material per fine tet
// from the image values, and the fine nodes' Dirichlet roles (docs/simulation-model.md).
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "sim/adapted_mesh.h"
#include "sim/coarsening.h"
#include "sim/materials.h"
#include "sim/base/progress.h"
#include "sim/static_solver.h"
#include "sim/tet_mesh.h"
#include "sim/volume.h"

namespace handson {

struct SimHandle {
  std::vector<std::uint32_t> voxels;  ///< linear voxel indices on the image grid
  /// Poses the handle will be moved to: the region also covers the handle's box at each of them
  /// (plus the padding), so a handle never runs into the region's fixed faces.
  std::vector<RigidTransform> reach;
};

struct SimSettings {
  int coarseTets = 6000;      ///< target coarse element count over the region
  int fineTets = 300000;      ///< target fine element count (m^3 per coarse tet, m rounded)
  double paddingMm = 40.0;    ///< margin around the handles (their bounding box, or their shape)
  bool wholeVolume = false;   ///< simulate the image's whole box instead
  /// The region's shape (sim/region_shape.h): the handles' padded bounding box, all of it simulated
  /// (Box, the baseline), or only the grid cells within the padding of the handles' own voxels
  /// (Handles: the box's far corners held at rest).
  enum class Region : std::uint8_t { Box, Handles } region = Region::Box;
  /// The coarse model's elements (CoarseModel; sim/coarsening.h): grid cells by default, measured
  /// more accurate than the spec's coarse tets on the same coarse nodes (docs/simulation-model.md, `bench sim`).
  CoarseElement element = CoarseElement::Cell;
  /// How the coarse model iterates (CoarseModel::setSolver): the matrix-free PCG by default, the
  /// assembled warped-stiffness solve as the measured baseline (docs/simulation-model.md, `bench sim`).
  CoarseSolver coarseSolver = CoarseSolver::Pcg;
  /// Graded cells near the handles (CoarseGrading; a named option, not the default: measured more
  /// accurate at several times the frame, docs/simulation-model.md). Graded models are not cached.
  CoarseGrading grading;
  /// The fine mesh: the regular refinement of the coarse grid (default), or image-adapted (TetGen,
  /// sim/adapted_mesh.h: extra points at material boundaries; needs cell elements).
  enum class FineMesh { Regular, ImageAdapted } fineMesh = FineMesh::Regular;
  double adaptContrast = 10.0;  ///< image-adapted: a Young's modulus jump of this factor adds points
  MaterialTable materials = MaterialTable::ctDefault();
  /// Which fine nodes a handle moves rigidly (docs/tissue-physics.md, "What a handle holds"):
  /// Inside (default): the nodes whose nearest voxel is one of the handle's, so the handle holds what
  /// was selected and converges to its shape as the mesh is refined; a handle no node lands in (thinner
  /// than the fine mesh) falls back to Tets. Tets (the earlier rule): every node of each fine tet
  /// holding a handle voxel's centre - up to a tet beyond the selection, bone included.
  enum class HandleNodes : std::uint8_t { Inside, Tets } handleNodes = HandleNodes::Inside;
  /// Bone (sim/skeleton.h): Anchored (default): the skeleton told from contrast-enhanced tissue and
  /// held at rest where no handle holds it; ByValue (the earlier rule): bands by value alone, nothing
  /// anchored but the region's faces.
  enum class Bone : std::uint8_t { Anchored, ByValue } bone = Bone::Anchored;
  double skeletonReachMm = 15.0;  ///< how far spongy-band voxels may lie from compact bone (TissueMap)
  /// The region's outer boundary (docs/tissue-physics.md, "The region's boundary"): Exterior
  /// (default): the outermost layer of coarse cells stands for the tissue beyond the region, an elastic
  /// layer with the stiffness of an unbounded medium seen from the handles (its outer faces held);
  /// Wall (the earlier rule): the region's own tissue to its faces, held there.
  enum class Outer : std::uint8_t { Exterior, Wall } outer = Outer::Exterior;
  /// The interface between a handle and the tissue around it (sim/sliding_interface.h,
  /// docs/tissue-physics.md "Organs slide"): Sliding (default): frictionless and bilateral, the
  /// handle's surface nodes free to slide over it (the organ drawn rigidly where its pose puts it);
  /// Glued (the earlier rule): the handle's surface nodes move with it.
  enum class Interface : std::uint8_t { Glued, Sliding } interface = Interface::Sliding;
};

/// "glued" / "sliding"; and back (nullopt for anything else).
const char* interfaceName(SimSettings::Interface i);
std::optional<SimSettings::Interface> parseInterface(const std::string& name);


struct SimScene {
  Eigen::Vector3d lo, hi;              ///< region box (world mm, axis-aligned)
  NestedMeshes meshes;
  std::vector<int> band;               ///< per fine tet: material band, kExteriorBand (exterior layer), kRigidBand (a sliding handle's own)
  std::vector<double> youngs, poisson; ///< per fine tet
  std::vector<Mat12> fineK;            ///< rest stiffness per fine tet
  FineConstraints constraints;         ///< handle nodes (last claimer wins), the fixed outer faces and the anchored skeleton
  std::vector<Eigen::Vector3d> handleCentroid;  ///< world centroid of each handle's voxels
  std::vector<std::size_t> handleNodeCount;
  /// Region::Handles: per coarse grid cell, simulated (1) or held at rest (0); empty for a box.
  std::vector<char> regionCell;
  AdaptedMeshStats adapted;            ///< image-adapted fine mesh only
};

/// Builds the scene. Handles are claimed in order: a fine node touched by two handles belongs to the
/// later one. Throws handson::Error for an empty handle, a handle outside the image, or a region
/// that is empty after clipping to the image.
SimScene buildSimScene(const Volume& image, const std::vector<SimHandle>& handles, const SimSettings& settings, const ProgressFn& progress = {});

/// SimScene::handleNodeCount from the scene's fine node roles: the nodes each handle moves
/// rigidly (enclosed tissue included) and its sliding surface's.
void countHandleNodes(SimScene& scene, std::size_t handleCount);

/// The fine reference's material: the linear corotational model (the default, what the coarse model
/// condenses) or compressible Neo-Hookean (sim/neo_hookean.h: where the linear material stops holding).
enum class FineMaterial : std::uint8_t { Corotational, NeoHookean };
const char* fineMaterialName(FineMaterial m);

/// The fine static answer of `scene` with its handles at `handles`: handle nodes moved, held nodes at
/// rest, the sliding interfaces' springs at those poses (options.springs is replaced); the free nodes
/// start from `start` (default: at rest). Neo-Hookean: from the corotational answer (a start that
/// inverts no tet), its iterations counted in. Throws handson::Error as solveStatic does.
StaticSolveResult solveFineStatic(const SimScene& scene, const std::vector<RigidTransform>& handles, StaticSolveOptions options = {},
                                  const std::vector<Eigen::Vector3d>* start = nullptr, FineMaterial material = FineMaterial::Corotational);

/// The fine positions x of `scene` sampled at rest points (world mm): each point moves with the fine
/// tet holding it (linear interpolation); points outside the scene's meshes stay where they are. For
/// comparing models on different meshes.
std::vector<Eigen::Vector3d> sampleDeformation(const SimScene& scene, const std::vector<Eigen::Vector3d>& x, const std::vector<Eigen::Vector3d>& points);

/// Error of fine node positions against a reference, over the free nodes (not Dirichlet): RMS and
/// max of |x - x_ref| divided by the handles' RMS displacement, and the relative L2 of the
/// displacements.
struct DeformationError {
  double rmsOfMotion = 0, maxOfMotion = 0, relativeL2 = 0;
  double handleMotionMm = 0;
};
DeformationError compareDeformation(const SimScene& scene, const std::vector<RigidTransform>& handles, const std::vector<Eigen::Vector3d>& x,
                                    const std::vector<Eigen::Vector3d>& reference);

}  // namespace handson
