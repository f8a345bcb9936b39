// `handson bench stability`: where the simulation's methods fail (docs/simulation-outputs.md,
// "Stability"), on the synthetic box scene (sim/box_scene.h): a ball handle rotated by growing angles in one
// step and with the app's continuation (increments of at most 30 degrees), and a stiff slab beside
// the handle at growing stiffness contrast. Per method: finite, converged, inverted fine tets,
// iterations and (contrast) the coarse model's error against the fine one. CSV + PNG.
#include <Eigen/Geometry>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <random>

#include "app/bench/bench.h"
#include "app/cli/args.h"
#include "interaction/gesture_solve.h"
#include "interaction/region_grow.h"
#include "sim/box_scene.h"
#include "sim/quantized_volume.h"

namespace handson::cli {

namespace {
const char* const kBenchStabilityHelp =
    "usage: handson bench stability [--out DIR] [--angles A,A,..] [--contrasts C,C,..] [--quick]\n"
    "  Sweeps on a 60x40x40 mm box (12,960 fine tets, fixed faces, a 9 mm ball handle):\n"
    "  rotation angle (degrees, default 15,30,45,60,90,120,150,180), each in one step and in <= 30 degree\n"
    "  increments (what the app does), for the coarse model and the fine solve; and the stiffness\n"
    "  contrast of a slab beside the handle (default 1,10,100,1e3,1e4,1e5,1e6). Failure: a non-finite\n"
    "  result, no convergence, or inverted tets (rotation); the coarse error against the fine answer\n"
    "  (contrast). Writes stability_rotation.csv, stability_contrast.csv and stability.png.\n"
    "  Then the interaction's methods (stability_drag.csv, stability_layout.csv, stability_seed.csv,\n"
    "  stability_interaction.png): the gesture solve against the finger step per event (one linearized\n"
    "  step vs the app's 2 px sub-steps; failure: an error over 0.5 px), against finger layouts (two\n"
    "  fingers closing in, three closing onto a line; the guard: refusal), and region growing against\n"
    "  the seed's contrast (a 12 mm ball in 15 HU noise; failure: over 10 % of the selection outside it).\n"
    "  --quick: 40 gesture cases per point instead of 200.\n";

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

constexpr double kPxPerNdc = 500.0;  // a 1000-pixel-high view

Eigen::Vector2d project(const GestureProblem& p, const Eigen::Vector3d& v) { return p.projection * v / v.z(); }

// A gesture on handle points 400 mm deep, moved by a random rigid motion within the finger count's
// degrees of freedom, scaled so that the largest finger step is stepPx.
GestureProblem movedPoints(std::mt19937& rng, std::vector<Eigen::Vector3d> points, double stepPx, double* turnDeg = nullptr) {
  std::uniform_real_distribution<double> u(-1, 1);
  GestureProblem p;
  const double f = 1.0 / std::tan(0.5 * 35.0 * M_PI / 180.0);
  p.projection << f, 0, 0, 0, f, 0;
  p.points = std::move(points);
  const std::size_t n = p.points.size();
  Eigen::Vector3d c = Eigen::Vector3d::Zero();
  for (const auto& q : p.points) c += q;
  c /= double(n);
  const Eigen::Vector3d t(u(rng), u(rng), n == 1 ? 0.0 : u(rng));
  const Eigen::Vector3d axis = n == 2 ? Eigen::Vector3d::UnitZ() : Eigen::Vector3d(u(rng), u(rng), u(rng)).normalized();
  const double angle = n == 1 ? 0.0 : 0.02 * u(rng);
  auto targets = [&](double k) {
    const Eigen::Matrix3d R = Eigen::AngleAxisd(angle * k, axis).toRotationMatrix();
    std::vector<Eigen::Vector2d> out;
    for (const auto& q : p.points) out.push_back(project(p, R * (q - c) + c + t * k));
    return out;
  };
  auto largest = [&](const std::vector<Eigen::Vector2d>& tg) {
    double l = 0;
    for (std::size_t j = 0; j < n; ++j) l = std::max(l, (tg[j] - project(p, p.points[j])).norm() * kPxPerNdc);
    return l;
  };
  double k = stepPx / std::max(largest(targets(1.0)), 1e-12);
  for (int it = 0; it < 3; ++it) k *= stepPx / std::max(largest(targets(k)), 1e-12);
  p.targets = targets(k);
  if (turnDeg) *turnDeg = std::abs(angle * k) * 180.0 / M_PI;
  return p;
}

// A point at depth z whose projection is `px` pixels from the view's centre.
Eigen::Vector3d atPixels(const Eigen::Vector2d& px, double z) {
  const double f = 1.0 / std::tan(0.5 * 35.0 * M_PI / 180.0);
  return {px.x() / kPxPerNdc * z / f, px.y() / kPxPerNdc * z / f, z};
}

struct GestureOutcome {
  double rmsPx = 0, maxPx = 0;
  double maxUnclampedPx = 0;    ///< the largest error among solves the per-event clamp did not reduce
  int clamped = 0;
  double maxExcessTurnDeg = 0;  ///< the solve's turn beyond the true motion's (a spin about an unobservable axis)
  int refused = 0, nonFinite = 0;
};

template <class Solve>
GestureOutcome runGestures(const std::vector<GestureProblem>& cases, Solve&& solve, const std::vector<double>& trueTurnDeg = {}) {
  GestureOutcome o;
  double sum2 = 0;
  int n = 0;
  for (std::size_t i = 0; i < cases.size(); ++i) {
    const GestureProblem& p = cases[i];
    const RigidIncrement r = solve(p);
    if (!r.motion.R.allFinite() || !r.motion.t.allFinite() || !std::isfinite(r.rmsAfter)) {
      ++o.nonFinite;
      continue;
    }
    if (!r.ok) {
      ++o.refused;
      continue;
    }
    const double e = r.rmsAfter * kPxPerNdc;
    sum2 += e * e;
    ++n;
    o.maxPx = std::max(o.maxPx, e);
    if (r.clamped) ++o.clamped;
    else o.maxUnclampedPx = std::max(o.maxUnclampedPx, e);
    const double turn = Eigen::AngleAxisd(r.motion.R).angle() * 180.0 / M_PI;
    o.maxExcessTurnDeg = std::max(o.maxExcessTurnDeg, turn - (i < trueTurnDeg.size() ? trueTurnDeg[i] : 0.0));
  }
  o.rmsPx = n ? std::sqrt(sum2 / n) : std::nan("");
  return o;
}

// Seed contrast: a 12 mm ball of value 40 + contrast * 15 HU in 40 HU tissue with 15 HU of
// Gaussian noise (1 mm voxels, an air slab and a bone slab so the 16-bit window is a CT's), grown
// from its centre to 24 mm. Leak: selected voxels outside the ball / selected; recall: ball voxels
// selected / ball voxels.
struct SeedOutcome {
  double leak = 0, recall = 0, selectedRadiusMm = 0;
};
SeedOutcome growInBall(double contrast, GrowCriterion criterion, std::uint32_t seed) {
  constexpr int n = 64;
  VolumeGeometry g;
  g.dims = {n, n, n};
  g.spacing = {1, 1, 1};
  Volume v(g, ScalarType::Int16);
  std::mt19937 rng(seed);
  std::normal_distribution<double> noise(0.0, 15.0);
  const Eigen::Vector3d c(n / 2, n / 2, n / 2);
  for (int k = 0; k < n; ++k)
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i) {
        double val = 40.0 + noise(rng);
        if ((Eigen::Vector3d(i, j, k) - c).norm() <= 12.0) val += contrast * 15.0;
        if (k == 0) val = -1000;
        if (k == n - 1) val = 1200;
        v.setValue(i, j, k, float(std::round(val)));
      }
  const QuantizedVolume q = quantizeVolume(v);
  GrowParams gp;
  gp.criterion = criterion;
  RegionGrower grower(q, Eigen::Vector3i(n / 2, n / 2, n / 2), gp);
  grower.growTo(24.0);
  const std::vector<std::uint8_t> m = grower.mask(24.0);
  std::size_t selected = 0, outside = 0, ball = 0, ballSelected = 0;
  SeedOutcome o;
  for (std::size_t i = 0; i < m.size(); ++i) {
    const Eigen::Vector3i p = g.voxelOf(i);
    const double r = (p.cast<double>() - c).norm();
    const bool in = r <= 12.0;
    ball += in;
    if (!m[i]) continue;
    ++selected;
    outside += !in;
    ballSelected += in;
    o.selectedRadiusMm = std::max(o.selectedRadiusMm, r);
  }
  o.leak = selected ? double(outside) / double(selected) : 0.0;
  o.recall = double(ballSelected) / double(std::max<std::size_t>(ball, 1));
  return o;
}
// The handle turned by each angle, in one step and in <= 30 degree increments: stability_rotation.csv.
void rotationSweep(const std::filesystem::path& out, const std::vector<double>& angles) {
  std::ofstream rot(out / "stability_rotation.csv");
  rot << "angle_deg,increments,coarse_finite,coarse_converged,coarse_inverted,coarse_iterations,fine_finite,fine_converged,fine_inverted,fine_iterations\n";
  BoxScene box;
  box.ball({30, 20, 20}, 9, 0);
  double firstFail[4] = {0, 0, 0, 0};  // coarse one step, coarse continued, fine one step, fine continued
  std::cout << "rotation of a 9 mm ball about z (12,960 fine tets):\n";
  for (double a : angles) {
    const Eigen::Vector3d rv(0, 0, a * M_PI / 180);
    const auto at = [&](double f) { return std::vector<RigidTransform>{RigidTransform::about({30, 20, 20}, f * rv, Eigen::Vector3d::Zero())}; };
    StabilityOutcome oneStep;
    for (int mode = 0; mode < 2; ++mode) {
      const int inc = mode == 0 ? 1 : std::max(1, int(std::ceil(a / 30.0 - 1e-9)));
      // Up to 30 degrees continuation is one step too: the same solve, not run twice.
      const StabilityOutcome o = mode == 1 && inc == 1 ? oneStep : solveBoxMotion(box, at, inc);
      if (mode == 0) oneStep = o;
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

}

// A stiff slab beside a moved ball, by contrast: stability_contrast.csv.
void contrastSweep(const std::filesystem::path& out, const std::vector<double>& contrasts) {
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
}

void dragSweep(const std::filesystem::path& out, std::mt19937& rng, int cases) {
  // The interaction's methods. Drag speed: the finger step per event, one linearized step (the
  // spec's) against the app's guard (2 px sub-steps); failure: an error over 0.5 px (the finger
  // visibly leaves the point it holds).
  std::ofstream drag(out / "stability_drag.csv");
  drag << "fingers,step_px,one_step_rms_px,one_step_max_px,substeps_rms_px,substeps_max_px,non_finite\n";
  std::cout << "\ngesture solve against the finger step per event (" << cases << " random rigid motions each):\n";
  double dragBreak[2] = {0, 0}, dragGuardBreak[2] = {0, 0};
  for (int fingers : {2, 3}) {
    for (double step : {1.0, 2.0, 5.0, 10.0, 20.0, 50.0, 100.0, 200.0}) {
      std::vector<GestureProblem> ps;
      std::uniform_real_distribution<double> spread(-60, 60);
      while (int(ps.size()) < cases) {
        std::vector<Eigen::Vector2d> at;
        for (int i = 0; i < fingers; ++i) at.emplace_back(spread(rng), spread(rng));
        bool apart = true;  // >= 40 px apart: a comfortable layout (layouts are swept below)
        for (int a = 0; a < fingers; ++a)
          for (int b = a + 1; b < fingers; ++b) apart = apart && (at[std::size_t(a)] - at[std::size_t(b)]).norm() >= 40;
        if (!apart) continue;
        std::vector<Eigen::Vector3d> pts;
        for (const auto& a : at) pts.push_back(atPixels(a, 400 + spread(rng)));
        ps.push_back(movedPoints(rng, pts, step));
      }
      const GestureOutcome one = runGestures(ps, [](const GestureProblem& p) { return solveLinearized(p); });
      const GestureOutcome sub = runGestures(ps, [](const GestureProblem& p) { return solveLinearizedSubsteps(p); });
      drag << fingers << "," << step << "," << one.rmsPx << "," << one.maxPx << "," << sub.rmsPx << "," << sub.maxPx << "," << one.nonFinite + sub.nonFinite << "\n";
      if (one.maxPx > 0.5 && dragBreak[fingers - 2] == 0) dragBreak[fingers - 2] = step;
      if (sub.maxPx > 0.5 && dragGuardBreak[fingers - 2] == 0) dragGuardBreak[fingers - 2] = step;
      std::cout << "  " << fingers << " fingers, " << std::setw(5) << step << " px: one step RMS " << std::setprecision(3) << one.rmsPx << " (max "
                << one.maxPx << ") px, sub-stepped RMS " << sub.rmsPx << " (max " << sub.maxPx << ") px"
                << (one.nonFinite + sub.nonFinite ? ", NON-FINITE" : "") << std::setprecision(6) << std::endl;
    }
  }
  auto px = [](double v) { return v > 0 ? std::to_string(int(v)) + " px" : std::string("none in the sweep"); };
  std::cout << "first step with an error over 0.5 px: one step " << px(dragBreak[0]) << " (2 fingers), " << px(dragBreak[1])
            << " (3); sub-stepped (the app) " << px(dragGuardBreak[0]) << " / " << px(dragGuardBreak[1]) << "\n";

}

void layoutSweep(const std::filesystem::path& out, std::mt19937& rng, int cases) {
  // Finger layouts: two fingers closing in (0: coincident) and three fingers closing onto a line
  // (0: collinear), a 5 px motion each, the app's solve. Failure: a non-finite answer or an error over
  // 0.5 px not explained by the per-event clamp (the guard: a step reduced to the clamp is finished by
  // the next events); refusals are counted. Three points ~400 mm away fix an out-of-plane turn only
  // through perspective, so the solve may fit the fingers with another turn than the generating
  // motion's (reported: the same cue lets three fingers tilt a handle, see the out-of-plane scenario).
  std::ofstream lay(out / "stability_layout.csv");
  lay << "layout,spacing_px,cases,refused,non_finite,rms_px,max_px,max_excess_turn_deg,clamped,max_unclamped_px\n";
  std::cout << "\nfinger layouts (5 px motion, the app's sub-stepped solve):\n";
  for (int layout = 0; layout < 2; ++layout)
    for (double sp : {0.0, 0.01, 0.1, 0.5, 1.0, 2.0, 5.0, 10.0, 20.0, 40.0}) {
      std::vector<GestureProblem> ps;
      std::vector<double> turns;
      std::uniform_real_distribution<double> at(-60, 60), ang(0, 2 * M_PI);
      for (int i = 0; i < cases; ++i) {
        const Eigen::Vector2d o(at(rng), at(rng));
        const double a = ang(rng);
        const Eigen::Vector2d d(std::cos(a), std::sin(a)), nrm(-std::sin(a), std::cos(a));
        std::vector<Eigen::Vector3d> pts;
        if (layout == 0) {
          pts = {atPixels(o, 400), atPixels(o + sp * d, 400)};
        } else {  // two fingers 40 px apart and a third `sp` px off the line through them
          pts = {atPixels(o - 20 * d, 400), atPixels(o + 20 * d, 400), atPixels(o + 5 * d + sp * nrm, 400)};
        }
        double turn = 0;
        ps.push_back(movedPoints(rng, pts, 5.0, &turn));
        turns.push_back(turn);
      }
      const GestureOutcome r = runGestures(ps, [](const GestureProblem& p) { return solveLinearizedSubsteps(p); }, turns);
      const char* name = layout == 0 ? "two-fingers-apart" : "three-fingers-off-line";
      lay << name << "," << sp << "," << cases << "," << r.refused << "," << r.nonFinite << "," << r.rmsPx << "," << r.maxPx << "," << r.maxExcessTurnDeg << "," << r.clamped << "," << r.maxUnclampedPx << "\n";
      std::cout << "  " << name << " " << std::setw(5) << sp << " px: " << r.refused << " refused, " << r.nonFinite << " non-finite, error RMS "
                << std::setprecision(3) << r.rmsPx << " (max " << r.maxPx << ") px (" << r.clamped << " clamped; unclamped max " << r.maxUnclampedPx << " px), turn beyond the generating motion's up to " << r.maxExcessTurnDeg << " deg" << std::setprecision(6)
                << std::endl;
    }

}

void seedSweep(const std::filesystem::path& out) {
  // Seed contrast: where region growing leaks (both criteria, 3 noise seeds each).
  std::ofstream seedCsv(out / "stability_seed.csv");
  seedCsv << "contrast_sigma,criterion,leak,recall,selected_radius_mm\n";
  std::cout << "\nregion growing against seed contrast (12 mm ball in 15 HU noise, grown to 24 mm):\n";
  double leakBelow[2] = {0, 0};
  for (GrowCriterion cr : {GrowCriterion::Paper, GrowCriterion::Smoothed}) {  // criterion by criterion: one line each in the chart
    for (double c : {0.5, 1.0, 2.0, 3.0, 4.0, 6.0, 8.0, 12.0}) {
      SeedOutcome mean;
      for (std::uint32_t sd = 1; sd <= 3; ++sd) {
        const SeedOutcome o = growInBall(c, cr, sd);
        mean.leak += o.leak / 3;
        mean.recall += o.recall / 3;
        mean.selectedRadiusMm = std::max(mean.selectedRadiusMm, o.selectedRadiusMm);
      }
      const int ci = cr == GrowCriterion::Paper ? 0 : 1;
      if (mean.leak > 0.1) leakBelow[ci] = c;
      seedCsv << c << "," << (ci == 0 ? "paper" : "smoothed") << "," << mean.leak << "," << mean.recall << "," << mean.selectedRadiusMm << "\n";
      std::cout << "  contrast " << std::setw(4) << c << " sigma, " << (ci == 0 ? "paper   " : "smoothed") << ": leak " << std::setprecision(3) << mean.leak
                << ", recall " << mean.recall << ", farthest selected voxel " << mean.selectedRadiusMm << " mm (extent 24)" << std::setprecision(6)
                << std::endl;
    }
  }
  std::cout << "leaks (over 10 % of the selection outside the organ) up to a contrast of " << leakBelow[0] << " sigma (paper), " << leakBelow[1]
            << " sigma (smoothed); the selection never leaves the fingers' extent ball\n";
}

// stability_interaction.png and stability.png from the CSVs (gnuplot; no charts without it).
void stabilityCharts(const std::filesystem::path& out) {
  if (std::system("command -v gnuplot > /dev/null 2>&1") == 0) {
    const auto gp = out / "stability_interaction.gp";
    const std::string d = (out / "stability_drag.csv").string(), l = (out / "stability_layout.csv").string(), sc = (out / "stability_seed.csv").string();
    std::ofstream(gp) << "set datafile separator ','\nset terminal pngcairo size 1500,480 font ',10'\nset output '"
                      << (out / "stability_interaction.png").string() << "'\nset termoption noenhanced\nset multiplot layout 1,3\n"
                      << "set title 'Drag speed: gesture error after one event'\nset logscale xy\nset xlabel 'finger step per event (px)'\n"
                      << "set ylabel 'largest error (px)'\nset format y '%g'\nset grid\nset key top left\nset yrange [1e-5:*]\n"
                      << "set arrow 1 from 1,0.5 to 200,0.5 nohead dt 2 lc rgb '#cc0000'\n"
                      << "plot for [n=2:3] '" << d << "' using ($1==n ? $2 : 1/0):($4+1e-5) with linespoints lw 2 title sprintf('one step (spec), %d fingers', n), "
                      << "for [n=2:3] '" << d << "' using ($1==n ? $2 : 1/0):($6+1e-5) with linespoints dt 2 title sprintf('2 px sub-steps (app), %d', n)\n"
                      << "unset arrow 1\nset title 'Finger layouts: the app solve on 5 px motions'\nset xlabel 'finger spacing / distance off the line (px; 0 plotted at 0.001)'\n"
                      << "set ylabel 'refused fraction; largest excess turn / 30 deg'\nset logscale x\nunset logscale y\nset yrange [0:1.05]\n"
                      << "plot '" << l << "' using (strcol(1) eq 'two-fingers-apart' ? ($2 > 0 ? $2 : 0.001) : 1/0):($4/$3) with linespoints pt 7 title 'two fingers: refused', "
                      << "'' using (strcol(1) eq 'three-fingers-off-line' ? ($2 > 0 ? $2 : 0.001) : 1/0):($4/$3) with linespoints pt 5 title 'three, off a line: refused', "
                      << "'' using (strcol(1) eq 'two-fingers-apart' ? ($2 > 0 ? $2 : 0.001) : 1/0):($8/30) with linespoints dt 2 pt 6 title 'two: excess turn', "
                      << "'' using (strcol(1) eq 'three-fingers-off-line' ? ($2 > 0 ? $2 : 0.001) : 1/0):($8/30) with linespoints dt 2 pt 4 title 'three: excess turn'\n"
                      << "set title 'Seed contrast: region growing leak'\nset xlabel 'organ contrast (noise sigmas)'\nset ylabel 'fraction'\nset logscale x\n"
                      << "set arrow 2 from 0.5,0.1 to 12,0.1 nohead dt 2 lc rgb '#cc0000'\n"
                      << "plot '" << sc << "' using (strcol(2) eq 'paper' ? $1 : 1/0):3 with linespoints pt 7 title 'leak, paper criterion', "
                      << "'' using (strcol(2) eq 'smoothed' ? $1 : 1/0):3 with linespoints pt 5 title 'leak, smoothed (default)', "
                      << "'' using (strcol(2) eq 'paper' ? $1 : 1/0):4 with linespoints dt 2 pt 6 title 'recall, paper', "
                      << "'' using (strcol(2) eq 'smoothed' ? $1 : 1/0):4 with linespoints dt 2 pt 4 title 'recall, smoothed'\n"
                      << "unset multiplot\n";
    if (std::system(("gnuplot " + gp.string() + " 2>/dev/null").c_str()) != 0) std::cerr << "gnuplot failed: no interaction chart\n";
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
}

}  // namespace

int cmdBenchStability(const Words& words) {
  Args args(words, {"--out", "--angles", "--contrasts"}, {"--quiet", "--quick"});
  const bool quick = args.flag("--quick");
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

  rotationSweep(out, angles);
  contrastSweep(out, contrasts);
  std::mt19937 rng(7);
  const int cases = quick ? 40 : 200;
  dragSweep(out, rng, cases);
  layoutSweep(out, rng, cases);
  seedSweep(out);
  stabilityCharts(out);
  std::cout << "wrote stability_rotation.csv, stability_contrast.csv, stability.png, stability_drag.csv, stability_layout.csv, stability_seed.csv and "
               "stability_interaction.png in "
            << out.string() << "\n";
  return 0;
}

}  // namespace handson::cli
