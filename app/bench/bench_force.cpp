// The force-against-motion chart of `handson bench sim` (sim_force.csv, sim_force.png): a 7 mm
// rigid ball in the 60 x 40 x 40 mm box of 3 kPa tissue (sim/box_scene.h) pulled along x in six
// steps; the reaction the tissue exerts on it from the coarse model's condensed blocks and from the
// fine reference (projected Newton to 1e-6 of the motion). Next to them the small-motion force on a
// rigid sphere of radius a displaced by d in an unbounded medium of shear modulus mu, Poisson ratio
// nu (Kelvin's solution): F = 24 pi mu a (1 - nu) d / (5 - 6 nu) - the box's fixed walls 13-23 mm
// from the ball make both models stiffer than that bound.
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>

#include "app/bench/bench_force.h"
#include "sim/box_scene.h"
#include "sim/handle_reaction.h"
#include "sim/static_solver.h"

namespace handson::cli {

void benchForceCurve(const std::filesystem::path& out) {
  BoxScene box(1.0);
  const Eigen::Vector3d centre(30, 20, 20);
  const double radius = 7.0;
  box.ball(centre, radius, 0);
  CoarseModel model(box.meshes, box.K, box.c);
  auto xc = model.restState();
  auto x = box.meshes.fine.nodes;
  std::ofstream csv(out / "sim_force.csv");
  csv << "motion_mm,force_fine_N,force_coarse_N,force_kelvin_N,coarse_over_fine\n";
  const double E = 3e3, nu = 0.45, mu = E / (2 * (1 + nu));
  std::cout << std::defaultfloat << "\nforce against motion (a " << radius << " mm ball in the 3 kPa box, pulled along x):\n";
  for (int k = 1; k <= 6; ++k) {
    const double d = double(k);
    const std::vector<RigidTransform> T{{Eigen::Matrix3d::Identity(), Eigen::Vector3d(d, 0, 0)}};
    model.solve(T, xc, 500, 1e-8);
    std::vector<char> dir;
    auto x0 = prescribedPositions(box.meshes.fine, box.c, T, &dir);
    for (std::size_t i = 0; i < x0.size(); ++i)
      if (!dir[i]) x0[i] = x[i];  // from the last step's answer
    x = solveStatic(box.meshes.fine, box.K, dir, x0).x;
    const double ff = -fineHandleReactions(box.meshes.fine, box.K, box.c, T, x)[0].forceN.x();
    const double fc = -model.handleReactions(T, xc)[0].forceN.x();
    const double fk = 24 * M_PI * mu * (radius * 1e-3) * (1 - nu) * (d * 1e-3) / (5 - 6 * nu);
    csv << d << "," << ff << "," << fc << "," << fk << "," << fc / ff << "\n";
    std::cout << std::setprecision(4) << "  " << k << " mm: fine " << ff << " N, coarse " << fc << " N (" << std::setprecision(3) << fc / ff
              << "x), unbounded-medium bound " << std::setprecision(4) << fk << " N\n";
  }
  csv.close();
  if (std::system("command -v gnuplot > /dev/null 2>&1") != 0) return;
  const auto gp = out / "sim_force.gp";
  const std::string f = (out / "sim_force.csv").string();
  std::ofstream(gp) << "set datafile separator ','\nset terminal pngcairo size 760,480 font ',11'\nset output '" << (out / "sim_force.png").string()
                    << "'\nset termoption noenhanced\nset title 'The tissue pulls back: reaction on a 7 mm ball pulled through a 3 kPa box'\n"
                    << "set xlabel 'handle motion (mm)'\nset ylabel 'reaction force against the motion (N)'\nset grid\nset key top left\n"
                    << "plot '" << f << "' using 1:2 every ::1 with linespoints pt 7 title 'fine reference', "
                    << "'' using 1:3 every ::1 with linespoints pt 5 title 'coarse model (condensed blocks)', "
                    << "'' using 1:4 every ::1 with lines dt 2 title 'rigid sphere in an unbounded medium (Kelvin)'\n";
  if (std::system(("gnuplot " + gp.string() + " 2>/dev/null").c_str()) != 0) std::cerr << "gnuplot failed: no chart\n";
}

}  // namespace handson::cli
