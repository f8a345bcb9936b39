// `handson bench deform`: the GPU deformation passes on a kidney drag: moved-box resampling against
// whole-volume resampling (same run, same frames, same device), the GPU passes against their CPU
// references, the interpolation pass, and the whole deformation frame, with a CSV and a chart.
#include <Eigen/Geometry>
#include <algorithm>
#include <array>
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
#include "render/deform_pass.h"
#include "render/vk_context.h"
#include "sim/coarsening.h"
#include "sim/base/error.h"
#include "sim/fine_interpolation.h"
#include "sim/quantized_volume.h"
#include "sim/sim_scene.h"
#include "sim/tet_raster.h"

namespace handson::cli {

namespace {
const char* const kBenchDeformHelp =
    "usage: handson bench deform [PATH --handle MASK [--handle-label N]] [options]\n"
    "  A kidney drag (the handle moved --step-mm along x and turned --step-deg about z each frame, the\n"
    "  coarse model solved 3 iterations a frame) deformed on the GPU three ways in the same run: redoing\n"
    "  only the dirty bricks (8^3 voxels) whose tissue moved more than --lag-voxels since they were last\n"
    "  resampled (the app's frames during motion), then one settled frame at the exact state; redoing\n"
    "  the box of all tissue that moved (the previous method); and redoing the whole volume at the exact\n"
    "  state (the baseline the others are judged against, in time and in HU). Also: the GPU passes\n"
    "  against their CPU references (interpolation; resampling of the region) and the whole deformation\n"
    "  frame. PATH omitted: the built-in phantom (right kidney).\n"
    "  --spacing MM           phantom voxel size (default 1.75: 219x165x137 = 4.95 M voxels)\n"
    "  --coarse-tets N        (default 6000)   --fine-tets N (default 300000)   --padding-mm D (default 40)   --region box|handles\n"
    "  --coarse-element cell|tet   the coarse model's elements (default cell)\n"
    "  --frames N             drag frames (default 10)   --step-mm D (default 1)   --step-deg A (default 1)\n"
    "  --lag-voxels V         dirty bricks: the lag allowed during motion (default 0.5 voxel per axis)\n"
    "  --commit-voxels V      moved box: a fine node's new position is taken once it moved more than V\n"
    "                         voxels (default 0.001)\n"
    "  --device NAME          Vulkan device (default: automatic)   --validation\n"
    "  --out DIR              deform_frames.csv, deform_summary.csv and deform_frames.png (default bench-out)\n"
    "  --quiet\n";

bool haveTsOf(const vk::Context& ctx) { return ctx.timestampPeriodNs() > 0; }

double since(std::chrono::steady_clock::time_point t0) { return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count(); }

// The resampling passes (the interpolation is timed on its own).
const std::initializer_list<PassId> kResamplePasses = {PassId::DeformReset, PassId::DeformBounds, PassId::DeformBricks, PassId::DeformArgs, PassId::DeformClear, PassId::DeformClaim, PassId::DeformResolve};

// GPU time of the passes with one of the ids (0 without timestamps).
double passMs(const std::vector<vk::PassTiming>& t, std::initializer_list<PassId> ids) {
  double ms = 0;
  for (const auto& p : t)
    for (const PassId id : ids)
      if (p.id == id) ms += p.gpuMs;
  return ms;
}

// The benchmark's scene: the image and its 16-bit copy on the GPU, the simulation, the handle's
// mask (id 1) and the deformers' setup (a sliding handle drawn rigidly, as in the app).
struct DeformBench {
  const vk::Context& ctx;
  const Volume& image;
  const QuantizedVolume& q;
  const SimScene& sc;
  CoarseModel& model;
  const FineInterpolationData& data;
  const std::vector<std::uint8_t>& ids;
  vk::Image &volume, &mask;
  vk::DeformSetup setup;
  Eigen::Vector3i rlo, rhi;  ///< the region's voxel box
};

// The drag's frames and where its rows go.
struct DragOptions {
  int frames = 10;
  double stepMm = 1, stepDeg = 1;  ///< per frame: translation along x, rotation about z
  std::filesystem::path out;
  bool quiet = false;
};

// The three deformers a drag compares: dirty bricks, the moved box, the whole volume (exact).
struct Deformers {
  vk::GpuDeformer &bricks, &box, &whole;
};

// The last frame's region resampled on the GPU from scratch and on the CPU (the reference), and
// the fine nodes interpolated by the CPU float reference and by CoarseModel::reconstruct: times and
// the fraction of voxels within 1 HU.
struct RegionCheck {
  double cpuInterp = 0, cpuReconstruct = 0, cpuRaster = 0, gpuRegionWall = 0, gpuRegion = 0, gpuInterp = 0, withinFraction = 0;
};
RegionCheck checkRegionAgainstCpu(const DeformBench& bench, const CoarseFrameState& state, const std::vector<RigidTransform>& T,
                                  const std::vector<Eigen::Vector3d>& xc) {
  const QuantizedVolume& q = bench.q;
  const SimScene& sc = bench.sc;
  const Volume& image = bench.image;
  RegionCheck r;
  const VolumeGeometry& g = q.geometry;
  const Eigen::Matrix4f w2i = g.worldToIndex().cast<float>();
  auto t0 = std::chrono::steady_clock::now();
  const auto cpuPos = interpolateFineReference(bench.data, state, w2i);
  r.cpuInterp = since(t0);
  t0 = std::chrono::steady_clock::now();
  const auto world = bench.model.reconstruct(T, xc);
  r.cpuReconstruct = since(t0);
  t0 = std::chrono::steady_clock::now();
  Volume cpuOut;
  RasterOptions ro;
  ro.maxTetVoxels = defaultMaxTetVoxels(sc.meshes.fine, g.worldToIndex());
  if (!bench.setup.rigidIds.empty()) {
    ro.restMask = &bench.ids;
    ro.rigid = rigidDraws(g, bench.setup.rigidIds, T);
  }
  rasterizeDeformed(image, sc.meshes.fine, world, {sc.lo, sc.hi, image.valueRange().first}, cpuOut, ro);
  r.cpuRaster = since(t0);
  vk::GpuDeformer region(bench.ctx, bench.volume, bench.mask, bench.setup, 1);
  t0 = std::chrono::steady_clock::now();
  const auto rr = region.runFrame(state, vk::Redo::Region);
  r.gpuRegionWall = since(t0);
  r.gpuRegion = passMs(rr.timings, kResamplePasses);
  r.gpuInterp = passMs(rr.timings, {PassId::DeformInterpolate});
  const auto gpuVol = region.readVolume();
  std::size_t within = 0;
  for (std::size_t i = 0; i < gpuVol.size(); ++i) within += std::abs(q.toValue(gpuVol[i] / 65535.0f) - cpuOut.value(i)) <= 1.0f ? 1 : 0;
  r.withinFraction = double(within) / double(gpuVol.size());
  return r;
}

// The dirty-brick image during motion against the exact one (a whole redo at the same state), over
// the region's voxel box, in HU. The stated tolerance: nodes lag by at most tau voxels per axis, so
// the image at v is the exact image at v + d with |d_i| <= tau, and |error| <= 3 tau D(v), where
// D(v) is the largest step between axis neighbours of the exact image in the 3x3x3 voxels around v.
struct LagError {
  double rmsHu = 0, p99Hu = 0, maxHu = 0, withinBound = 1, worstOverBound = 0;
  double worstOverRange = 0;  // error / (largest difference from the voxel to its 26 neighbours + 0.5 HU)
};
LagError lagError(const std::vector<std::uint16_t>& lagging, const std::vector<std::uint16_t>& exact, const QuantizedVolume& q, const Eigen::Vector3i& lo,
                  const Eigen::Vector3i& hi, double tau) {
  const Eigen::Vector3i d = q.geometry.dims;
  auto at = [&](const std::vector<std::uint16_t>& v, int x, int y, int z) {
    return double(q.toValue(v[std::size_t(x) + std::size_t(d.x()) * (std::size_t(y) + std::size_t(d.y()) * std::size_t(z))] / 65535.0f));
  };
  std::vector<double> err;
  std::size_t within = 0;
  LagError r;
  double sq = 0;
  for (int z = lo.z(); z <= hi.z(); ++z)
    for (int y = lo.y(); y <= hi.y(); ++y)
      for (int x = lo.x(); x <= hi.x(); ++x) {
        const double e = std::abs(at(lagging, x, y, z) - at(exact, x, y, z));
        err.push_back(e);
        sq += e * e;
        double step = 0, range = 0;
        if (e > 0)
          for (int dz = -1; dz <= 1; ++dz)
            for (int dy = -1; dy <= 1; ++dy)
              for (int dx = -1; dx <= 1; ++dx) {
                const int a = std::clamp(x + dx, 0, d.x() - 1), b = std::clamp(y + dy, 0, d.y() - 1), c = std::clamp(z + dz, 0, d.z() - 1);
                const double here = at(exact, a, b, c);
                range = std::max(range, std::abs(here - at(exact, x, y, z)));
                if (a + 1 < d.x() && dx < 1) step = std::max(step, std::abs(at(exact, a + 1, b, c) - here));
                if (b + 1 < d.y() && dy < 1) step = std::max(step, std::abs(at(exact, a, b + 1, c) - here));
                if (c + 1 < d.z() && dz < 1) step = std::max(step, std::abs(at(exact, a, b, c + 1) - here));
              }
        const double bound = 3.0 * tau * step + 0.5;  // + half a HU: the 16-bit quantization of both images
        within += e <= bound ? 1 : 0;
        r.worstOverBound = std::max(r.worstOverBound, e / bound);
        r.worstOverRange = std::max(r.worstOverRange, e / (range + 0.5));
      }
  if (err.empty()) return r;
  r.rmsHu = std::sqrt(sq / double(err.size()));
  std::sort(err.begin(), err.end());
  r.p99Hu = err[std::min(err.size() - 1, std::size_t(0.99 * double(err.size())))];
  r.maxHu = err.back();
  r.withinBound = double(within) / double(err.size());
  return r;
}

// deform_frames.png from deform_frames.csv (gnuplot; no chart without it).
void writeDeformChart(const std::filesystem::path& out, bool haveTs) {
  if (std::system("command -v gnuplot > /dev/null 2>&1") == 0) {
    const auto gp = out / "deform_frames.gp";
    const int o = haveTs ? 0 : 1;  // GPU time columns, or the wall-time ones beside them
    std::ofstream(gp) << "set datafile separator ','\nset terminal pngcairo size 900,520 font ',11'\nset output '" << (out / "deform_frames.png").string()
                      << "'\nset termoption noenhanced\nset title 'Kidney drag: resampling the dirty bricks, the moved box, the whole volume'\n"
                      << "set xlabel 'frame'\nset ylabel 'ms per frame (" << (haveTs ? "GPU passes" : "wall") << ")'\nset logscale y\nset grid\nset key top right\n"
                      << "plot '" << (out / "deform_frames.csv").string() << "' every ::1 using 1:" << 9 + o
                      << " with linespoints pt 7 title 'dirty bricks', '' every ::1 using 1:" << 11 + o
                      << " with linespoints pt 9 title 'moved box (previous)', '' every ::1 using 1:" << 13 + o
                      << " with linespoints pt 5 title 'whole volume', '' every ::1 using 1:8 with linespoints pt 3 title 'interpolation'\n";
    if (std::system(("gnuplot " + gp.string() + " 2>/dev/null").c_str()) != 0) std::cerr << "gnuplot failed: no chart\n";
  }
}

// The drag: per frame the coarse solve, then the same state deformed by the three deformers; the
// frame's row of deform_frames.csv, and the series the summary takes its medians from.
struct DragRun {
  std::array<std::vector<double>, 12> series;  // bricks/box/whole GPU ms, bricks/box/whole wall ms, interpolation, solve, brick/box fractions, RMS/p99 HU
  LagError worst;                              // over the frames: largest error, smallest share within the bound
  CoarseFrameState state;                      // the last frame's
  std::vector<RigidTransform> T;
  std::vector<Eigen::Vector3d> xc;
};
DragRun runDrag(const DeformBench& bench, Deformers& d, const DragOptions& o) {
  const SimScene& sc = bench.sc;
  CoarseModel& model = bench.model;
  const QuantizedVolume& q = bench.q;
  const double tau = bench.setup.motionLagVoxels;
  const int frames = o.frames;
  std::ofstream csv(o.out / "deform_frames.csv");
  csv << "frame,coarse_solve_ms,upload_bytes,moved_tets,dirty_bricks,bricks_voxels,box_voxels,interpolate_ms,bricks_resample_ms,bricks_frame_wall_ms,"
         "box_resample_ms,box_frame_wall_ms,whole_resample_ms,whole_frame_wall_ms,rms_hu,p99_hu,max_hu,within_bound\n";
  DragRun r;
  r.xc = model.restState();
  r.worst.withinBound = 1;
  auto& [bricksMs, boxMs, wholeMs, bricksWall, boxWall, wholeWall, interpMs, solveMs, brickFrac, boxFrac, rmsHu, p99Hu] = r.series;
  LagError& worst = r.worst;
  CoarseFrameState& state = r.state;
  std::vector<RigidTransform>& T = r.T;
  auto& xc = r.xc;
  const VolumeGeometry& g = q.geometry;
  auto timed = [&](vk::GpuDeformer& deformer, vk::Redo redo, double& wall) {
    const auto t = std::chrono::steady_clock::now();
    const auto st = deformer.runFrame(state, redo);
    wall = since(t);
    return st;
  };
  for (int f = 1; f <= frames; ++f) {
    T = {RigidTransform::about(sc.handleCentroid[0], Eigen::Vector3d(0, 0, f * o.stepDeg * M_PI / 180), Eigen::Vector3d(f * o.stepMm, 0, 0))};
    const auto t0 = std::chrono::steady_clock::now();
    model.solve(T, xc, 3);
    state = packFrameState(xc, model.elementRotations(xc), T);
    const double tSolve = since(t0);
    double wk = 0, wb = 0, ww = 0;
    const auto k = timed(d.bricks, vk::Redo::BricksDuringMotion, wk);
    const auto b = timed(d.box, vk::Redo::Moved, wb);
    const auto w = timed(d.whole, vk::Redo::WholeVolume, ww);
    const double rk = passMs(k.timings, kResamplePasses), rb = passMs(b.timings, kResamplePasses), rw = passMs(w.timings, kResamplePasses);
    const double ik = passMs(k.timings, {PassId::DeformInterpolate});
    const LagError e = lagError(d.bricks.readVolume(), d.whole.readVolume(), q, bench.rlo, bench.rhi, tau);
    csv << f << "," << tSolve << "," << state.bytes() << "," << b.movedTets << "," << k.dirtyBricks << "," << k.redoneVoxels() << "," << b.boxVoxels() << ","
        << ik << "," << rk << "," << wk << "," << rb << "," << wb << "," << rw << "," << ww << "," << e.rmsHu << "," << e.p99Hu << "," << e.maxHu << ","
        << e.withinBound << "\n";
    if (f > 1) {  // frame 1 starts from rest: not a steady drag frame
      bricksMs.push_back(rk);
      boxMs.push_back(rb);
      wholeMs.push_back(rw);
      bricksWall.push_back(wk);
      boxWall.push_back(wb);
      wholeWall.push_back(ww);
      interpMs.push_back(ik);
      solveMs.push_back(tSolve);
      brickFrac.push_back(double(k.redoneVoxels()) / double(g.voxelCount()));
      boxFrac.push_back(double(b.boxVoxels()) / double(g.voxelCount()));
    }
    rmsHu.push_back(e.rmsHu);
    p99Hu.push_back(e.p99Hu);
    worst.maxHu = std::max(worst.maxHu, e.maxHu);
    worst.withinBound = std::min(worst.withinBound, e.withinBound);
    worst.worstOverBound = std::max(worst.worstOverBound, e.worstOverBound);
    worst.worstOverRange = std::max(worst.worstOverRange, e.worstOverRange);
    if (!o.quiet && f == frames) {
      std::cout << "  passes of the last frame (dirty bricks / moved box / whole volume, ms):";
      for (const PassId n : {PassId::DeformInterpolate, PassId::DeformReset, PassId::DeformBounds, PassId::DeformBricks, PassId::DeformArgs, PassId::DeformClear,
                             PassId::DeformClaim, PassId::DeformResolve})
        std::cout << " " << passName(n) << " " << std::setprecision(2) << passMs(k.timings, {n}) << "/" << passMs(b.timings, {n}) << "/" << passMs(w.timings, {n});
      std::cout << "\n";
    }
    if (!o.quiet)
      std::cout << std::setprecision(2) << "frame " << f << ": " << k.dirtyBricks << (k.allBricks ? " (all)" : "") << " dirty bricks " << (haveTsOf(bench.ctx) ? rk : wk) << " ms, error RMS "
                << e.rmsHu << " HU (p99 " << e.p99Hu << ", max " << e.maxHu << "); moved box " << b.boxVoxels() << " voxels " << (haveTsOf(bench.ctx) ? rb : wb)
                << " ms; whole volume " << (haveTsOf(bench.ctx) ? rw : ww) << " ms\n";
  }
  csv.close();
  return r;
}

// What the drag's end measures: the settled frame against the whole redo, the moved box against
// a whole redo of its own positions, the CPU references; and the drag's medians.
struct DeformBenchResult {
  vk::DeformFrameStats settled;
  double settleMs = 0, settleWall = 0;
  bool identical = false, boxIdentical = false;
  RegionCheck region;
};

DeformBenchResult checkAfterDrag(DeformBench& bench, Deformers& d, const DragRun& run) {
  DeformBenchResult r;
  // Motion stops: one settled frame brings every brick to the exact state, equal to the whole redo.
  const auto t = std::chrono::steady_clock::now();
  r.settled = d.bricks.runFrame(run.state, vk::Redo::Bricks);
  r.settleWall = since(t);
  r.settleMs = passMs(r.settled.timings, kResamplePasses);
  r.identical = d.bricks.readVolume() == d.whole.readVolume() && d.bricks.readMask() == d.whole.readMask();
  // The moved box against a whole redo of the same positions (its own commit threshold).
  const auto v = d.box.readVolume();
  const auto m = d.box.readMask();
  d.box.runFrame(run.state, vk::Redo::WholeVolume);
  r.boxIdentical = v == d.box.readVolume() && m == d.box.readMask();
  // CPU references on the last frame: interpolation and the region's rasterization.
  r.region = checkRegionAgainstCpu(bench, run.state, run.T, run.xc);
  return r;
}

void writeDeformSummary(const DeformBench& bench, const DragRun& run, const DeformBenchResult& r, const std::filesystem::path& out) {
  const auto& [bricksMs, boxMs, wholeMs, bricksWall, boxWall, wholeWall, interpMs, solveMs, brickFrac, boxFrac, rmsHu, p99Hu] = run.series;
  const double km = median(bricksMs), bm = median(boxMs), wm = median(wholeMs), kw = median(bricksWall), bw = median(boxWall), ww = median(wholeWall);
  const SimScene& sc = bench.sc;
  const RegionCheck& rc = r.region;
  const LagError& worst = run.worst;
  std::ofstream sum(out / "deform_summary.csv");
  sum << "quantity,value\n"
      << "voxels," << bench.q.geometry.voxelCount() << "\nfine_tets," << sc.meshes.fine.tets.size() << "\nfine_nodes," << sc.meshes.fine.nodes.size()
      << "\nupload_bytes_per_frame," << run.state.bytes() << "\nlag_voxels," << bench.setup.motionLagVoxels << "\nmedian_bricks_fraction," << median(brickFrac)
      << "\nmedian_box_fraction," << median(boxFrac) << "\nmedian_dirty_resample_ms," << km << "\nmedian_box_resample_ms," << bm
      << "\nmedian_whole_resample_ms," << wm << "\nwhole_over_dirty_gpu," << (km > 0 ? wm / km : 0) << "\nwhole_over_box_gpu," << (bm > 0 ? wm / bm : 0)
      << "\nmedian_dirty_frame_wall_ms," << kw << "\nmedian_box_frame_wall_ms," << bw << "\nmedian_whole_frame_wall_ms," << ww
      << "\nwhole_over_dirty_wall," << ww / kw << "\nwhole_over_box_wall," << ww / bw << "\nmotion_error_median_rms_hu," << median(rmsHu)
      << "\nmotion_error_median_p99_hu," << median(p99Hu) << "\nmotion_error_max_hu," << worst.maxHu << "\nmotion_error_within_bound," << worst.withinBound
      << "\nmotion_error_worst_over_bound," << worst.worstOverBound << "\nmotion_error_worst_over_neighbourhood_range," << worst.worstOverRange
      << "\nsettle_resample_ms," << (haveTsOf(bench.ctx) ? r.settleMs : r.settleWall) << "\nsettle_dirty_bricks," << r.settled.dirtyBricks
      << "\ngpu_interpolate_ms," << rc.gpuInterp << "\ncpu_interpolate_reference_ms," << rc.cpuInterp << "\ncpu_reconstruct_double_ms," << rc.cpuReconstruct
      << "\ngpu_region_resample_ms," << rc.gpuRegion << "\ngpu_region_frame_wall_ms," << rc.gpuRegionWall << "\ncpu_region_resample_ms," << rc.cpuRaster
      << "\nmedian_coarse_solve_ms," << median(solveMs) << "\nmedian_interpolate_ms," << median(interpMs) << "\ngpu_cpu_within_1hu," << rc.withinFraction
      << "\nsettled_equals_whole," << (r.identical ? 1 : 0) << "\nbox_equals_whole," << (r.boxIdentical ? 1 : 0) << "\n";
}

void printDeformSummary(const DeformBench& bench, const DragRun& run, const DeformBenchResult& r, int frames) {
  const auto& [bricksMs, boxMs, wholeMs, bricksWall, boxWall, wholeWall, interpMs, solveMs, brickFrac, boxFrac, rmsHu, p99Hu] = run.series;
  const double km = median(bricksMs), bm = median(boxMs), wm = median(wholeMs), kw = median(bricksWall), bw = median(boxWall), ww = median(wholeWall);
  const bool haveTs = haveTsOf(bench.ctx);
  const RegionCheck& rc = r.region;
  const LagError& worst = run.worst;
  const double tau = bench.setup.motionLagVoxels;
  std::cout << std::setprecision(2) << "\nkidney drag, frames 2.." << frames << " (medians; " << (haveTs ? "GPU timestamps" : "wall") << "):\n"
            << "  resampling: dirty bricks " << (haveTs ? km : kw) << " ms (" << std::setprecision(1) << 100 * median(brickFrac) << " % of the volume), moved box "
            << std::setprecision(2) << (haveTs ? bm : bw) << " ms (" << std::setprecision(1) << 100 * median(boxFrac) << " %), whole volume "
            << std::setprecision(2) << (haveTs ? wm : ww) << " ms: whole / dirty bricks " << (haveTs ? wm / km : ww / kw) << "x, whole / moved box "
            << (haveTs ? wm / bm : ww / bw) << "x\n  during motion (lag <= " << tau << " voxel per axis) against the whole redo: RMS " << median(rmsHu)
            << " HU, p99 " << median(p99Hu) << " HU (medians over frames), max " << worst.maxHu << " HU; within 3 x lag x the local voxel step on "
            << std::setprecision(4) << 100 * worst.withinBound << " % of region voxels (worst frame; worst error / bound "
            << std::setprecision(2) << worst.worstOverBound << ", / the range of its 26 neighbours " << worst.worstOverRange << ")\n"
            << std::setprecision(2) << "  settled frame: " << r.settled.dirtyBricks << " bricks, " << (haveTs ? r.settleMs : r.settleWall)
            << " ms; equals the whole redo: " << (r.identical ? "yes" : "NO") << "; the moved box equals a whole redo at its own threshold: "
            << (r.boxIdentical ? "yes" : "NO") << "\n  frame wall time (interpolation + resampling, submitted and waited for): dirty bricks " << kw
            << " ms, moved box " << bw << " ms, whole volume " << ww << " ms\n  interpolation of " << bench.sc.meshes.fine.nodes.size() << " fine nodes: GPU "
            << rc.gpuInterp << " ms, CPU float reference " << rc.cpuInterp << " ms, CoarseModel::reconstruct " << rc.cpuReconstruct
            << " ms\n  resampling the region: GPU " << rc.gpuRegion << " ms (" << rc.gpuRegionWall << " ms wall), CPU reference " << rc.cpuRaster
            << " ms: " << rc.cpuRaster / (haveTs ? rc.gpuRegion : rc.gpuRegionWall) << "x; within 1 HU on " << std::setprecision(4)
            << 100.0 * rc.withinFraction << " % of voxels\n"
            << std::setprecision(2) << "  whole deformation frame: coarse solve " << median(solveMs) << " ms (CPU, worker thread) + " << run.state.bytes() / 1024.0
            << " KB upload + GPU " << kw << " ms\n";
}

// The scene's settings from the command line.
SimSettings deformBenchSettings(const Args& args) {
  SimSettings s;
  s.coarseTets = int(args.integer("--coarse-tets", 6000, 6, 2000000));
  s.fineTets = int(args.integer("--fine-tets", 300000, 6, 20000000));
  if (s.fineTets < s.coarseTets) throw UsageError("--fine-tets must be at least --coarse-tets");
  s.paddingMm = args.number("--padding-mm", 40.0, 0.0, 1e4);
  regionOption(args, "--region", s);
  s.element = coarseElementOption(args, "--coarse-element");
  return s;
}

}  // namespace

int cmdBenchDeform(const Words& words) {
  Args args(words,
            {"--handle", "--handle-label", "--spacing", "--coarse-tets", "--fine-tets", "--padding-mm", "--region", "--frames", "--step-mm", "--step-deg", "--device",
             "--out", "--commit-voxels", "--lag-voxels", "--coarse-element"},
            {"--quiet", "--validation"});
  if (args.help() || args.positional().size() > 1 || (args.positional().size() == 1) != bool(args.value("--handle"))) {
    usageStream(args) << kBenchDeformHelp;
    return args.help() ? 0 : 2;
  }
  DragOptions o;
  o.quiet = args.flag("--quiet");
  const ProgressFn progress = o.quiet ? ProgressFn{} : consoleProgress();
  const SimSettings s = deformBenchSettings(args);
  o.frames = int(args.integer("--frames", 10, 1, 10000));
  o.stepMm = args.number("--step-mm", 1.0, -100.0, 100.0);
  o.stepDeg = args.number("--step-deg", 1.0, -90.0, 90.0);
  o.out = args.valueOr("--out", "bench-out");
  std::filesystem::create_directories(o.out);

  HandleScene loaded = handleSceneOptions(args, 1.75, progress);
  const Volume image = std::move(loaded.image);
  const SimHandle handle{std::move(loaded.handle), {}};
  auto t0 = std::chrono::steady_clock::now();
  const SimScene sc = buildSimScene(image, {handle}, s, progress);
  CoarseModel model(sc.meshes, sc.fineK, sc.constraints, progress, s.element);
  const double tPre = since(t0);
  const FineInterpolationData data = model.interpolationData();
  const QuantizedVolume q = quantizeVolume(image);
  const VolumeGeometry& g = q.geometry;

  vk::ContextOptions co;
  co.device = args.valueOr("--device", "");
  co.validation = args.flag("--validation");
  co.verbose = !o.quiet;
  const vk::Context ctx(co);
  const fg::ImageDesc desc{std::uint32_t(g.dims.x()), std::uint32_t(g.dims.y()), std::uint32_t(g.dims.z()), fg::Format::R16Unorm};
  const VkImageUsageFlags usage = VK_IMAGE_USAGE_SAMPLED_BIT | VK_IMAGE_USAGE_TRANSFER_DST_BIT | VK_IMAGE_USAGE_TRANSFER_SRC_BIT;
  vk::Image volume(ctx, desc, usage, true), mask(ctx, {desc.width, desc.height, desc.depth, fg::Format::R8Unorm}, usage, true);
  vk::uploadToImage(ctx, volume, q.data.data(), q.data.size() * 2, VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL);
  std::vector<std::uint8_t> ids(q.data.size(), 0);
  for (auto v : handle.voxels) ids[v] = 1;
  vk::uploadToImage(ctx, mask, ids.data(), ids.size(), VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL);
  DeformBench bench{ctx, image, q, sc, model, data, ids, volume, mask, {}, {}, {}};
  vk::DeformSetup& setup = bench.setup;
  setup.interpolation = &data;
  setup.fineTets = &sc.meshes.fine.tets;
  setup.regionLo = sc.lo;
  setup.regionHi = sc.hi;
  setup.background = q.toNormalized(image.valueRange().first);
  setup.worldToIndex = g.worldToIndex();
  setup.commitVoxels = args.number("--commit-voxels", 1e-3, 0.0, 10.0);
  setup.motionLagVoxels = args.number("--lag-voxels", 0.5, 0.0, 4.0);
  if (!sc.constraints.slide.empty()) {  // a sliding handle drawn where its pose puts it, as in the app
    setup.rigidIds = {1};
    setup.rigidRestBoxes = {voxelIndexBox(g, handle.voxels)};
  }
  vk::DeformSetup exactSetup = setup;
  exactSetup.commitVoxels = 0.0;  // the whole redo takes every node that moved at all: the exact state
  vk::GpuDeformer bricks(ctx, volume, mask, setup, 1), box(ctx, volume, mask, setup, 1), whole(ctx, volume, mask, exactSetup, 1);
  regionVoxelBox(g, sc.lo, sc.hi, bench.rlo, bench.rhi);
  const std::uint64_t regionBox = std::uint64_t((bench.rhi - bench.rlo + Eigen::Vector3i::Ones()).prod());
  std::cout << std::fixed << std::setprecision(1) << "volume " << g.dims.x() << "x" << g.dims.y() << "x" << g.dims.z() << " (" << g.voxelCount() / 1e6
            << " M voxels); region " << regionBox << " voxels; coarse " << sc.meshes.coarse.tets.size() << ", fine " << sc.meshes.fine.tets.size()
            << " tets, " << sc.meshes.fine.nodes.size() << " fine nodes; preprocessing " << tPre / 1e3 << " s; device " << ctx.properties().deviceName
            << (ctx.timestampPeriodNs() > 0 ? "" : " (no timestamps: wall times only)") << "\n";

  Deformers d{bricks, box, whole};
  const DragRun run = runDrag(bench, d, o);
  const DeformBenchResult r = checkAfterDrag(bench, d, run);
  if (ctx.validationMessageCount()) throw Error("Vulkan validation messages were reported");
  writeDeformSummary(bench, run, r, o.out);
  printDeformSummary(bench, run, r, o.frames);
  writeDeformChart(o.out, haveTsOf(ctx));
  std::cout << "wrote " << (o.out / "deform_frames.csv").string() << ", " << (o.out / "deform_summary.csv").string() << " and deform_frames.png\n";
  return r.identical && r.boxIdentical ? 0 : 1;
}

}  // namespace handson::cli
