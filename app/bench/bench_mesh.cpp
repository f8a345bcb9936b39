// `handson bench mesh`: the fine mesh against a much finer one. The fine reference is only as good as
// its mesh: this measures the regular refinement (the baseline) and the image-adapted TetGen mesh
// (sim/adapted_mesh.h) at several resolutions against a regular mesh `--truth-refinement` times finer
// per coarse cell edge, all solved with the fine static solver on the same scene, and charts the error
// against the fine tet count (CSV + PNG).
#include <Eigen/Dense>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>

#include "app/bench/bench.h"
#include "app/cli/args.h"
#include "app/io/volume_io.h"
#include "app/session/console.h"
#include "sim/coarsening.h"
#include "sim/base/error.h"
#include "sim/sim_scene.h"
#include "sim/static_solver.h"

namespace handson::cli {

namespace {
const char* const kBenchMeshHelp =
    "usage: handson bench mesh [PATH --handle MASK [--handle-label N]] [options]\n"
    "  Fine meshes against a finer regular one (the 'truth'), same scene and motion (a handle moved\n"
    "  10 mm along x and rotated 30 degrees about z): the regular refinement (m fine cells per coarse\n"
    "  cell edge) and the image-adapted TetGen mesh (regular lattice plus points at stiffness jumps).\n"
    "  Error: the displacement at the truth's free nodes, each mesh's field interpolated linearly, RMS\n"
    "  and max relative to the truth's handle motion. PATH omitted: the built-in phantom, right kidney.\n"
    "  --coarse-tets N         coarse grid (default 600)\n"
    "  --regular-list M,M,..   regular refinements (default 2,3,4,5,6)\n"
    "  --adapted-list M,M,..   image-adapted refinements (default 2,3,4)\n"
    "  --truth-refinement M    the truth's refinement (default 8)\n"
    "  --contrast F            image-adapted: stiffness jump that adds points (default 10)\n"
    "  --spacing MM            phantom voxel size (default 2)\n"
    "  --out DIR               mesh_accuracy.csv and mesh_accuracy.png (default bench-out)\n"
    "  --quiet\n";

double since(std::chrono::steady_clock::time_point t0) { return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(); }

struct Solved {
  SimScene scene;
  std::vector<Eigen::Vector3d> x;
  double meshSeconds = 0, solveSeconds = 0;
};
}  // namespace

namespace {

// The scene and motion every mesh of the benchmark solves: the image and handle, the coarse count,
// the adapted meshes' contrast.
struct MeshCase {
  const Volume& image;
  const SimHandle& handle;
  int coarse = 600;
  double contrast = 10.0;
  ProgressFn progress;
  RigidTransform motionAt(const SimScene& sc) const {
    return RigidTransform::about(sc.handleCentroid[0], Eigen::Vector3d(0, 0, M_PI / 6), Eigen::Vector3d(10, 0, 0));
  }
};

// The fine reference at refinement m (regular, or image-adapted), the handle turned 30 degrees and moved 10 mm.
Solved solveMesh(const MeshCase& mc, int m, bool adaptedMesh) {
  Solved s;
  SimSettings set;
  set.coarseTets = mc.coarse;
  set.fineTets = mc.coarse * m * m * m;
  set.fineMesh = adaptedMesh ? SimSettings::FineMesh::ImageAdapted : SimSettings::FineMesh::Regular;
  set.adaptContrast = mc.contrast;
  auto t0 = std::chrono::steady_clock::now();
  s.scene = buildSimScene(mc.image, {mc.handle}, set, mc.progress);
  s.meshSeconds = since(t0);
  if (s.scene.meshes.refinement != m) throw Error("bench mesh: the refinement came out as " + std::to_string(s.scene.meshes.refinement));
  StaticSolveOptions so;
  so.tolerance = 1e-5;
  so.progress = mc.progress;
  t0 = std::chrono::steady_clock::now();
  const auto r = solveFineStatic(s.scene, {mc.motionAt(s.scene)}, so);
  s.solveSeconds = since(t0);
  if (!r.converged) std::cerr << "warning: the fine solve (m = " << m << (adaptedMesh ? ", adapted" : "") << ") did not converge\n";
  s.x = r.x;
  return s;
}

// The RMS motion (mm) of the truth's moved handle nodes: the errors' unit.
double handleMotion(const MeshCase& mc, const Solved& truth) {
  const SimScene& ts = truth.scene;
  const TetMesh& TF = ts.meshes.fine;
  const RigidTransform T = mc.motionAt(ts);
  double motion2 = 0;
  std::size_t nh = 0;
  for (std::size_t n = 0; n < TF.nodes.size(); ++n)
    if (ts.constraints.handleOf[n] >= 0 && !ts.constraints.fixed[n]) {
      motion2 += (T.apply(TF.nodes[n]) - TF.nodes[n]).squaredNorm();
      ++nh;
    }
  return std::sqrt(motion2 / double(std::max<std::size_t>(nh, 1)));
}

// A mesh's displacement error at the truth's free nodes (interpolated in the mesh's fine tets):
// RMS and largest, over the handle's motion.
std::pair<double, double> errorAgainstTruth(const Solved& c, const Solved& truth, double motion) {
  const SimScene& ts = truth.scene;
  const TetMesh& TF = ts.meshes.fine;
  const NestedMeshes& M = c.scene.meshes;
  double e2 = 0, emax = 0;
  std::size_t n = 0;
  for (std::size_t i = 0; i < TF.nodes.size(); ++i) {
    if (ts.constraints.fixed[i] || ts.constraints.handleOf[i] >= 0) continue;
    const Eigen::Vector3d& p = TF.nodes[i];
    const int t = M.locateFine(p);
    if (t < 0) continue;
    const auto& v = M.fine.tets[std::size_t(t)];
    Eigen::Matrix3d D;
    D << M.fine.nodes[std::size_t(v[1])] - M.fine.nodes[std::size_t(v[0])], M.fine.nodes[std::size_t(v[2])] - M.fine.nodes[std::size_t(v[0])],
        M.fine.nodes[std::size_t(v[3])] - M.fine.nodes[std::size_t(v[0])];
    const Eigen::Vector3d l = D.inverse() * (p - M.fine.nodes[std::size_t(v[0])]);
    const double w[4] = {1.0 - l.sum(), l.x(), l.y(), l.z()};
    Eigen::Vector3d u = Eigen::Vector3d::Zero();
    for (int k = 0; k < 4; ++k) u += w[k] * (c.x[std::size_t(v[std::size_t(k)])] - M.fine.nodes[std::size_t(v[std::size_t(k)])]);
    const double e = (u - (truth.x[i] - p)).norm();
    e2 += e * e;
    emax = std::max(emax, e);
    ++n;
  }
  return {std::sqrt(e2 / double(std::max<std::size_t>(n, 1))) / motion, emax / motion};
}

// One mesh against the truth: its row of mesh_accuracy.csv and its report line.
void measureMesh(const MeshCase& mc, const Solved& truth, double motion, int m, bool adaptedMesh, std::ostream& csv) {
  const Solved c = solveMesh(mc, m, adaptedMesh);
  const NestedMeshes& M = c.scene.meshes;
  const auto [rms, worst] = errorAgainstTruth(c, truth, motion);
  csv << (adaptedMesh ? "adapted," : "regular,") << m << "," << M.fine.tets.size() << "," << M.fine.nodes.size() << "," << c.scene.adapted.structurePoints << ","
      << c.scene.adapted.fallbackCells << "," << c.meshSeconds << "," << c.solveSeconds << "," << rms << "," << worst << std::endl;
  std::cout << (adaptedMesh ? "adapted" : "regular") << " m = " << m << ": " << M.fine.tets.size() << " fine tets";
  if (adaptedMesh)
    std::cout << " (" << c.scene.adapted.structurePoints << " points at stiffness jumps, " << c.scene.adapted.fallbackCells << " cells left regular"
              << (c.scene.adapted.firstFailure.empty() ? "" : ": " + c.scene.adapted.firstFailure) << ")";
  std::cout << std::setprecision(2) << ", mesh " << c.meshSeconds << " s, solve " << c.solveSeconds << " s: RMS " << std::setprecision(4) << rms << ", max "
            << worst << " of the motion" << std::endl;
}

// mesh_accuracy.png from mesh_accuracy.csv (gnuplot; no chart without it).
void writeMeshChart(const std::filesystem::path& out, int truthM) {
  if (std::system("command -v gnuplot > /dev/null 2>&1") != 0) return;
  const auto gp = out / "mesh_accuracy.gp";
  const std::string f = (out / "mesh_accuracy.csv").string();
  std::ofstream(gp) << "set datafile separator ','\nset terminal pngcairo size 900,560 font ',11'\nset output '" << (out / "mesh_accuracy.png").string()
                    << "'\nset termoption noenhanced\nset title 'Fine mesh against a regular mesh " << truthM
                    << "x finer per cell edge: displacement error'\nset logscale xy\nset xlabel 'fine tets'\n"
                    << "set ylabel 'RMS error / handle motion'\nset grid\nset key top right\n"
                    << "plot '" << f << "' using (strcol(1) eq 'regular' ? $3 : 1/0):9 with linespoints pt 7 ps 1.3 title 'regular refinement (baseline)', "
                    << "'' using (strcol(1) eq 'adapted' ? $3 : 1/0):9 with linespoints pt 5 ps 1.3 title 'image-adapted (TetGen, points at stiffness jumps)', "
                    << "'' using (strcol(1) eq 'regular' ? $3 : 1/0):9:2 with labels offset 0,1 notitle, "
                    << "'' using (strcol(1) eq 'adapted' ? $3 : 1/0):9:2 with labels offset 0,-1 notitle\n";
  if (std::system(("gnuplot " + gp.string() + " 2>/dev/null").c_str()) != 0) std::cerr << "gnuplot failed: no chart\n";
}

}  // namespace

int cmdBenchMesh(const Words& words) {
  Args args(words, {"--handle", "--handle-label", "--coarse-tets", "--regular-list", "--adapted-list", "--truth-refinement", "--contrast", "--spacing", "--out"},
            {"--quiet"});
  if (args.help() || args.positional().size() > 1 || (args.positional().size() == 1) != bool(args.value("--handle"))) {
    usageStream(args) << kBenchMeshHelp;
    return args.help() ? 0 : 2;
  }
  const ProgressFn progress = args.flag("--quiet") ? ProgressFn{} : consoleProgress();
  const std::vector<int> regular = integerListOption(args, "--regular-list", "2,3,4,5,6", 1, 16);
  const std::vector<int> adapted = integerListOption(args, "--adapted-list", "2,3,4", 1, 16);
  const int truthM = int(args.integer("--truth-refinement", 8, 2, 16));
  const int coarse = int(args.integer("--coarse-tets", 600, 6, 100000));
  const double contrast = args.number("--contrast", 10.0, 1.01, 1e9);
  const std::filesystem::path out = args.valueOr("--out", "bench-out");
  std::filesystem::create_directories(out);
  HandleScene loaded = handleSceneOptions(args, 2.0, progress);
  const Volume image = std::move(loaded.image);
  const SimHandle handle{std::move(loaded.handle), {}};
  const MeshCase mc{image, handle, coarse, contrast, progress};
  std::cout << std::fixed;
  const Solved truth = solveMesh(mc, truthM, false);
  const double motion = handleMotion(mc, truth);
  if (!(motion > 0.0)) throw Error("bench mesh: the handle moves no free fine node of the truth's mesh (more --coarse-tets or a larger --truth-refinement)");
  std::cout << "truth: regular m = " << truthM << ", " << truth.scene.meshes.fine.tets.size() << " fine tets, solved in " << std::setprecision(1)
            << truth.solveSeconds << " s; handle motion " << std::setprecision(2) << motion << " mm\n";
  std::ofstream csv(out / "mesh_accuracy.csv");
  csv << "mesh,refinement,fine_tets,fine_nodes,structure_points,fallback_cells,mesh_s,solve_s,rms,max\n";
  for (int m : regular) measureMesh(mc, truth, motion, m, false, csv);
  for (int m : adapted) measureMesh(mc, truth, motion, m, true, csv);
  csv.close();
  writeMeshChart(out, truthM);
  std::cout << "wrote " << (out / "mesh_accuracy.csv").string() << " and the chart mesh_accuracy.png\n";
  return 0;
}

}  // namespace handson::cli
