// `handson deform`: move a handle rigidly and deform the surrounding tissue, from the command line.
#include <Eigen/Geometry>
#include <chrono>
#include <functional>
#include <cmath>
#include <filesystem>
#include <iomanip>
#include <iostream>
#include <memory>
#include <optional>

#include "app/cli/args.h"
#include "app/cli/commands.h"
#include "app/cli/deform_resample.h"
#include "app/io/forces_json.h"
#include "app/io/nifti_io.h"
#include "app/io/volume_io.h"
#include "app/io/fine_mesh_vtu.h"
#include "app/session/console.h"
#include "render/deform_pass.h"
#include "render/vk_context.h"
#include "sim/coarsening.h"
#include "sim/base/error.h"
#include "sim/handle_reaction.h"
#include "sim/quantized_volume.h"
#include "sim/scene_cache.h"
#include "sim/scene_cut.h"
#include "sim/sim_scene.h"
#include "sim/static_solver.h"
#include "sim/strain.h"
#include "sim/tet_raster.h"
#include "sim/tissue_limits.h"
#include "sim/two_level.h"

namespace handson::cli {

namespace {
const char* const kDeformHelp =
    "usage: handson deform PATH --handle MASK.nii.gz --translate-mm X,Y,Z -o DEFORMED.nii.gz [options]\n"
    "  Moves the handle (the mask's non-zero voxels) rigidly and deforms the tissue around it; writes the\n"
    "  deformed image on the input's grid (tetrahedral rasterization of the deformed fine mesh); an -o\n"
    "  ending in .nrrd writes NRRD (LPS space, as 3D Slicer writes it), anything else NIfTI. Prints the\n"
    "  volume of tissue strained past its limit (the material table's strain_limit column) and the\n"
    "  handle whose motion it is put down to (the nearest along the mesh).\n"
    "  --handle-label N        only the mask's voxels equal to N (a label map as the mask)\n"
    "  --frame N               the volume of a 4D NIfTI image to load (default 0)\n"
    "  --fixed MASK.nii.gz     voxels held in place (a fixed handle; wins where the masks overlap)\n"
    "  --fixed-label N         only the fixed mask's voxels equal to N\n"
    "  --rotate-deg AX,AY,AZ   rotation vector in RAS+ degrees about the handle's centroid (default 0)\n"
    "  --model coarse|fine     the interactive coarsened model (default) or the fine reference (static\n"
    "                          corotational FEM, projected Newton to 1e-6 of the handle's motion)\n"
    "  --fine-material corotational|neo-hookean  the fine reference's material: the linear corotational\n"
    "                          one (default) or compressible Neo-Hookean, solved from the corotational\n"
    "                          answer (where the linear material stops holding; --model fine only)\n"
    "  --refine-steps N        coarse model: two-level refinement steps toward the fine answer (default 0)\n"
    "  --coarse-tets N         coarse tets over the region (default 6000; 6 per grid cell)\n"
    "  --coarse-element cell|tet  the coarse model's elements: grid cells (default; 8 corners, the\n"
    "                          cell's diagonal faces condensed) or the coarse tets (the spec's)\n"
    "  --coarse-solver pcg|assembled  the coarse solve: matrix-free PCG (default) or the assembled\n"
    "                          warped stiffness (the old one, kept to compare); the same answer\n"
    "  --graded-split CELLS    graded cells (a named option, off by default): the coarse cells within\n"
    "                          CELLS cell sizes of a handle halved, their hanging corners tied to the\n"
    "                          whole cells; more accurate, several times the frame, pcg only, not cached\n"
    "  --handle-nodes inside|tets  the fine nodes the handle moves rigidly: those inside the selection\n"
    "                          (default: the handle holds what was selected) or every node of the fine\n"
    "                          tets holding its voxels (the earlier rule: up to a tet beyond it, bone too)\n"
    "  --bone anchored|by-value  bone anchored to the skeleton (default: compact bone and the spongy-bone\n"
    "                          values joined to it within 15 mm held at rest unless a handle holds them;\n"
    "                          spongy-bone values elsewhere, contrast-enhanced tissue, take the band below)\n"
    "                          or bands by value alone with nothing anchored (the earlier rule)\n"
    "  --outer-boundary exterior|wall  the region's outer boundary: an elastic layer standing for the\n"
    "                          unbounded tissue beyond it (default: its outermost coarse cells, as stiff\n"
    "                          as an infinite medium seen from the handle) or a wall of the region's own\n"
    "                          tissue held at rest (the earlier rule)\n"
    "  --interface sliding|glued  the handle's interface with the tissue around it: frictionless and\n"
    "                          bilateral, the tissue free to slide over the organ's surface, or glued to\n"
    "                          it (default sliding; docs/tissue-physics.md says why)\n"
    "  --fine-mesh regular|adapted  the regular refinement (default) or image-adapted: TetGen meshes\n"
    "                          each cell with extra points at stiffness jumps (cell elements only)\n"
    "  --adapt-contrast F      a Young's modulus jump of F or more adds points (default 10)\n"
    "  --cache-dir DIR|off     preprocessing cache for the coarse model (scene + condensed elements):\n"
    "                          default $HANDSON_CACHE_DIR, $XDG_CACHE_HOME/handson or ~/.cache/handson\n"
    "  --fine-tets N           fine elements (default 300000; m^3 per coarse tet, m rounded)\n"
    "  --padding-mm D          region of interest: the handles' box plus D mm (default 40)\n"
    "  --region box|handles    simulate the whole padded box, or only its cells within the padding of\n"
    "                          the handles themselves (the box's far corners held at rest)\n"
    "  --whole-volume          simulate the whole image box instead\n"
    "  --materials FILE        material table (default: assets/materials/ct-default.csv, built in)\n"
    "  --backend cpu|gpu       resampling on the CPU reference (default) or the Vulkan passes: for the\n"
    "                          coarse model the GPU interpolates the fine nodes from the coarse state;\n"
    "                          fine and refined positions are uploaded\n"
    "  --device NAME           Vulkan device for --backend gpu (default: automatic; see handson render)\n"
    "  --validation            Khronos validation layer on (any message is an error)\n"
    "  --strain-out S.nii.gz   the tissue's strain on the input's grid: per voxel, the largest principal\n"
    "                          stretch - 1 of the deformed fine tet covering it (0 outside the region)\n"
    "  --forces-out F.json     each handle's reaction: the force (N) and torque (N mm, about its current\n"
    "                          centroid) the tissue exerts on it, RAS; from the model that was solved (the\n"
    "                          coarse model's own is approximate, far off where bone shares its cells with\n"
    "                          the handle; --refine-steps 2 gives the fine model's within about 5 %)\n"
    "  --cut-quad X0,Y0,Z0,X1,Y1,Z1,X2,Y2,Z2,X3,Y3,Z3  (repeatable) cuts the tissue along a planar convex\n"
    "                          quad (RAS mm, corners in order) before the handle moves: the fine mesh\n"
    "                          separates along the faces over the quad between the tets on either side of\n"
    "                          its plane (docs/cutting.md). Seen by --model fine and by the coarse model\n"
    "                          (built on the cut scene, not cached: its cells split where the cut passes)\n"
    "  --retract-mm D          pulls the last cut's lip on the side away from the handle D mm away from\n"
    "                          the cut (a retractor: the tissue within --retract-width-mm W, default 10,\n"
    "                          of the cut and over it, a handle of its own, its force in --forces-out)\n"
    "  --mesh-out MESH.vtu     the fine mesh for ParaView: rest positions, point data displacement and\n"
    "                          dirichlet, cell data youngs_modulus, poisson_ratio, coarse_element (the\n"
    "                          coarse model's element: grid cell or coarse tet), strain and\n"
    "                          strain_over_limit (strain / the tissue's limit; 0 where it has none)\n"
    "  --quiet                 no progress output\n";

double seconds(std::chrono::steady_clock::time_point t0) { return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(); }

// The scene's one-line summary: region, meshes, handle nodes (and the simulated cells of a shaped region).
void printScene(const SimScene& sc) {
  std::cout << std::fixed << std::setprecision(1) << "region: (" << sc.lo.x() << ", " << sc.lo.y() << ", " << sc.lo.z() << ") .. (" << sc.hi.x() << ", "
            << sc.hi.y() << ", " << sc.hi.z() << ") mm; coarse " << sc.meshes.coarse.tets.size() << " tets, fine " << sc.meshes.fine.tets.size()
            << " tets (" << (sc.meshes.regularFine ? std::to_string(sc.meshes.refinement) + "^3 per coarse tet"
                                                   : "image-adapted: " + std::to_string(sc.adapted.structurePoints) + " points at stiffness jumps, " +
                                                         std::to_string(sc.adapted.fallbackCells) + " cells left regular")
            << "); handle nodes " << sc.handleNodeCount[0];
  if (!sc.regionCell.empty())
    std::cout << "; cells simulated " << std::count(sc.regionCell.begin(), sc.regionCell.end(), 1) << " of " << sc.regionCell.size() << " (shaped by the handles)";
  std::cout << "\n";
}

}  // namespace

// The fine static solve through `steps` increments of the motion (transformsAt(k / steps)), each
// starting from the last; a solve that stops unconverged is reported and the next goes on from it.
static std::vector<Eigen::Vector3d> solveFineInIncrements(const SimScene& sc, const std::function<std::vector<RigidTransform>(double)>& transformsAt, int steps,
                                                          const ProgressFn& progress, FineMaterial material) {
  std::vector<Eigen::Vector3d> x = sc.meshes.fine.nodes;
  for (int k = 1; k <= steps; ++k) {
    StaticSolveOptions o;
    o.progress = progress;
    const auto r = solveFineStatic(sc, transformsAt(double(k) / steps), o, &x, material);
    if (!r.converged) std::cerr << "warning: the fine solve stopped after " << r.iterations << " iterations (last update " << r.lastUpdate << " mm)\n";
    x = r.x;
  }
  return x;
}

namespace {

// What `handson deform` was asked, parsed and checked.
struct DeformRequest {
  Eigen::Vector3d translation = Eigen::Vector3d::Zero(), rotation = Eigen::Vector3d::Zero();  ///< mm; rotation vector in radians
  std::string model, backend;
  FineMaterial material = FineMaterial::Corotational;
  SimSettings settings;
  int refineSteps = 0;
  std::filesystem::path cacheDir;  ///< empty: no cache
  bool quiet = false;
  std::vector<CutQuad> cuts;  ///< --cut-quad, in order
  double retractMm = 0.0, retractWidthMm = 10.0;  ///< --retract-mm, --retract-width-mm: the last cut's lip pulled
  bool coarseOnly() const { return model == "coarse" && refineSteps == 0; }
};

// --cut-quad: twelve numbers, a planar convex quad.
std::vector<CutQuad> cutOptions(const Args& args) {
  std::vector<CutQuad> cuts;
  for (const std::string& text : args.values("--cut-quad")) {
    const std::vector<double> v = parseNumberList(text, "--cut-quad");
    if (v.size() != 12) throw UsageError("--cut-quad takes twelve numbers: the quad's four corners X,Y,Z in order");
    CutQuad q;
    for (int c = 0; c < 4; ++c) q.corners[std::size_t(c)] = Eigen::Vector3d(v[std::size_t(3 * c)], v[std::size_t(3 * c + 1)], v[std::size_t(3 * c + 2)]);
    try {
      checkCutQuad(q);
    } catch (const Error& e) {
      throw UsageError(std::string("--cut-quad: ") + e.what());
    }
    cuts.push_back(q);
  }
  return cuts;
}

DeformRequest parseDeformRequest(const Args& args) {
  DeformRequest r;
  const auto tr = parseNumberList(*args.value("--translate-mm"), "--translate-mm");
  const auto rot = parseNumberList(args.valueOr("--rotate-deg", "0,0,0"), "--rotate-deg");
  if (tr.size() != 3 || rot.size() != 3) throw UsageError("--translate-mm and --rotate-deg take three numbers");
  r.translation = Eigen::Vector3d(tr[0], tr[1], tr[2]);
  r.rotation = Eigen::Vector3d(rot[0], rot[1], rot[2]) * (M_PI / 180.0);
  if (r.translation.norm() > 1000.0 || r.rotation.norm() > 4 * M_PI) throw UsageError("--translate-mm beyond 1 m or --rotate-deg beyond 720 degrees");
  r.model = args.valueOr("--model", "coarse");
  if (r.model != "coarse" && r.model != "fine") throw UsageError("--model must be coarse or fine");
  r.material = fineMaterialOption(args, r.model == "fine");
  r.backend = args.valueOr("--backend", "cpu");
  if (r.backend != "cpu" && r.backend != "gpu") throw UsageError("--backend must be cpu or gpu");
  SimSettings& s = r.settings;
  s.coarseTets = int(args.integer("--coarse-tets", s.coarseTets, 6, 2000000));
  s.fineTets = int(args.integer("--fine-tets", s.fineTets, 6, 20000000));
  if (s.fineTets < s.coarseTets) throw UsageError("--fine-tets must be at least --coarse-tets");
  s.paddingMm = args.number("--padding-mm", s.paddingMm, 0.0, 1e4);
  regionOption(args, "--region", s);
  s.wholeVolume = args.flag("--whole-volume");
  coarseModelOptions(args, "--", s);
  fineMeshOptions(args, "--fine-mesh", "--adapt-contrast", s);
  if (auto m = args.value("--materials")) s.materials = MaterialTable::load(*m);
  r.refineSteps = int(args.integer("--refine-steps", 0, 0, 1000));
  const std::string cacheArg = args.valueOr("--cache-dir", defaultSimulationCacheDir().string());
  r.cacheDir = cacheArg == "off" ? std::filesystem::path() : std::filesystem::path(cacheArg);
  r.quiet = args.flag("--quiet");
  r.cuts = cutOptions(args);
  r.retractMm = args.number("--retract-mm", 0.0, 0.0, 200.0);
  r.retractWidthMm = args.number("--retract-width-mm", 10.0, 0.1, 200.0);
  if (r.retractMm > 0.0 && r.cuts.empty()) throw UsageError("--retract-mm pulls a cut's lip: give the cut (--cut-quad)");
  return r;
}

// The moved handle (and the fixed one, when given); the region covers where the handle goes too.
std::vector<SimHandle> loadHandles(const Args& args, const Volume& image, const DeformRequest& r) {
  auto labelOf = [&](const char* opt) { return args.value(opt) ? std::optional<long>(args.integer(opt, 0, 1, 65535)) : std::nullopt; };
  std::vector<SimHandle> handles{{maskVoxels(*args.value("--handle"), image, "handle mask", labelOf("--handle-label")), {}}};
  if (auto f = args.value("--fixed")) handles.push_back({maskVoxels(*f, image, "fixed mask", labelOf("--fixed-label")), {}});
  const VolumeGeometry& g = image.geometry();
  Eigen::Vector3d c = Eigen::Vector3d::Zero();  // the handle's centroid, from its voxels
  for (std::uint32_t v : handles[0].voxels) c += g.toWorld(g.voxelOf(v).cast<double>());
  c /= double(handles[0].voxels.size());
  handles[0].reach.push_back(RigidTransform::about(c, r.rotation, r.translation));
  return handles;
}

// The scene solved at the requested motion (not to be moved: its model refers to its scene).
struct DeformSolution {
  DeformSolution() = default;
  DeformSolution(const DeformSolution&) = delete;
  DeformSolution& operator=(const DeformSolution&) = delete;
  SimScene scene;                      ///< the scene solved, cut (--cut-quad) and with its retractor (--retract-mm)
  std::unique_ptr<CoarseModel> model;  ///< null for the fine model
  std::vector<RigidTransform> T;       ///< the handles' poses (a retractor's last)
  std::vector<RigidTransform> drawn;   ///< the poses of the handles given (drawn rigidly where they slide; no retractor)
  std::vector<Eigen::Vector3d> x, xc;  ///< fine positions; the coarse state (coarse model)
  int steps = 1;                       ///< increments of the motion
  double sceneSeconds = 0, solveSeconds = 0;
};

// --retract-mm: a retractor on the last cut's lip, on the side away from the moved handle, added to
// the scene the fine positions are on; its translation (zero: none), away from the cut.
Eigen::Vector3d addRetractor(SimScene& shown, const DeformRequest& r) {
  if (!(r.retractMm > 0.0)) return Eigen::Vector3d::Zero();
  const CutLip lip = lipAwayFrom(r.cuts.back(), shown.handleCentroid[0], r.retractWidthMm);
  const int handle = addLipHandle(shown, lip);
  std::cout << "retractor: the cut's lip (" << shown.handleNodeCount[std::size_t(handle)] << " fine nodes) pulled " << r.retractMm << " mm away from it\n";
  return r.retractMm * lip.side * cutPlane(lip.quad).n;
}

// Fills `d` in place: its coarse model keeps a reference to its scene's meshes, so the solution is
// never moved.
void solveDeform(const DeformRequest& r, const Volume& image, const std::vector<SimHandle>& handles, const ProgressFn& progress, DeformSolution& d) {
  SimScene& sc = d.scene;
  auto t0 = std::chrono::steady_clock::now();
  // The coarse model of an uncut scene comes with it from the preprocessing cache when there (built
  // and saved otherwise); a cut scene's is built on the cut scene, its cells split where the cut
  // passes (docs/cutting.md); the fine model needs only the scene.
  const bool cached = r.model == "coarse" && r.cuts.empty();
  if (cached) {
    CacheOutcome co;
    d.model = buildOrLoadSimulation(image, handles, r.settings, sc, {r.cacheDir, &co}, progress);
    if (co.hit) std::cout << "preprocessing loaded from the cache in " << r.cacheDir.string() << "\n";
    if (!co.note.empty()) std::cerr << "note: " << co.note << "\n";
  } else {
    sc = buildSimScene(image, handles, r.settings, progress);
  }
  const SceneCutStats cut = cutScene(sc, r.cuts);
  printScene(sc);
  if (!r.cuts.empty()) std::cout << "cut: " << r.cuts.size() << " quad(s), " << cut.cutFaces << " faces separated, " << cut.copiedNodes << " nodes copied\n";
  const Eigen::Vector3d retract = addRetractor(sc, r);
  if (r.model == "coarse" && !cached) {
    d.model = std::make_unique<CoarseModel>(sc.meshes, sc.fineK, sc.constraints, progress, r.settings.element, r.settings.grading);
    d.model->setSolver(r.settings.coarseSolver);
    std::cout << "coarse model of the cut scene: " << d.model->elementCount() << " elements on " << sc.meshes.coarseGrid.cellCount() << " cells, "
              << d.model->restState().size() << " coarse nodes (" << sc.meshes.coarse.nodes.size() << " uncut)\n";
  }
  d.sceneSeconds = seconds(t0);
  // Large motions are applied in increments of at most 30 degrees and 10 mm (a retractor's pull
  // too), each solve starting from the previous one (continuation keeps the Newton and corotational
  // iterations in their basin).
  d.steps = std::max({1, int(std::ceil(r.rotation.norm() / (M_PI / 6))), int(std::ceil(r.translation.norm() / 10.0)), int(std::ceil(r.retractMm / 10.0))});
  // The handles' poses: the moved one, the fixed one, the retractor.
  auto transformsAt = [&](double f) {
    std::vector<RigidTransform> T{RigidTransform::about(sc.handleCentroid[0], f * r.rotation, f * r.translation)};
    if (handles.size() > 1) T.push_back(RigidTransform{});
    if (retract.squaredNorm() > 0.0) T.push_back(RigidTransform{Eigen::Matrix3d::Identity(), f * retract});
    return T;
  };
  d.T = transformsAt(1.0);
  d.drawn = transformsAt(1.0);
  d.drawn.resize(handles.size());
  t0 = std::chrono::steady_clock::now();
  if (!d.model) {
    d.x = solveFineInIncrements(sc, transformsAt, d.steps, progress, r.material);
  } else {
    CoarseModel& m = *d.model;
    d.xc = m.restState();
    // To convergence, not a frame's budget (kOneOffSolveIterations); a solve that stops short says so.
    for (int k = 1; k <= d.steps; ++k) {
      const CoarseSolveStats st = m.solve(transformsAt(double(k) / d.steps), d.xc, kOneOffSolveIterations);
      if (!st.converged)
        std::cerr << "warning: the coarse model did not converge in " << st.iterations << " iterations (last update " << st.lastUpdate
                  << " mm): its answer is approximate\n";
    }
    d.x = m.reconstruct(d.T, d.xc);
    if (r.refineSteps > 0) {
      FineRefiner refiner(m, sc.fineK, sc.youngs, sc.poisson);
      for (int k = 0; k < r.refineSteps; ++k) refiner.step(d.T, d.xc, d.x, 10);
    }
  }
  d.solveSeconds = seconds(t0);
}

// The deformed volume on the chosen backend; with `tetOf` (CPU) which tet wrote each voxel.
struct DeformImage {
  Volume out;
  std::size_t regionVoxels = 0, covered = 0;
  double seconds = 0;
};

DeformImage resampleDeform(const Args& args, const DeformRequest& r, const Volume& image, const DeformSolution& d, const RigidHandles& rigid,
                           RasterOptions raster) {
  DeformImage im;
  const auto t0 = std::chrono::steady_clock::now();
  const SimScene& sc = d.scene;
  if (r.backend == "cpu") {
    const auto rs = rasterizeDeformed(image, sc.meshes.fine, d.x, {sc.lo, sc.hi, image.valueRange().first}, im.out, raster);
    im.regionVoxels = rs.regionVoxels;
    im.covered = rs.covered;
  } else {
    vk::ContextOptions co;
    co.device = args.valueOr("--device", "");
    co.validation = args.flag("--validation");
    co.verbose = !r.quiet;
    GpuResample g = resampleOnNewDevice(co, image, {&sc, d.model.get(), d.drawn, &d.xc, &d.x, r.coarseOnly(), &rigid, d.T});
    im.out = std::move(g.image);
    im.regionVoxels = g.regionVoxels;
    im.covered = g.covered;
  }
  im.seconds = seconds(t0);
  return im;
}

// The tissue past its strain limit, from the moved handle (a --fixed mask is never the cause).
TissueLimitReport movedHandleLimits(const SimScene& sc, const std::vector<float>& strain, const MaterialTable& materials) {
  std::vector<char> moving(std::size_t(sc.constraints.handleCount), 0);
  moving[0] = 1;
  return tissueLimits(sc.meshes.fine, strain, sc.band, materials, nearestHandleOfNodes(sc.meshes.fine, sc.constraints, moving), sc.constraints.handleCount);
}

// The run's summary on stdout: timings, the motion, the resampling and the tissue past its limit.
void printDeformSummary(const DeformRequest& r, const DeformSolution& d, const DeformImage& im, const TissueLimitReport& limits, const std::string& outPath) {
  const auto& fine = d.scene.meshes.fine;
  double maxDisp = 0;
  for (std::size_t i = 0; i < d.x.size(); ++i) maxDisp = std::max(maxDisp, (d.x[i] - fine.nodes[i]).norm());
  // The coarse model's preprocessing (scene and coarsening, or their cache) is one step.
  std::cout << std::setprecision(3) << "model " << r.model << ": " << (r.model == "coarse" ? "scene + coarsening " : "scene ") << d.sceneSeconds << " s, ";
  std::cout << "solve " << d.solveSeconds << " s (" << d.steps << " increment" << (d.steps > 1 ? "s" : "") << "), resampling " << im.seconds << " s\n"
            << "largest displacement " << maxDisp << " mm; inverted fine tets " << countInvertedTets(fine, d.x) << "; region voxels " << im.regionVoxels
            << ", covered " << im.covered << " (" << r.backend << ")\ntissue past its strain limit: " << describeTissueLimits(limits) << "\nwrote "
            << outPath << "\n";
}

// The fine mesh for ParaView (app/io/fine_mesh_vtu.h), each tet's coarse element a grid cell or a
// coarse tet (the model's own: a cut splits cells into elements).
void writeMesh(const std::string& path, const DeformSolution& d, const std::vector<float>& strain, const std::vector<float>& limits, CoarseElement element) {
  const SimScene& sc = d.scene;
  std::vector<double> coarseEl(sc.meshes.fine.tets.size());
  for (std::size_t t = 0; t < coarseEl.size(); ++t)
    coarseEl[t] = d.model ? d.model->elementOfFineTet(t) : element == CoarseElement::Cell ? sc.meshes.fineParent[t] / 6 : sc.meshes.fineParent[t];
  writeFineMeshVtu(path, {sc, d.x, strain, limits, coarseEl});
}

// --forces-out: the reactions of the model that was solved: the coarse model's own, or the fine
// tets' at the fine or refined positions.
void writeForces(const std::string& path, const DeformRequest& r, const DeformSolution& d) {
  const SimScene& sc = d.scene;
  const auto hyper = r.material == FineMaterial::NeoHookean ? neoHookeanTets(sc.meshes.fine, sc.youngs, sc.poisson) : std::vector<NeoHookeanTet>{};
  writeForcesJson(path,
                  r.coarseOnly() ? d.model->handleReactions(d.T, d.xc)
                                 : fineHandleReactions(sc.meshes.fine, sc.fineK, sc.constraints, d.T, d.x, hyper.empty() ? nullptr : &hyper),
                  r.coarseOnly() ? "coarse" : r.model == "fine" ? "fine" : "refined");
}

}  // namespace

int cmdDeform(const Words& words) {
  Args args(words,
            {"--frame", "--handle", "--fixed", "--translate-mm", "--rotate-deg", "--model", "--refine-steps", "--coarse-tets", "--fine-tets", "--padding-mm", "--region",
             "--materials", "--backend", "-o", "--mesh-out", "--handle-label", "--fixed-label", "--device", "--coarse-element", "--coarse-solver", "--graded-split", "--fine-mesh", "--adapt-contrast", "--cache-dir", "--forces-out", "--strain-out", "--cut-quad", "--retract-mm", "--retract-width-mm",
             "--handle-nodes", "--bone", "--outer-boundary", "--interface", "--fine-material"},
            {"--whole-volume", "--quiet", "--validation"});
  if (args.help() || args.positional().size() != 1 || !args.value("--handle") || !args.value("--translate-mm") || !args.value("-o")) {
    usageStream(args) << kDeformHelp;
    return args.help() ? 0 : 2;
  }
  const DeformRequest r = parseDeformRequest(args);
  const ProgressFn progress = r.quiet ? ProgressFn{} : consoleProgress();
  const Volume image = loadVolume(args.positional()[0], nullptr, progress, loadOptions(args));
  const std::vector<SimHandle> handles = loadHandles(args, image, r);
  for (const auto& name : r.settings.materials.capped()) std::cerr << "note: material '" << name << "': Poisson ratio capped at " << kMaxPoisson << " (linear tets lock)\n";
  DeformSolution solved;
  solveDeform(r, image, handles, progress, solved);
  const DeformSolution& d = solved;
  const SimScene& sc = d.scene;
  std::vector<float> strain = tetStrain(sc.meshes.fine, d.x);
  const std::vector<float> limits = tetStrainLimits(sc.band, r.settings.materials);
  hideRigidStrain(strain, limits);  // a sliding handle's own tets: not shown
  // A sliding handle is drawn where its pose puts it, not smeared by the tets straddling its surface.
  const RigidHandles rigid = rigidHandlesOf(image, handles, sc);
  const RasterOptions raster = rasterOptions(image, sc, rigid, d.drawn);
  std::vector<std::int32_t> tetOf;  // which tet drew each voxel (the CPU resampling, for the strain)
  const bool wantStrain = args.value("--strain-out").has_value();
  RasterOptions resampling = raster;
  if (wantStrain && r.backend == "cpu") resampling.tetOf = &tetOf;
  const DeformImage im = resampleDeform(args, r, image, d, rigid, resampling);
  writeVolume(im.out, *args.value("-o"));
  if (wantStrain) {
    if (tetOf.empty()) tetOf = voxelTets(image, sc, d.x, raster);  // the GPU resampled: which tet drew each voxel, on the CPU
    writeVolume(strainVolume(image.geometry(), tetOf, strain), *args.value("--strain-out"));
    std::cout << "wrote " << *args.value("--strain-out") << "\n";
  }
  printDeformSummary(r, d, im, movedHandleLimits(sc, strain, r.settings.materials), *args.value("-o"));
  if (auto fo = args.value("--forces-out")) {
    writeForces(*fo, r, d);
    std::cout << "wrote " << *fo << "\n";
  }
  if (auto mo = args.value("--mesh-out")) {
    writeMesh(*mo, d, strain, limits, r.settings.element);
    std::cout << "wrote " << *mo << "\n";
  }
  return 0;
}

}  // namespace handson::cli
