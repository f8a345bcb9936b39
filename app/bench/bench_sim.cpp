// `handson bench sim`: the interactive coarse model against the fine reference on one scene, over
// coarse resolutions: preprocessing, coarse time per frame, fine static solve, errors of the
// coarsened model, of a plain coarse FEM and of the two-level refinement, with a CSV and a chart.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <memory>
#include <sstream>

#include "app/bench/bench.h"
#include "app/bench/bench_force.h"
#include "app/cli/args.h"
#include "app/io/nifti_io.h"
#include "app/io/volume_io.h"
#include "app/session/console.h"
#include "sim/coarsening.h"
#include "sim/base/error.h"
#include "sim/handle_reaction.h"
#include "sim/sim_scene.h"
#include "sim/static_solver.h"
#include "sim/two_level.h"

namespace handson::cli {

namespace {
const char* const kBenchSimHelp =
    "usage: handson bench sim [PATH --handle MASK [--handle-label N]] [options]\n"
    "  The coarse model against the fine reference (static corotational FEM on the fine mesh) with a\n"
    "  handle moved 10 mm along x and rotated 30 degrees about z (about its centroid). PATH omitted: the\n"
    "  built-in phantom with its right kidney (label 4) as the handle. Per coarse resolution: scene and\n"
    "  coarsening time, coarse solve per frame (a 10-frame drag three times, warm started, 3 iterations a\n"
    "  frame, the median; the\n"
    "  default matrix-free PCG solve and the assembled baseline, with where the time goes),\n"
    "  fine solve time and their ratio, RMS / max error over free fine nodes relative to the handle's\n"
    "  motion for the coarsened model with both element kinds (grid cells, the default, and the spec's\n"
    "  coarse tets, on the same coarse nodes), a plain coarse FEM and the two-level refinement (cells);\n"
    "  the region shaped by the handle (--region handles: its own finer grid, the same budget) against the\n"
    "  box's fine reference, frame and error; graded cells (the cells near the handle halved, a named\n"
    "  option of the coarse model) on the same meshes, frame and error;\n"
    "  and the coarse solve's error after 1, 2, 3, 5 and 8 iterations from rest (solver iterations).\n"
    "  --coarse-list N,N,..   coarse tet counts (default 1500,3000,6000)\n"
    "  --fine-per-coarse N    fine tets per coarse tet (default 64: m = 4)\n"
    "  --spacing MM           phantom voxel size (default 2)\n"
    "  --refine-steps N       two-level steps measured (default 4, 10 PCG iterations each)\n"
    "  --handle-nodes inside|tets, --bone anchored|by-value, --outer-boundary exterior|wall,\n"
    "  --interface sliding|glued  the tissue\n"
    "                         rules (see handson deform --help; the earlier rules to compare with)\n"
    "  --graded-split CELLS   graded cells: halve the cells within CELLS cell sizes of the handle (default\n"
    "                         1; -1 skips them)\n"
    "  --translate-mm X,Y,Z, --rotate-deg AX,AY,AZ   another motion\n"
    "  --materials CSV        material table (default: the CT defaults, assets/materials/ct-default.csv)\n"
    "  --out DIR              sim_accuracy.csv, sim_tradeoff.csv, sim_tradeoff.png and sim_force.csv/png\n"
    "                         (the handle's reaction against its motion, coarse and fine; default bench-out)\n"
    "  --quiet\n";

double since(std::chrono::steady_clock::time_point t0) { return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(); }

// One benchmark case: a scene at one coarse count, the handle's motion and the fine reference.
struct BenchCase {
  const SimScene& sc;
  Eigen::Vector3d rv, tv;                     ///< rotation vector (radians) about the handle's centroid; translation (mm)
  std::vector<RigidTransform> T;              ///< the final pose
  double motion = 1;                          ///< the handle's motion (mm), the errors' unit
  const std::vector<Eigen::Vector3d>& fine;   ///< the fine reference's positions
  ProgressFn progress;
};

// The benchmark's two CSV files.
struct BenchCsv {
  std::ostream& acc;    ///< sim_accuracy.csv: a row per coarse count
  std::ostream& trade;  ///< sim_tradeoff.csv: model, coarse tets, seconds, RMS
};

// The two-level refinement from the coarse answer (fine positions xcoarse, coarse state xc), with the
// analytic matrix-free linearization (the default), the warped stiffness alone and the projected
// exact Hessian (the baseline), the same steps from the same start: RMS after each step to `acc` and
// `trade`, and the seconds per step of each method (in that order).
std::vector<double> compareRefinements(const BenchCase& c, const CoarseModel& model, const std::vector<Eigen::Vector3d>& xc, int refineSteps, double frameMs,
                                       BenchCsv& csv) {
  const SimScene& sc = c.sc;
  const std::vector<RigidTransform>& T = c.T;
  const std::vector<Eigen::Vector3d> xcoarse = model.reconstruct(T, xc);
  std::ostream &acc = csv.acc, &trade = csv.trade;
  std::vector<double> stepSeconds;
  for (const RefineMethod method : {RefineMethod::Analytic, RefineMethod::Warped, RefineMethod::Projected}) {
    const FineRefiner refiner(model, sc.fineK, sc.youngs, sc.poisson, RefineOptions{method, 0});
    auto x = xcoarse;
    double tStep = 0;
    for (int k = 1; k <= refineSteps; ++k) {
      const auto t0 = std::chrono::steady_clock::now();
      refiner.step(T, xc, x, 10);
      tStep += since(t0);
      const auto e = compareDeformation(sc, T, x, c.fine);
      acc << "," << e.rmsOfMotion;
      trade << (method == RefineMethod::Analytic ? std::string("refined") : std::string("refined-") + refineMethodName(method)) << ","
            << sc.meshes.coarse.tets.size() << "," << frameMs * 1e-3 + tStep << "," << e.rmsOfMotion << "\n";
      std::cout << "  refined (" << refineMethodName(method) << ") " << k << " step" << (k > 1 ? "s" : "") << " (" << std::setprecision(2) << tStep
                << " s): RMS " << std::setprecision(4) << e.rmsOfMotion << ", max " << e.maxOfMotion << "\n";
    }
    stepSeconds.push_back(refineSteps ? tStep / refineSteps : 0.0);
  }
  if (refineSteps > 0)
    std::cout << std::setprecision(3) << "  refinement step: analytic " << stepSeconds[0] << " s, warped " << stepSeconds[1] << " s, projected "
              << stepSeconds[2] << " s (projected / analytic " << std::setprecision(1) << stepSeconds[2] / stepSeconds[0] << "x)\n";
  return stepSeconds;
}
// A 10-frame drag from rest to the case's motion (rotation vector rv about the handle's centroid,
// translation tv), 3 iterations a frame, with `solver`, three times: the median frame, the mean
// breakdown, and how far the last state lies from the converged one (of the motion); leaves the
// model's state in xc.
struct Drag {
  double frame = 0;        // median frame (ms)
  double meanFrame = 0;    // mean frame (ms): a preconditioner refresh's factorization lands in a few frames
  CoarseSolveStats mean;   // per frame, averaged over the drag: the breakdown
  double lag = 0;          // after the drag: largest coarse node distance to the converged state / motion
};
Drag dragRun(CoarseModel& model, CoarseSolver solver, const BenchCase& c, std::vector<Eigen::Vector3d>& xc, const PcgOptions& pcg = {}) {
  const Eigen::Vector3d& centre = c.sc.handleCentroid[0];
  const Eigen::Vector3d &rv = c.rv, &tv = c.tv;
  model.setSolver(solver);
  model.setPcgOptions(pcg);
  model.prepareSolve();  // one-off set-up (pcg: the rest factorization), part of the preprocessing
  Drag d;
  std::vector<double> frameMs;
  for (int rep = 0; rep < 3; ++rep) {
    xc = model.restState();
    for (int f = 1; f <= 10; ++f) {
      const std::vector<RigidTransform> Tf{RigidTransform::about(centre, rv * (f / 10.0), tv * (f / 10.0))};
      const auto t1 = std::chrono::steady_clock::now();
      const CoarseSolveStats st = model.solve(Tf, xc, 3);
      frameMs.push_back(1e3 * since(t1));
      for (auto [sum, v] : {std::pair{&d.mean.rotationMs, st.rotationMs}, {&d.mean.productMs, st.productMs}, {&d.mean.factorMs, st.factorMs},
                            {&d.mean.backSolveMs, st.backSolveMs}, {&d.mean.boundaryMs, st.boundaryMs}, {&d.mean.solveMs, st.solveMs}})
        *sum += v / 30.0;
      d.mean.pcgIterations += st.pcgIterations;
      d.mean.factorizations += st.factorizations;
    }
  }
  std::sort(frameMs.begin(), frameMs.end());
  d.frame = frameMs[frameMs.size() / 2];
  for (const double f : frameMs) d.meanFrame += f / double(frameMs.size());
  auto xconv = xc;
  model.solve({RigidTransform::about(centre, rv, tv)}, xconv, 2000, 1e-10);
  for (std::size_t v = 0; v < xc.size(); ++v) d.lag = std::max(d.lag, (xc[v] - xconv[v]).norm() / c.motion);
  model.setPcgOptions({});
  return d;
}

// The region shaped by the handle (--region handles: the box's cells away from the handle held, the
// same coarse budget spent on the others, so a finer grid), on its own meshes, sampled at the box
// scene's fine nodes and measured against the box's fine reference `fine`.
struct ShapedRun {
  std::size_t tets = 0;  // coarse tets of its grid (over the box)
  double share = 0;      // of the grid's cells simulated
  Drag drag;
  DeformationError error;
  /// Its line of the console report; `boxFrame`: the box's frame (ms).
  std::string summary(double boxFrame) const {
    std::ostringstream o;
    o << std::fixed << std::setprecision(3) << "  region shaped by the handle (--region handles): " << tets << " tets over the box, " << share * 100
      << " % of its cells simulated; frame " << drag.frame << " ms (" << drag.frame / boxFrame << "x the box's); against the box's fine reference RMS "
      << std::setprecision(4) << error.rmsOfMotion << ", max " << error.maxOfMotion << "\n";
    return o.str();
  }
};
ShapedRun measureShapedRegion(const Volume& image, const SimHandle& handle, SimSettings s, const BenchCase& c) {
  const SimScene& box = c.sc;
  s.region = SimSettings::Region::Handles;
  const SimScene shaped = buildSimScene(image, {handle}, s, c.progress);
  ShapedRun r;
  r.tets = shaped.meshes.coarse.tets.size();
  r.share = double(std::count(shaped.regionCell.begin(), shaped.regionCell.end(), 1)) / double(shaped.regionCell.size());
  CoarseModel model(shaped.meshes, shaped.fineK, shaped.constraints, c.progress, CoarseElement::Cell);
  std::vector<Eigen::Vector3d> x;
  r.drag = dragRun(model, CoarseSolver::Pcg, c, x);
  model.solve(c.T, x, kOneOffSolveIterations);
  r.error = compareDeformation(box, c.T, sampleDeformation(shaped, model.reconstruct(c.T, x), box.meshes.fine.nodes), c.fine);
  return r;
}

// Graded cells (CoarseGrading: cells within `split` cell sizes of the handle halved, hanging nodes
// tied to the whole cells) on the same scene and meshes: the drag, the converged answer's error.
struct GradedRun {
  double split = -1;
  std::size_t elements = 0, hanging = 0;
  Drag drag;
  CoarseSolveStats conv;
  DeformationError error;
  std::string summary;  ///< its line of the console report (empty when skipped)
  /// Its sim_accuracy.csv fields, each followed by a comma.
  std::string csv() const {
    std::ostringstream o;
    o << split << "," << elements << "," << hanging << "," << drag.frame << "," << drag.lag << "," << (conv.converged ? conv.iterations : -1) << ","
      << error.rmsOfMotion << "," << error.maxOfMotion << ",";
    return o.str();
  }
};
GradedRun measureGraded(const BenchCase& c, double split, double frame, std::ostream& trade) {
  const SimScene& sc = c.sc;
  GradedRun g;
  g.split = split;
  if (split < 0) return g;
  CoarseModel model(sc.meshes, sc.fineK, sc.constraints, c.progress, CoarseElement::Cell, CoarseGrading{split});
  g.elements = model.elementCount();
  g.hanging = model.hangingNodeCount();
  std::vector<Eigen::Vector3d> x;
  g.drag = dragRun(model, CoarseSolver::Pcg, c, x);
  g.conv = model.solve(c.T, x, 5000);
  g.error = compareDeformation(sc, c.T, model.reconstruct(c.T, x), c.fine);
  trade << "graded-cells," << sc.meshes.coarse.tets.size() << "," << g.drag.frame * 1e-3 << "," << g.error.rmsOfMotion << "\n";
  std::ostringstream o;
  o << std::fixed << std::setprecision(3) << "  graded cells (--graded-split " << split << "): " << g.elements << " cells (" << g.hanging
            << " hanging nodes), frame " << g.drag.frame << " ms (" << g.drag.frame / frame << "x the uniform grid's), after the drag "
            << std::setprecision(4) << g.drag.lag << " of the motion from converged (" << g.conv.iterations << " iterations"
            << (g.conv.converged ? "" : ", NOT converged") << "); RMS " << g.error.rmsOfMotion << ", max " << g.error.maxOfMotion << "\n";
  g.summary = o.str();
  return g;
}

void writeAccuracyHeader(std::ostream& acc, int refineSteps) {
  acc << "coarse_tets,fine_tets,scene_s,coarsening_s,frame_ms,fine_solve_s,fine_over_frame,fine_iterations,coarse_iterations_to_converge,rms_coarse,max_coarse,"
         "shaped_coarse_tets,shaped_cell_share,frame_ms_shaped,rms_shaped,max_shaped,"
         "graded_split_cells,graded_elements,graded_hanging_nodes,frame_ms_graded,frame_lag_graded,graded_iterations_to_converge,rms_graded,max_graded,"
         "coarsening_s_tet,frame_ms_tet,rms_coarse_tet,max_coarse_tet,rms_plain,max_plain,frame_ms_assembled,frame_speedup,frame_lag,frame_lag_assembled,"
         "solver_difference,rotation_ms,products_ms,factor_ms,backsolve_ms,boundary_ms,pcg_per_frame,rotation_ms_assembled,assembly_ms_assembled,"
         "factor_ms_assembled,backsolve_ms_assembled,boundary_ms_assembled,factorizations_per_frame_assembled,frame_mean_ms,factorizations_per_frame,"
         "frame_ms_pcg_earlier,frame_mean_ms_pcg_earlier,frame_lag_pcg_earlier,pcg_earlier_iterations_to_converge";
  for (int k = 1; k <= refineSteps; ++k) acc << ",rms_refined_" << k;
  for (int k = 1; k <= refineSteps; ++k) acc << ",rms_refined_" << k << "_warped";
  for (int k = 1; k <= refineSteps; ++k) acc << ",rms_refined_" << k << "_projected";
  acc << ",refine_step_s,refine_step_s_warped,refine_step_s_projected,force_fine_N,force_coarse_N,force_coarse_over_fine,torque_fine_Nmm,torque_coarse_Nmm\n";
}

// sim_tradeoff.png from sim_tradeoff.csv (gnuplot; no chart without it).
void writeTradeoffChart(const std::filesystem::path& out) {
  if (std::system("command -v gnuplot > /dev/null 2>&1") == 0) {
    const auto gp = out / "sim_tradeoff.gp";
    const std::string f = (out / "sim_tradeoff.csv").string();
    std::ofstream(gp) << "set datafile separator ','\nset terminal pngcairo size 900,560 font ',11'\nset output '" << (out / "sim_tradeoff.png").string()
                      << "'\nset termoption noenhanced\nset title 'Speed against accuracy: error of the fine-node positions vs time'\n"
                      << "set logscale xy\nset xlabel 'seconds (coarse: one frame; refined: frame + refinement; fine: static solve)'\n"
                      << "set ylabel 'RMS error / handle motion (fine reference at 1e-4)'\nset grid\nset key top right\n"
                      << "set arrow from graph 0, first 0.1 to graph 1, first 0.1 nohead dt 2 lc rgb '#cc4444'\n"
                      << "set arrow from graph 0, first 0.02 to graph 1, first 0.02 nohead dt 3 lc rgb '#44aa44'\n"
                      << "plot '" << f << "' using (strcol(1) eq 'coarsened-cells' ? $3 : 1/0):4 with points pt 7 ps 1.5 title 'coarsened, cell elements (default)', "
                      << "'' using (strcol(1) eq 'coarsened-cells-assembled' ? $3 : 1/0):4 with points pt 4 ps 1.5 title 'coarsened, cells, assembled solve (baseline)', "
                      << "'' using (strcol(1) eq 'coarsened-tets' ? $3 : 1/0):4 with points pt 6 ps 1.5 title 'coarsened, tet elements (spec)', "
                      << "'' using (strcol(1) eq 'plain' ? $3 : 1/0):4 with points pt 5 ps 1.5 title 'plain coarse FEM', "
                      << "'' using (strcol(1) eq 'shaped-region' ? $3 : 1/0):4 with points pt 13 ps 1.5 title 'coarsened, region shaped by the handle (vs the box reference)', "
                      << "'' using (strcol(1) eq 'graded-cells' ? $3 : 1/0):4 with points pt 11 ps 1.5 title 'coarsened, graded cells (halved near the handle)', "
                      << "'' using (strcol(1) eq 'coarse-iterations' ? $3 : 1/0):4 with linespoints pt 1 dt 2 title 'coarse solve from rest: 1, 2, 3, 5, 8 iterations', "
                      << "'' using (strcol(1) eq 'refined' ? $3 : 1/0):4 with linespoints pt 9 title 'two-level refinement, analytic matrix-free (default; 10 PCG / step)', "
                      << "'' using (strcol(1) eq 'refined-warped' ? $3 : 1/0):4 with linespoints pt 10 dt 3 title 'two-level refinement, warped stiffness only', "
                      << "'' using (strcol(1) eq 'refined-projected' ? $3 : 1/0):4 with linespoints pt 8 dt 4 title 'two-level refinement, projected Hessian (baseline)', "
                      << "'' using (strcol(1) eq 'fine' ? $3 : 1/0):4 with points pt 3 ps 2 title 'fine static solve', "
                      << "'' using (strcol(1) eq 'operating-point' ? $3 : 1/0):4 with points pt 6 ps 4 lw 2 lc rgb '#cc0000' title 'paper operating point (~6,000 / 300,000 tets)', "
                      << "'' using (strcol(1) eq 'coarsened-cells' ? $3 : 1/0):4:2 with labels offset 1.5,0.6 notitle\n";
    if (std::system(("gnuplot " + gp.string() + " 2>/dev/null").c_str()) != 0) std::cerr << "gnuplot failed: no chart\n";
  }
}

// The coarse solve from rest to the final pose in one input (no warm start, the worst case) with 1,
// 2, 3, 5 and 8 iterations: error against the time spent (solver iterations), to `trade`.
void coarseIterationSweep(const BenchCase& c, CoarseModel& model, std::ostream& trade) {
  const SimScene& sc = c.sc;
  const std::vector<RigidTransform>& T = c.T;
  const std::vector<Eigen::Vector3d>& fine = c.fine;
  for (int k : {1, 2, 3, 5, 8}) {
    std::vector<Eigen::Vector3d> xk = model.restState();
    const auto t0 = std::chrono::steady_clock::now();
    model.solve(T, xk, k, 0.0);
    const double tk = since(t0);
    const auto e = compareDeformation(sc, T, model.reconstruct(T, xk), fine);
    trade << "coarse-iterations," << sc.meshes.coarse.tets.size() << "," << tk << "," << e.rmsOfMotion << "\n";
    std::cout << "  coarse solve from rest, " << k << " iteration" << (k > 1 ? "s" : "") << " (" << std::setprecision(3) << tk * 1e3
              << " ms): RMS " << std::setprecision(4) << e.rmsOfMotion << "\n";
  }
}
// What `bench sim` was asked.
struct BenchSimOptions {
  std::vector<int> coarseList;
  int finePer = 64, refineSteps = 4;
  double gradedSplit = 1.0;
  Eigen::Vector3d rv = Eigen::Vector3d::Zero(), tv = Eigen::Vector3d::Zero();  ///< radians (rotation vector), mm
  std::filesystem::path out;
  SimSettings settings;  ///< materials, tissue rules and interface (the counts set per level)
};

BenchSimOptions parseBenchSimOptions(const Args& args) {
  BenchSimOptions o;
  o.coarseList = integerListOption(args, "--coarse-list", "1500,3000,6000", 6, 1000000);
  o.finePer = int(args.integer("--fine-per-coarse", 64, 1, 4096));
  o.refineSteps = int(args.integer("--refine-steps", 4, 0, 100));
  o.gradedSplit = args.number("--graded-split", 1.0, -1.0, 10.0);
  const auto tr = parseNumberList(args.valueOr("--translate-mm", "10,0,0"), "--translate-mm");
  const auto ro = parseNumberList(args.valueOr("--rotate-deg", "0,0,30"), "--rotate-deg");
  if (tr.size() != 3 || ro.size() != 3) throw UsageError("--translate-mm and --rotate-deg take three numbers");
  o.tv = Eigen::Vector3d(tr[0], tr[1], tr[2]);
  o.rv = Eigen::Vector3d(ro[0], ro[1], ro[2]) * (M_PI / 180);
  o.out = args.valueOr("--out", "bench-out");
  o.settings.materials = args.value("--materials") ? MaterialTable::load(*args.value("--materials")) : MaterialTable::ctDefault();
  tissueRuleOptions(args, "--", o.settings);
  interfaceOption(args, "--", o.settings);
  return o;
}

// One coarse element kind's model: preprocessing, a 10-frame drag (3 iterations a frame), then its
// converged answer and its error against the fine reference.
struct Measured {
  std::unique_ptr<CoarseModel> model;
  std::vector<Eigen::Vector3d> xc;
  double coarsening = 0;
  Drag drag, baseline;     // the default solver (pcg) and the assembled one (cells only)
  Drag earlier;            // pcg as it was: the plain iteration, without Anderson acceleration (cells only)
  int earlierIterations = 0;  // its iterations from rest to converged (-1: not converged)
  CoarseSolveStats conv;
  double solverDiff = 0;   // the two solvers' converged states: largest difference / motion
  DeformationError error;
};

Measured measureCoarse(const BenchCase& c, CoarseElement kind) {
  const SimScene& sc = c.sc;
  Measured m;
  auto t1 = std::chrono::steady_clock::now();
  m.model = std::make_unique<CoarseModel>(sc.meshes, sc.fineK, sc.constraints, c.progress, kind);
  m.coarsening = since(t1);
  std::vector<Eigen::Vector3d> xb;
  if (kind == CoarseElement::Cell) {
    m.baseline = dragRun(*m.model, CoarseSolver::Assembled, c, xb);
    m.model->solve(c.T, xb, 2000, 1e-10);
  }
  if (kind == CoarseElement::Cell) {
    PcgOptions earlier;
    earlier.andersonDepth = 0;
    std::vector<Eigen::Vector3d> xr;
    m.earlier = dragRun(*m.model, CoarseSolver::Pcg, c, xr, earlier);
    xr = m.model->restState();
    m.model->setPcgOptions(earlier);
    const CoarseSolveStats st = m.model->solve(c.T, xr, kOneOffSolveIterations);
    m.earlierIterations = st.converged ? st.iterations : -1;
    m.model->setPcgOptions({});
  }
  m.drag = dragRun(*m.model, CoarseSolver::Pcg, c, m.xc);
  m.xc = m.model->restState();  // converged from rest, as the rest factor's count above
  m.conv = m.model->solve(c.T, m.xc, kOneOffSolveIterations);  // the coarse model's own converged answer
  if (kind == CoarseElement::Cell) {
    // Both solvers to 1e-10 of the motion: how far apart their answers are.
    auto xp = m.xc;
    m.model->solve(c.T, xp, 2000, 1e-10);
    for (std::size_t v = 0; v < xb.size(); ++v) m.solverDiff = std::max(m.solverDiff, (xb[v] - xp[v]).norm() / c.motion);
  }
  m.error = compareDeformation(sc, c.T, m.model->reconstruct(c.T, m.xc), c.fine);
  return m;
}

// Everything one coarse count measures.
struct Level {
  double sceneSeconds = 0, fineSeconds = 0;
  int fineIterations = 0;
  Measured tet, cell;
  ShapedRun shaped;
  GradedRun graded;
  DeformationError plain;  ///< the plain coarse FEM's error
};

// The level's sim_accuracy.csv fields up to the refinement's, and its sim_tradeoff.csv rows.
void writeLevel(const BenchCase& c, const Level& l, bool operatingPoint, BenchCsv& csv) {
  const SimScene& sc = c.sc;
  const Measured& cell = l.cell;
  const double frame = cell.drag.frame;
  const auto& ec = cell.error;
  csv.acc << sc.meshes.coarse.tets.size() << "," << sc.meshes.fine.tets.size() << "," << l.sceneSeconds << "," << cell.coarsening << "," << frame << ","
          << l.fineSeconds << "," << l.fineSeconds / (frame * 1e-3) << "," << l.fineIterations << "," << (cell.conv.converged ? cell.conv.iterations : -1) << ","
          << ec.rmsOfMotion << "," << ec.maxOfMotion << "," << l.shaped.tets << "," << l.shaped.share << "," << l.shaped.drag.frame << ","
          << l.shaped.error.rmsOfMotion << "," << l.shaped.error.maxOfMotion << "," << l.graded.csv() << l.tet.coarsening << "," << l.tet.drag.frame << ","
          << l.tet.error.rmsOfMotion << "," << l.tet.error.maxOfMotion << "," << l.plain.rmsOfMotion << "," << l.plain.maxOfMotion;
  const Drag& a = cell.baseline;
  const CoarseSolveStats& b = cell.drag.mean;
  csv.acc << "," << a.frame << "," << a.frame / frame << "," << cell.drag.lag << "," << a.lag << "," << cell.solverDiff << "," << b.rotationMs << ","
          << b.productMs << "," << b.factorMs << "," << b.backSolveMs << "," << b.boundaryMs << "," << b.pcgIterations / 30.0 << "," << a.mean.rotationMs << ","
          << a.mean.productMs << "," << a.mean.factorMs << "," << a.mean.backSolveMs << "," << a.mean.boundaryMs << "," << a.mean.factorizations / 30.0;
  const Drag& pe = cell.earlier;
  csv.acc << "," << cell.drag.meanFrame << "," << b.factorizations / 30.0 << "," << pe.frame << "," << pe.meanFrame << "," << pe.lag << ","
          << cell.earlierIterations;
  const auto n = sc.meshes.coarse.tets.size();
  std::ostream& trade = csv.trade;
  trade << "coarsened-cells," << n << "," << frame * 1e-3 << "," << ec.rmsOfMotion << "\n";
  trade << "coarsened-cells-assembled," << n << "," << a.frame * 1e-3 << "," << ec.rmsOfMotion << "\n";
  // The paper's operating point: about 6,000 coarse and 300,000 fine tets (the defaults).
  if (operatingPoint) trade << "operating-point," << n << "," << frame * 1e-3 << "," << ec.rmsOfMotion << "\n";
  trade << "coarsened-tets," << n << "," << l.tet.drag.frame * 1e-3 << "," << l.tet.error.rmsOfMotion << "\n";
  trade << "plain," << n << "," << frame * 1e-3 << "," << l.plain.rmsOfMotion << "\n";
  trade << "shaped-region," << l.shaped.tets << "," << l.shaped.drag.frame * 1e-3 << "," << l.shaped.error.rmsOfMotion << "\n";
}

// The level's console report.
void printLevel(const BenchCase& c, const Level& l) {
  const SimScene& sc = c.sc;
  const Measured &cell = l.cell, &tet = l.tet;
  const double frame = cell.drag.frame;
  const auto& ec = cell.error;
  const Drag& a = cell.baseline;
  const CoarseSolveStats& b = cell.drag.mean;
  std::cout << std::setprecision(3) << "\ncoarse " << sc.meshes.coarse.tets.size() << " tets (" << cell.model->elementCount() << " cells) / fine "
            << sc.meshes.fine.tets.size() << " tets: scene " << l.sceneSeconds << " s, coarsening " << cell.coarsening << " s (tets " << tet.coarsening
            << " s); coarse frame " << frame << " ms (tets " << tet.drag.frame << " ms), fine solve " << l.fineSeconds << " s (" << l.fineIterations
            << " Newton iterations): " << std::setprecision(0) << l.fineSeconds / (frame * 1e-3) << "x\n"
            << "  coarse model converged in " << cell.conv.iterations << " iterations" << (cell.conv.converged ? "" : " (NOT converged)") << " (tets "
            << tet.conv.iterations << (tet.conv.converged ? "" : ", NOT converged") << ")\n"
            << std::setprecision(3) << "  coarse frame, pcg " << frame << " ms against assembled " << a.frame << " ms (" << std::setprecision(1)
            << a.frame / frame << "x); per frame, pcg: rotations " << std::setprecision(3) << b.rotationMs << ", products " << b.productMs
            << ", factorization " << b.factorMs << ", back-solves " << b.backSolveMs << ", boundary " << b.boundaryMs << " ms, "
            << b.pcgIterations / 30.0 << " CG iterations; assembled: rotations " << a.mean.rotationMs << ", assembly " << a.mean.productMs
            << ", factorization " << a.mean.factorMs << ", back-solves " << a.mean.backSolveMs << ", boundary " << a.mean.boundaryMs << " ms\n"
            << "  pcg: " << std::setprecision(3) << b.factorizations / 30.0 << " factorizations a frame, mean frame " << cell.drag.meanFrame
            << " ms; as it was (the plain iteration, no Anderson acceleration): frame " << cell.earlier.frame << " ms (mean "
            << cell.earlier.meanFrame << "), after the drag " << std::setprecision(6) << cell.earlier.lag << " of the motion from converged, from rest "
            << cell.earlierIterations << " iterations to converge\n"
            << std::setprecision(6) << "  after the drag, distance to the converged state / motion: pcg " << cell.drag.lag << ", assembled " << a.lag
            << "; converged states differ by " << std::setprecision(2) << std::scientific << cell.solverDiff << std::fixed << " of the motion\n"
            << std::setprecision(4) << "  RMS / max of the handle's motion (" << std::setprecision(2) << ec.handleMotionMm << " mm): coarsened (cells) "
            << std::setprecision(4) << ec.rmsOfMotion << " / " << ec.maxOfMotion << ", coarsened (tets) " << tet.error.rmsOfMotion << " / "
            << tet.error.maxOfMotion << ", plain coarse FEM " << l.plain.rmsOfMotion << " / " << l.plain.maxOfMotion << " (plain / cells "
            << std::setprecision(2) << l.plain.rmsOfMotion / ec.rmsOfMotion << "x)\n"
            << l.shaped.summary(frame) << l.graded.summary;
}

// The handle's reaction (what the tissue does to it), coarse model against the fine reference: to
// the console and the accuracy row's last fields.
void compareReactions(const BenchCase& c, const Measured& cell, std::ostream& acc) {
  const SimScene& sc = c.sc;
  const HandleReaction rf = fineHandleReactions(sc.meshes.fine, sc.fineK, sc.constraints, c.T, c.fine)[0], rc = cell.model->handleReactions(c.T, cell.xc)[0];
  std::cout << std::setprecision(4) << "  reaction on the handle: fine " << rf.forceN.norm() << " N, " << rf.torqueNmm.norm() << " N mm; coarse model "
            << rc.forceN.norm() << " N (" << std::setprecision(2) << rc.forceN.norm() / rf.forceN.norm() << "x), " << std::setprecision(4)
            << rc.torqueNmm.norm() << " N mm\n";
  acc << "," << rf.forceN.norm() << "," << rc.forceN.norm() << "," << rc.forceN.norm() / rf.forceN.norm() << "," << rf.torqueNmm.norm() << ","
      << rc.torqueNmm.norm();
}

// One coarse count: the scene, the fine reference, the coarse models, the shaped region, graded
// cells, the plain coarse FEM, the refinements and the reactions; its rows written as it goes.
void runLevel(const BenchSimOptions& o, const Volume& image, const SimHandle& handle, int nc, const ProgressFn& progress, BenchCsv& csv) {
  SimSettings s = o.settings;
  s.coarseTets = nc;
  s.fineTets = nc * o.finePer;
  Level l;
  auto t0 = std::chrono::steady_clock::now();
  const SimScene sc = buildSimScene(image, {handle}, s, progress);
  l.sceneSeconds = since(t0);
  const std::vector<RigidTransform> T{RigidTransform::about(sc.handleCentroid[0], o.rv, o.tv)};
  t0 = std::chrono::steady_clock::now();
  StaticSolveOptions so;
  so.progress = progress;
  so.tolerance = 1e-4;  // the errors measured are >= 1e-3 of the motion: a 1e-4 reference suffices
  const auto fine = solveFineStatic(sc, T, so);
  l.fineSeconds = since(t0);
  l.fineIterations = fine.iterations;
  const double motion = std::max(1e-9, compareDeformation(sc, T, sc.meshes.fine.nodes, sc.meshes.fine.nodes).handleMotionMm);
  const BenchCase c{sc, o.rv, o.tv, T, motion, fine.x, progress};
  l.tet = measureCoarse(c, CoarseElement::Tet);
  l.cell = measureCoarse(c, CoarseElement::Cell);
  l.shaped = measureShapedRegion(image, handle, s, c);
  l.graded = measureGraded(c, o.gradedSplit, l.cell.drag.frame, csv.trade);
  l.plain = compareDeformation(sc, T, plainCoarseSolve(sc.meshes, sc.youngs, sc.poisson, sc.constraints, T), fine.x);
  writeLevel(c, l, nc == 6000 && o.finePer == 64, csv);
  printLevel(c, l);
  coarseIterationSweep(c, *l.cell.model, csv.trade);
  const std::vector<double> stepSeconds = compareRefinements(c, *l.cell.model, l.cell.xc, o.refineSteps, l.cell.drag.frame, csv);
  csv.trade << "fine," << sc.meshes.coarse.tets.size() << "," << l.fineSeconds << ",1e-4\n";
  csv.acc << "," << stepSeconds[0] << "," << stepSeconds[1] << "," << stepSeconds[2];
  compareReactions(c, l.cell, csv.acc);
  csv.acc << std::endl;  // a row at a time: long runs show progress
  csv.trade.flush();
  std::cout.flush();
}

}  // namespace

int cmdBenchSim(const Words& words) {
  Args args(words, {"--handle", "--handle-label", "--coarse-list", "--fine-per-coarse", "--spacing", "--refine-steps", "--graded-split", "--translate-mm", "--rotate-deg", "--materials", "--out",
                    "--handle-nodes", "--bone", "--outer-boundary", "--interface"},
            {"--quiet"});
  if (args.help() || args.positional().size() > 1 || (args.positional().size() == 1) != bool(args.value("--handle"))) {
    usageStream(args) << kBenchSimHelp;
    return args.help() ? 0 : 2;
  }
  const ProgressFn progress = args.flag("--quiet") ? ProgressFn{} : consoleProgress();
  const BenchSimOptions o = parseBenchSimOptions(args);
  std::filesystem::create_directories(o.out);
  HandleScene loaded = handleSceneOptions(args, 2.0, progress);
  const Volume image = std::move(loaded.image);
  const SimHandle handle{std::move(loaded.handle), {}};
  std::ofstream acc(o.out / "sim_accuracy.csv"), trade(o.out / "sim_tradeoff.csv");
  writeAccuracyHeader(acc, o.refineSteps);
  trade << "model,coarse_tets,seconds,rms\n";
  std::cout << std::fixed;
  BenchCsv csv{acc, trade};
  for (int nc : o.coarseList) runLevel(o, image, handle, nc, progress, csv);
  acc.close();
  trade.close();
  writeTradeoffChart(o.out);
  benchForceCurve(o.out);
  std::cout << "\nwrote " << (o.out / "sim_accuracy.csv").string() << ", " << (o.out / "sim_tradeoff.csv").string()
            << " and the charts sim_tradeoff.png, sim_force.png\n";
  return 0;
}

}  // namespace handson::cli
