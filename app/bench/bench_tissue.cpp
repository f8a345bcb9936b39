// `handson bench tissue`: what the tissue feels as a kidney is moved further (docs/tissue-physics.md).
// The handle is translated 0..max mm craniocaudally (+z, RAS superior) and anteriorly (+y), each
// motion solved from the last (the coarse model's continuation, then refinement steps toward the fine
// answer); at each motion the handle's reaction force, the tissue past its strain limit and the peak
// strain (the exterior layer's tets left out: they stand for tissue beyond the region), from the coarse
// model's reconstruction and from the refined positions. Writes tissue_response.csv and, with gnuplot,
// tissue_response.png. The interface between the handle and the tissue is glued (sliding interfaces
// are not implemented yet: the column says which).
#include <algorithm>
#include <cmath>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <sstream>

#include "app/bench/bench.h"
#include "app/cli/args.h"
#include "app/session/console.h"
#include "sim/handle_reaction.h"
#include "sim/materials.h"
#include "sim/sim_scene.h"
#include "sim/strain.h"
#include "sim/tissue_limits.h"
#include "sim/two_level.h"

namespace handson::cli {

namespace {

constexpr const char* kBenchTissueHelp =
    "usage: handson bench tissue [PATH --handle MASK [--handle-label N]] [--out DIR] [--max-mm D] [--step-mm D]\n"
    "        [--coarse-tets N] [--fine-tets N] [--refine-steps N] [--spacing MM] [--materials FILE]\n"
    "        [--handle-nodes inside|tets] [--bone anchored|by-value] [--outer-boundary exterior|wall]\n"
    "        [--interface sliding|glued|both]\n"
    "  The handle (default: the built-in phantom's right kidney) moved 0..D mm (default 30, in steps of 5)\n"
    "  craniocaudally and anteriorly: its reaction force, the tissue past its strain limit and the peak\n"
    "  strain, from the coarse model and after N refinement steps (default 2), with each interface\n"
    "  (default both: sliding and glued), in DIR/tissue_response.csv\n"
    "  (scene, interface, model, direction, motion_mm, force_N, past_limit_cm3, peak_strain) and\n"
    "  DIR/tissue_response.png (gnuplot). Meshes default to the app's (6000 coarse, 300000 fine tets).\n";

struct Row {
  double forceN = 0, pastCm3 = 0, peak = 0;
};

// The force, the tissue past its limit and the peak strain (outside the exterior layer) of positions x.
Row measure(const SimScene& sc, const MaterialTable& table, const NearestHandle& nearest, const std::vector<Eigen::Vector3d>& x, double forceN) {
  Row r;
  r.forceN = forceN;
  const std::vector<float> strain = tetStrain(sc.meshes.fine, x);
  r.pastCm3 = tissueLimits(sc.meshes.fine, strain, sc.band, table, nearest, sc.constraints.handleCount).volumeMm3 / 1000.0;
  for (std::size_t t = 0; t < strain.size(); ++t)
    if (sc.band[t] >= 0 && std::isfinite(strain[t])) r.peak = std::max(r.peak, double(strain[t]));
  return r;
}

struct RowKey {
  std::string scene;
  const char *interface, *model, *direction;
  double motionMm;
};

void write(std::ostream& csv, const RowKey& k, const Row& r) {
  csv << k.scene << "," << k.interface << "," << k.model << "," << k.direction << "," << k.motionMm << "," << r.forceN << "," << r.pastCm3 << "," << r.peak
      << "\n";
  std::cout << std::fixed << std::setprecision(2) << "  " << k.direction << " " << k.motionMm << " mm, " << k.model << ": " << r.forceN << " N, "
            << r.pastCm3 << " cm3 past the limit, peak strain " << std::setprecision(3) << r.peak << "\n";
}

struct Direction {
  const char* name;
  Eigen::Vector3d unit;
};

struct Sweep {
  std::string scene;
  Direction direction;
  std::vector<double> motions;  ///< mm, from 0, each solved from the last
  int refineSteps = 2;
};

// One direction's motions, written to csv.
void sweep(const SimScene& sc, const SimSettings& s, const Sweep& w, std::ostream& csv) {
  const Direction& d = w.direction;
  const std::string& scene = w.scene;
  CoarseModel model(sc.meshes, sc.fineK, sc.constraints, {}, s.element);
  FineRefiner refiner(model, sc.fineK, sc.youngs, sc.poisson);
  const NearestHandle nearest = nearestHandleOfNodes(sc.meshes.fine, sc.constraints, std::vector<char>(std::size_t(sc.constraints.handleCount), 1));
  std::vector<Eigen::Vector3d> xc = model.restState();
  const char* interface = interfaceName(s.interface);
  std::ostringstream refinedRows;  // after the coarse rows: each series' rows together (the chart's lines)
  for (double m : w.motions) {
    const std::vector<RigidTransform> T{RigidTransform::about(sc.handleCentroid[0], Eigen::Vector3d::Zero(), m * d.unit)};
    model.solve(T, xc, kOneOffSolveIterations);  // to convergence, not a frame's budget
    std::vector<Eigen::Vector3d> x = model.reconstruct(T, xc);
    const Row coarse = measure(sc, s.materials, nearest, x, model.handleReactions(T, xc)[0].forceN.norm());
    for (int k = 0; k < w.refineSteps; ++k) refiner.step(T, xc, x, 10);
    const Row refined = measure(sc, s.materials, nearest, x, fineHandleReactions(sc.meshes.fine, sc.fineK, sc.constraints, T, x)[0].forceN.norm());
    write(csv, {scene, interface, "coarse", d.name, m}, coarse);
    write(refinedRows, {scene, interface, "refined", d.name, m}, refined);
  }
  csv << refinedRows.str();
}

void chart(const std::filesystem::path& out, const std::vector<SimSettings::Interface>& interfaces) {
  if (std::system("command -v gnuplot > /dev/null 2>&1") != 0) return;
  const auto gp = out / "tissue_response.gp";
  const std::string f = (out / "tissue_response.csv").string();
  // Columns: 5 motion, 6 force, 7 past limit; rows selected by interface (2), model (3) and
  // direction (4). One row of panels per interface.
  auto series = [&](const char* interface, int col) {
    std::string s;
    for (const char* dir : {"craniocaudal", "anterior"})
      for (const char* model : {"coarse", "refined"})
        s += std::string(s.empty() ? "plot " : ", ") + "'" + f + "' using 5:(strcol(2) eq '" + interface + "' && strcol(3) eq '" + model +
             "' && strcol(4) eq '" + dir + "' ? $" + std::to_string(col) + " : 1/0) with linespoints title '" + dir + ", " + model + "'";
    return s + "\n";
  };
  std::ofstream g(gp);
  g << "set datafile separator ','\nset terminal pngcairo size 1100,"  << 440 * interfaces.size() << " font ',11'\nset output '"
    << (out / "tissue_response.png").string() << "'\nset termoption noenhanced\nset multiplot layout " << interfaces.size()
    << ",2 title 'What the tissue feels as the handle moves'\nset xlabel 'handle motion (mm)'\nset grid\nset key top left\n";
  for (const auto i : interfaces)
    g << "set ylabel 'reaction force (N), " << interfaceName(i) << "'\n" << series(interfaceName(i), 6) << "set ylabel 'tissue past its strain limit (cm3), "
      << interfaceName(i) << "'\n" << series(interfaceName(i), 7);
  g << "unset multiplot\n";
  g.close();
  if (std::system(("gnuplot " + gp.string() + " 2>/dev/null").c_str()) != 0) std::cerr << "gnuplot failed: no chart\n";
}

}  // namespace

int cmdBenchTissue(const Words& words) {
  Args args(words,
            {"--handle", "--handle-label", "--out", "--max-mm", "--step-mm", "--coarse-tets", "--fine-tets", "--refine-steps", "--spacing", "--materials",
             "--handle-nodes", "--bone", "--outer-boundary", "--interface"},
            {"--quiet"});
  if (args.help() || args.positional().size() > 1 || (args.positional().size() == 1) != bool(args.value("--handle"))) {
    usageStream(args) << kBenchTissueHelp;
    return args.help() ? 0 : 2;
  }
  const double maxMm = args.number("--max-mm", 30.0, 0.0, 200.0), stepMm = args.number("--step-mm", 5.0, 0.1, 200.0);
  const int refineSteps = int(args.integer("--refine-steps", 2, 0, 100));
  SimSettings s;
  s.coarseTets = int(args.integer("--coarse-tets", s.coarseTets, 6, 2000000));
  s.fineTets = int(args.integer("--fine-tets", s.fineTets, 6, 20000000));
  if (auto m = args.value("--materials")) s.materials = MaterialTable::load(*m);
  std::vector<SimSettings::Interface> interfaces{SimSettings::Interface::Sliding, SimSettings::Interface::Glued};
  if (const auto v = args.value("--interface"); v && *v != "both") {
    if (!parseInterface(*v)) throw UsageError("--interface must be sliding, glued or both");
    interfaces = {*parseInterface(*v)};
  }
  tissueRuleOptions(args, "--", s);
  const std::filesystem::path out = args.valueOr("--out", "bench-out");
  std::filesystem::create_directories(out);
  HandleScene loaded = handleSceneOptions(args, 2.0, args.flag("--quiet") ? ProgressFn{} : consoleProgress());
  const std::string scene = args.positional().empty() ? "phantom" : std::filesystem::path(args.positional()[0]).filename().string();
  std::vector<double> motions;
  for (int k = 0; k * stepMm <= maxMm + 1e-9; ++k) motions.push_back(k * stepMm);
  const std::vector<Direction> dirs{{"craniocaudal", Eigen::Vector3d::UnitZ()}, {"anterior", Eigen::Vector3d::UnitY()}};
  std::ofstream csv(out / "tissue_response.csv");
  csv << "scene,interface,model,direction,motion_mm,force_N,past_limit_cm3,peak_strain\n";
  std::cout << "tissue response of " << scene << " (" << s.coarseTets << " coarse / " << s.fineTets << " fine tets requested, " << refineSteps
            << " refinement steps):\n";
  for (const auto i : interfaces)
    for (const Direction& d : dirs) {
      s.interface = i;
      // The region covers the handle at its furthest motion (plus the padding).
      SimHandle h{loaded.handle, {RigidTransform{Eigen::Matrix3d::Identity(), maxMm * d.unit}}};
      const SimScene sc = buildSimScene(loaded.image, {h}, s);
      sweep(sc, s, {scene, d, motions, refineSteps}, csv);
    }
  csv.close();
  chart(out, interfaces);
  std::cout << "wrote " << (out / "tissue_response.csv").string() << "\n";
  return 0;
}

}  // namespace handson::cli
