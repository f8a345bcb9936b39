// `handson bench hyperelastic`: where the linear corotational material stops holding - the fine
// reference's force and displacement against a compressible Neo-Hookean reference on the same mesh
// (sim/neo_hookean.h) as the handle's motion, and with it the strain, grows
// (docs/tissue-physics.md, "Where the linear material stops holding").
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>

#include "app/bench/bench.h"
#include "app/cli/args.h"
#include "app/session/console.h"
#include "sim/base/error.h"
#include "sim/handle_reaction.h"
#include "sim/sim_scene.h"
#include "sim/strain.h"

namespace handson::cli {

namespace {

constexpr const char* kBenchHyperelasticHelp =
    "usage: handson bench hyperelastic [PATH --handle MASK [--handle-label N]] [--out DIR] [--max-mm D] [--step-mm D]\n"
    "        [--coarse-tets N] [--fine-tets N] [--spacing MM] [--interface sliding|glued] [tissue rules]\n"
    "  The handle (default: the built-in phantom's right kidney) moved 0..D mm (default 30, in steps of 5)\n"
    "  craniocaudally; at each motion the fine reference with the linear corotational material and with\n"
    "  compressible Neo-Hookean (from the corotational answer), on the same mesh (default 1600 coarse /\n"
    "  102400 fine tets): their reaction forces, the RMS difference of their free nodes' displacements\n"
    "  (of the handle's motion) and the peak strain, in DIR/hyperelastic.csv and DIR/hyperelastic.png;\n"
    "  prints the strain at which they first part by 10 % (force or displacement); stops where the\n"
    "  corotational answer inverts a tet (the Neo-Hookean reference cannot start from it).\n";

struct Sample {
  double motionMm = 0, peakStrain = 0, forceCorotational = 0, forceNeoHookean = 0, displacementDifference = 0;
  double parting() const {
    const double f = forceNeoHookean > 0 ? std::abs(forceCorotational - forceNeoHookean) / forceNeoHookean : 0.0;
    return std::max(f, displacementDifference);
  }
};

// The peak strain of tissue with a limit (not the exterior layer nor a sliding handle's own tets).
double peakStrain(const SimScene& sc, const std::vector<Eigen::Vector3d>& x) {
  const std::vector<float> strain = tetStrain(sc.meshes.fine, x);
  double peak = 0;
  for (std::size_t t = 0; t < strain.size(); ++t)
    if (sc.band[t] >= 0 && std::isfinite(strain[t])) peak = std::max(peak, double(strain[t]));
  return peak;
}

// RMS over the free nodes of the difference of two answers, over the handle's motion.
double displacementDifference(const SimScene& sc, const std::vector<Eigen::Vector3d>& a, const std::vector<Eigen::Vector3d>& b, double motionMm) {
  double s = 0;
  std::size_t n = 0;
  for (std::size_t i = 0; i < a.size(); ++i)
    if (!sc.constraints.fixed[i] && sc.constraints.handleOf[i] < 0) {
      s += (a[i] - b[i]).squaredNorm();
      ++n;
    }
  return n && motionMm > 0 ? std::sqrt(s / double(n)) / motionMm : 0.0;
}

Sample measure(const SimScene& sc, double motionMm, std::vector<Eigen::Vector3d>& start) {
  const std::vector<RigidTransform> T{RigidTransform::about(sc.handleCentroid[0], Eigen::Vector3d::Zero(), Eigen::Vector3d(0, 0, motionMm))};
  const StaticSolveResult co = solveFineStatic(sc, T, {}, &start);
  const StaticSolveResult nh = solveFineStatic(sc, T, {}, &co.x, FineMaterial::NeoHookean);
  if (!co.converged || !nh.converged) std::cerr << "warning: a fine solve at " << motionMm << " mm did not converge\n";
  const std::vector<NeoHookeanTet> tets = neoHookeanTets(sc.meshes.fine, sc.youngs, sc.poisson);
  Sample s;
  s.motionMm = motionMm;
  s.peakStrain = peakStrain(sc, co.x);
  s.forceCorotational = fineHandleReactions(sc.meshes.fine, sc.fineK, sc.constraints, T, co.x)[0].forceN.norm();
  s.forceNeoHookean = fineHandleReactions(sc.meshes.fine, sc.fineK, sc.constraints, T, nh.x, &tets)[0].forceN.norm();
  s.displacementDifference = displacementDifference(sc, co.x, nh.x, motionMm);
  start = co.x;
  return s;
}

void chart(const std::filesystem::path& out) {
  if (std::system("command -v gnuplot > /dev/null 2>&1") != 0) return;
  const auto gp = out / "hyperelastic.gp";
  const std::string f = (out / "hyperelastic.csv").string();
  std::ofstream(gp) << "set datafile separator ','\nset terminal pngcairo size 1100,440 font ',11'\nset output '" << (out / "hyperelastic.png").string()
                    << "'\nset termoption noenhanced\nset multiplot layout 1,2 title 'Linear corotational against Neo-Hookean (fine reference)'\n"
                    << "set grid\nset key top left\nset xlabel 'handle motion (mm)'\nset ylabel 'reaction force (N)'\n"
                    << "plot '" << f << "' every ::1 using 1:3 with linespoints title 'corotational', '' every ::1 using 1:4 with linespoints title 'Neo-Hookean'\n"
                    << "set xlabel 'peak strain'\nset ylabel 'difference (fraction)'\n"
                    << "plot '" << f << "' every ::1 using 2:(abs($3-$4)/$4) with linespoints title 'force', '' every ::1 using 2:5 with linespoints title "
                    << "'displacement (RMS / motion)', 0.1 with lines dt 2 title '10 %'\nunset multiplot\n";
  if (std::system(("gnuplot " + gp.string() + " 2>/dev/null").c_str()) != 0) std::cerr << "gnuplot failed: no chart\n";
}

}  // namespace

int cmdBenchHyperelastic(const Words& words) {
  Args args(words,
            {"--handle", "--handle-label", "--out", "--max-mm", "--step-mm", "--coarse-tets", "--fine-tets", "--spacing", "--handle-nodes", "--bone",
             "--outer-boundary", "--interface"},
            {"--quiet"});
  if (args.help() || args.positional().size() > 1 || (args.positional().size() == 1) != bool(args.value("--handle"))) {
    usageStream(args) << kBenchHyperelasticHelp;
    return args.help() ? 0 : 2;
  }
  const double maxMm = args.number("--max-mm", 30.0, 0.0, 200.0), stepMm = args.number("--step-mm", 5.0, 0.1, 200.0);
  SimSettings s;
  s.coarseTets = int(args.integer("--coarse-tets", 1600, 6, 2000000));
  s.fineTets = int(args.integer("--fine-tets", 102400, 6, 20000000));
  tissueRuleOptions(args, "--", s);
  interfaceOption(args, "--", s);
  const std::filesystem::path out = args.valueOr("--out", "bench-out");
  std::filesystem::create_directories(out);
  HandleScene loaded = handleSceneOptions(args, 2.0, args.flag("--quiet") ? ProgressFn{} : consoleProgress());
  const SimScene sc = buildSimScene(loaded.image, {SimHandle{loaded.handle, {RigidTransform{Eigen::Matrix3d::Identity(), Eigen::Vector3d(0, 0, maxMm)}}}}, s);
  std::ofstream csv(out / "hyperelastic.csv");
  csv << "motion_mm,peak_strain,force_corotational_N,force_neo_hookean_N,displacement_difference\n";
  std::cout << "corotational against Neo-Hookean (" << sc.meshes.fine.tets.size() << " fine tets, " << interfaceName(s.interface) << "):\n";
  std::vector<Eigen::Vector3d> start = sc.meshes.fine.nodes;
  double partsAt = -1, lastMm = 0, lastStrain = 0;
  for (int k = 1; k * stepMm <= maxMm + 1e-9; ++k) {
    Sample m;
    try {
      m = measure(sc, k * stepMm, start);
    } catch (const Error& e) {
      // Where the linear model fails first: its answer inverts a tet, which the Neo-Hookean
      // reference (infinite energy there) cannot start from. The motions so far are kept.
      std::cout << "  " << k * stepMm << " mm: stopped - " << e.what() << "\n";
      break;
    }
    csv << m.motionMm << "," << m.peakStrain << "," << m.forceCorotational << "," << m.forceNeoHookean << "," << m.displacementDifference << "\n";
    std::cout << std::fixed << std::setprecision(3) << "  " << m.motionMm << " mm (peak strain " << m.peakStrain << "): force " << m.forceCorotational
              << " / " << m.forceNeoHookean << " N, displacements " << 100 * m.displacementDifference << " % apart\n";
    if (partsAt < 0 && m.parting() > 0.1) partsAt = m.peakStrain;
    lastMm = m.motionMm;
    lastStrain = m.peakStrain;
  }
  csv.close();
  chart(out);
  std::cout << std::defaultfloat << std::setprecision(3);
  if (partsAt < 0) std::cout << "they stay within 10 % up to " << lastMm << " mm (peak strain " << lastStrain << ")\n";
  else std::cout << "they part by 10 % at a peak strain of " << partsAt << "\n";
  std::cout << "wrote " << (out / "hyperelastic.csv").string() << "\n";
  return 0;
}

}  // namespace handson::cli
