// `handson bench stability`: where the simulation's methods fail (../shared/spec/methods.md section
// 8), on the synthetic box scene (sim/box_scene.h): a ball handle rotated by growing angles in one
// step and with the app's continuation (increments of at most 30 degrees), and a stiff slab beside
// the handle at growing stiffness contrast. Per method: finite, converged, inverted fine tets,
// iterations and (contrast) the coarse model's error against the fine one. CSV + PNG.
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>

#include "app/cli.h"
#include "app/cli_args.h"
#include "sim/box_scene.h"

namespace handson::cli {

namespace {
const char* const kBenchStabilityHelp =
    "usage: handson bench stability [--out DIR] [--angles A,A,..] [--contrasts C,C,..]\n"
    "  Sweeps on a 60x40x40 mm box (12,960 fine tets, fixed faces, a 9 mm ball handle):\n"
    "  rotation angle (degrees, default 15,30,45,60,90,120,150,180), each in one step and in <= 30 degree\n"
    "  increments (what the app does), for the coarse model and the fine solve; and the stiffness\n"
    "  contrast of a slab beside the handle (default 1,10,100,1e3,1e4,1e5,1e6). Failure: a non-finite\n"
    "  result, no convergence, or inverted tets (rotation); the coarse error against the fine answer\n"
    "  (contrast). Writes stability_rotation.csv, stability_contrast.csv and stability.png.\n";

const char* yes(bool b) { return b ? "1" : "0"; }

// RMS distance between two fine answers over the free nodes, relative to the handle nodes' RMS motion.
double relativeRms(const BoxScene& s, const std::vector<RigidTransform>& T, const std::vector<Eigen::Vector3d>& a, const std::vector<Eigen::Vector3d>& b) {
  double e2 = 0, m2 = 0;
  std::size_t ne = 0, nm = 0;
  for (std::size_t n = 0; n < a.size(); ++n) {
    if (s.c.fixed[n]) continue;
    if (s.c.handleOf[n] >= 0) {
      m2 += (T[std::size_t(s.c.handleOf[n])].apply(s.meshes.fine.nodes[n]) - s.meshes.fine.nodes[n]).squaredNorm();
      ++nm;
    } else {
      e2 += (a[n] - b[n]).squaredNorm();
      ++ne;
    }
  }
  return std::sqrt(e2 / double(std::max<std::size_t>(ne, 1))) / std::max(std::sqrt(m2 / double(std::max<std::size_t>(nm, 1))), 1e-12);
}
}  // namespace

int cmdBenchStability(const Words& words) {
  Args args(words, {"--out", "--angles", "--contrasts"}, {"--quiet"});
  if (args.help() || !args.positional().empty()) {
    usageStream(args) << kBenchStabilityHelp;
    return args.help() ? 0 : 2;
  }
  const auto angles = parseNumberList(args.valueOr("--angles", "15,30,45,60,90,120,150,180"), "--angles");
  const auto contrasts = parseNumberList(args.valueOr("--contrasts", "1,10,100,1e3,1e4,1e5,1e6"), "--contrasts");
  for (double a : angles)
    if (!(a > 0 && a <= 360)) throw UsageError("--angles are degrees in (0, 360]");
  for (double c : contrasts)
    if (!(c >= 1 && c <= 1e9)) throw UsageError("--contrasts are factors in [1, 1e9]");
  const std::filesystem::path out = args.valueOr("--out", "bench-out");
  std::filesystem::create_directories(out);

  std::ofstream rot(out / "stability_rotation.csv");
  rot << "angle_deg,increments,coarse_finite,coarse_converged,coarse_inverted,coarse_iterations,fine_finite,fine_converged,fine_inverted,fine_iterations\n";
  BoxScene box;
  box.ball({30, 20, 20}, 9, 0);
  double firstFail[4] = {0, 0, 0, 0};  // coarse one step, coarse continued, fine one step, fine continued
  std::cout << "rotation of a 9 mm ball about z (12,960 fine tets):\n";
  for (double a : angles) {
    const Eigen::Vector3d rv(0, 0, a * M_PI / 180);
    const auto at = [&](double f) { return std::vector<RigidTransform>{RigidTransform::about({30, 20, 20}, f * rv, Eigen::Vector3d::Zero())}; };
    for (int mode = 0; mode < 2; ++mode) {
      const int inc = mode == 0 ? 1 : std::max(1, int(std::ceil(a / 30.0 - 1e-9)));
      const StabilityOutcome o = solveBoxMotion(box, at, inc);
      rot << a << "," << inc << "," << yes(o.coarseFinite) << "," << yes(o.coarseConverged) << "," << o.coarseInverted << "," << o.coarseIterations << ","
          << yes(o.fineFinite) << "," << yes(o.fineConverged) << "," << o.fineInverted << "," << o.fineIterations << std::endl;
      const bool coarseOk = o.coarseFinite && o.coarseConverged && o.coarseInverted == 0;
      const bool fineOk = o.fineFinite && o.fineConverged && o.fineInverted == 0;
      if (!coarseOk && firstFail[mode] == 0) firstFail[mode] = a;
      if (!fineOk && firstFail[2 + mode] == 0) firstFail[2 + mode] = a;
      std::cout << "  " << std::setw(5) << a << " deg in " << inc << " step" << (inc > 1 ? "s" : " ") << ": coarse " << (o.coarseFinite ? "finite" : "NOT FINITE")
                << (o.coarseConverged ? ", converged" : ", not converged") << ", " << o.coarseInverted << " inverted; fine "
                << (o.fineFinite ? "finite" : "NOT FINITE") << (o.fineConverged ? ", converged" : ", not converged") << " in " << o.fineIterations
                << " Newton iterations, " << o.fineInverted << " inverted" << std::endl;
    }
  }
  auto threshold = [](double v) { return v > 0 ? std::to_string(int(v)) + " deg" : std::string("none in the sweep"); };
  std::cout << "first failure (non-finite, not converged or inverted tets): coarse " << threshold(firstFail[0]) << " in one step, "
            << threshold(firstFail[1]) << " with continuation; fine " << threshold(firstFail[2]) << " in one step, " << threshold(firstFail[3])
            << " with continuation\n";

  std::ofstream con(out / "stability_contrast.csv");
  con << "contrast,coarse_finite,coarse_converged,fine_finite,fine_converged,fine_iterations,coarse_rms_vs_fine,fine_inverted\n";
  std::cout << "\nslab beside a ball moved 6 mm and tilted 0.3 rad, slab contrast:\n";
  for (double c : contrasts) {
    BoxScene s(c);
    s.ball({30, 16, 20}, 7, 0);
    const auto at = [](double f) {
      return std::vector<RigidTransform>{RigidTransform::about({30, 16, 20}, Eigen::Vector3d(0.3 * f, 0, 0), Eigen::Vector3d(0, 6 * f, 0))};
    };
    const StabilityOutcome o = solveBoxMotion(s, at, 1);
    const double err = o.coarseFinite && o.fineFinite ? relativeRms(s, at(1.0), o.coarse, o.fine) : std::nan("");
    con << c << "," << yes(o.coarseFinite) << "," << yes(o.coarseConverged) << "," << yes(o.fineFinite) << "," << yes(o.fineConverged) << ","
        << o.fineIterations << "," << err << "," << o.fineInverted << std::endl;
    std::cout << "  " << std::setw(7) << c << "x: coarse " << (o.coarseConverged ? "converged" : "NOT converged") << ", fine "
              << (o.fineConverged ? "converged" : "NOT converged") << " in " << o.fineIterations << " iterations; coarse RMS vs fine "
              << std::setprecision(4) << err << " of the motion" << std::endl;
  }
  if (std::system("command -v gnuplot > /dev/null 2>&1") == 0) {
    const auto gp = out / "stability.gp";
    const std::string r = (out / "stability_rotation.csv").string(), k = (out / "stability_contrast.csv").string();
    std::ofstream(gp) << "set datafile separator ','\nset terminal pngcairo size 1200,500 font ',11'\nset output '" << (out / "stability.png").string()
                      << "'\nset termoption noenhanced\nset multiplot layout 1,2\n"
                      << "set title 'Handle rotation: inverted fine tets (+1, log) per method'\nset xlabel 'rotation (degrees)'\n"
                      << "set ylabel 'inverted fine tets + 1'\nset logscale y\nset grid\nset key top left\n"
                      << "plot '" << r << "' using ($2 == 1 ? $1 : 1/0):($5 + 1) with points pt 7 ps 1.4 title 'coarse, one step', "
                      << "'' using ($2 > 1 || $1 <= 30 ? $1 : 1/0):($5 + 1) with points pt 6 ps 2 title 'coarse, <= 30 deg increments (app)', "
                      << "'' using ($2 == 1 ? $1 : 1/0):($9 + 1) with points pt 5 ps 1.2 title 'fine, one step', "
                      << "'' using ($2 > 1 || $1 <= 30 ? $1 : 1/0):($9 + 1) with points pt 4 ps 2.2 title 'fine, <= 30 deg increments'\n"
                      << "unset logscale y\nset title 'Stiff slab beside the handle: coarse model against fine'\nset xlabel 'stiffness contrast'\n"
                      << "set logscale x\nset ylabel 'coarse RMS error / handle motion'\nset yrange [0:*]\nset y2range [0:*]\nset y2label 'fine Newton iterations'\nset y2tics\nset key top left\n"
                      << "plot '" << k << "' using 1:7 with linespoints pt 7 title 'coarse RMS vs fine', '' using 1:6 axes x1y2 with linespoints pt 5 title 'fine Newton iterations'\n"
                      << "unset multiplot\n";
    if (std::system(("gnuplot " + gp.string() + " 2>/dev/null").c_str()) != 0) std::cerr << "gnuplot failed: no chart\n";
  }
  std::cout << "wrote stability_rotation.csv, stability_contrast.csv and stability.png in " << out.string() << "\n";
  return 0;
}

}  // namespace handson::cli
