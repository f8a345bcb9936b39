// `handson bench deform`: the GPU deformation passes on a kidney drag: moved-box resampling against
// whole-volume resampling (same run, same frames, same device), the GPU passes against their CPU
// references, the interpolation pass, and the whole deformation frame, with a CSV and a chart.
#include <Eigen/Geometry>
#include <algorithm>
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
#include "sim/error.h"
#include "sim/fine_interpolation.h"
#include "sim/quantized_volume.h"
#include "sim/sim_scene.h"
#include "sim/tet_raster.h"

namespace handson::cli {

namespace {
const char* const kBenchDeformHelp =
    "usage: handson bench deform [PATH --handle MASK [--handle-label N]] [options]\n"
    "  A kidney drag (the handle moved --step-mm along x and turned --step-deg about z each frame, the\n"
    "  coarse model solved 3 iterations a frame) deformed on the GPU two ways in the same run: redoing\n"
    "  only the box of tissue that moved since the last frame, and redoing the whole volume (the\n"
    "  baseline). Also: the GPU passes against their CPU references (interpolation; resampling of the\n"
    "  region) and the whole deformation frame. PATH omitted: the built-in phantom (right kidney).\n"
    "  --spacing MM           phantom voxel size (default 1.75: 219x165x137 = 4.95 M voxels)\n"
    "  --coarse-tets N        (default 6000)   --fine-tets N (default 300000)   --padding-mm D (default 40)   --region box|handles\n"
    "  --coarse-element cell|tet   the coarse model's elements (default cell)\n"
    "  --frames N             drag frames (default 10)   --step-mm D (default 1)   --step-deg A (default 1)\n"
    "  --commit-voxels V      a fine node's new position is taken once it moved more than V voxels\n"
    "                         (default 0.001: the image lags the simulation by at most that)\n"
    "  --device NAME          Vulkan device (default: automatic)   --validation\n"
    "  --out DIR              deform_frames.csv, deform_summary.csv and deform_frames.png (default bench-out)\n"
    "  --quiet\n";

double since(std::chrono::steady_clock::time_point t0) { return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count(); }

double median(std::vector<double> v) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

// GPU time of the passes whose names start with one of the prefixes (0 without timestamps).
// The resampling passes (the interpolation is timed on its own).
const std::initializer_list<const char*> kResamplePasses = {"deform-reset", "deform-bounds", "deform-args", "deform-clear", "deform-claim", "deform-resolve"};

double passMs(const std::vector<vk::PassTiming>& t, std::initializer_list<const char*> names) {
  double ms = 0;
  for (const auto& p : t)
    for (const char* n : names)
      if (p.name == n) ms += p.gpuMs;
  return ms;
}

// The last frame's region resampled on the GPU from scratch and on the CPU (the reference), and
// the fine nodes interpolated by the CPU float reference and by CoarseModel::reconstruct: times and
// the fraction of voxels within 1 HU.
struct RegionCheck {
  double cpuInterp = 0, cpuReconstruct = 0, cpuRaster = 0, gpuRegionWall = 0, gpuRegion = 0, gpuInterp = 0, withinFraction = 0;
};
RegionCheck checkRegionAgainstCpu(const vk::Context& ctx, vk::Image& volume, vk::Image& mask, const vk::DeformSetup& setup, const Volume& image,
                                  const QuantizedVolume& q, const SimScene& sc, const CoarseModel& model, const FineInterpolationData& data,
                                  const CoarseFrameState& state, const std::vector<RigidTransform>& T, const std::vector<Eigen::Vector3d>& xc) {
  RegionCheck r;
  const VolumeGeometry& g = q.geometry;
  const Eigen::Matrix4f w2i = g.worldToIndex().cast<float>();
  auto t0 = std::chrono::steady_clock::now();
  const auto cpuPos = interpolateFineReference(data, state, w2i);
  r.cpuInterp = since(t0);
  t0 = std::chrono::steady_clock::now();
  const auto world = model.reconstruct(T, xc);
  r.cpuReconstruct = since(t0);
  t0 = std::chrono::steady_clock::now();
  Volume cpuOut;
  rasterizeDeformed(image, sc.meshes.fine, world, sc.lo, sc.hi, image.valueRange().first, cpuOut, nullptr, nullptr,
                    defaultMaxTetVoxels(sc.meshes.fine, g.worldToIndex()));
  r.cpuRaster = since(t0);
  vk::GpuDeformer region(ctx, volume, mask, setup, 1);
  t0 = std::chrono::steady_clock::now();
  const auto rr = region.runFrame(state, vk::Redo::Region);
  r.gpuRegionWall = since(t0);
  r.gpuRegion = passMs(rr.timings, kResamplePasses);
  r.gpuInterp = passMs(rr.timings, {"deform-interpolate"});
  const auto gpuVol = region.readVolume();
  std::size_t within = 0;
  for (std::size_t i = 0; i < gpuVol.size(); ++i) within += std::abs(q.toValue(gpuVol[i] / 65535.0f) - cpuOut.value(i)) <= 1.0f ? 1 : 0;
  r.withinFraction = double(within) / double(gpuVol.size());
  return r;
}

// deform_frames.png from deform_frames.csv (gnuplot; no chart without it).
void writeDeformChart(const std::filesystem::path& out, bool haveTs) {
  if (std::system("command -v gnuplot > /dev/null 2>&1") == 0) {
    const auto gp = out / "deform_frames.gp";
    std::ofstream(gp) << "set datafile separator ','\nset terminal pngcairo size 900,520 font ',11'\nset output '" << (out / "deform_frames.png").string()
                      << "'\nset termoption noenhanced\nset title 'Kidney drag: resampling only the moved box vs the whole volume'\n"
                      << "set xlabel 'frame'\nset ylabel 'ms per frame (" << (haveTs ? "GPU passes" : "wall") << ")'\nset logscale y\nset grid\nset key top right\n"
                      << "plot '" << (out / "deform_frames.csv").string() << "' every ::1 using 1:" << (haveTs ? 7 : 8)
                      << " with linespoints pt 7 title 'moved box', '' every ::1 using 1:" << (haveTs ? 9 : 10)
                      << " with linespoints pt 5 title 'whole volume', '' every ::1 using 1:6 with linespoints pt 9 title 'interpolation'\n";
    if (std::system(("gnuplot " + gp.string() + " 2>/dev/null").c_str()) != 0) std::cerr << "gnuplot failed: no chart\n";
  }
}

}  // namespace

int cmdBenchDeform(const Words& words) {
  Args args(words,
            {"--handle", "--handle-label", "--spacing", "--coarse-tets", "--fine-tets", "--padding-mm", "--region", "--frames", "--step-mm", "--step-deg", "--device",
             "--out", "--commit-voxels", "--coarse-element"},
            {"--quiet", "--validation"});
  if (args.help() || args.positional().size() > 1 || (args.positional().size() == 1) != bool(args.value("--handle"))) {
    usageStream(args) << kBenchDeformHelp;
    return args.help() ? 0 : 2;
  }
  const bool quiet = args.flag("--quiet");
  const ProgressFn progress = quiet ? ProgressFn{} : consoleProgress();
  SimSettings s;
  s.coarseTets = int(args.integer("--coarse-tets", 6000, 6, 2000000));
  s.fineTets = int(args.integer("--fine-tets", 300000, 6, 20000000));
  if (s.fineTets < s.coarseTets) throw UsageError("--fine-tets must be at least --coarse-tets");
  s.paddingMm = args.number("--padding-mm", 40.0, 0.0, 1e4);
  regionOption(args, "--region", s);
  s.element = coarseElementOption(args, "--coarse-element");
  const int frames = int(args.integer("--frames", 10, 1, 10000));
  const double stepMm = args.number("--step-mm", 1.0, -100.0, 100.0);
  const double stepDeg = args.number("--step-deg", 1.0, -90.0, 90.0);
  const std::filesystem::path out = args.valueOr("--out", "bench-out");
  std::filesystem::create_directories(out);

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
  co.verbose = !quiet;
  const vk::Context ctx(co);
  const fg::ImageDesc desc{std::uint32_t(g.dims.x()), std::uint32_t(g.dims.y()), std::uint32_t(g.dims.z()), fg::Format::R16Unorm};
  const VkImageUsageFlags usage = VK_IMAGE_USAGE_SAMPLED_BIT | VK_IMAGE_USAGE_TRANSFER_DST_BIT | VK_IMAGE_USAGE_TRANSFER_SRC_BIT;
  vk::Image volume(ctx, desc, usage, true), mask(ctx, {desc.width, desc.height, desc.depth, fg::Format::R8Unorm}, usage, true);
  vk::uploadToImage(ctx, volume, q.data.data(), q.data.size() * 2, VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL);
  std::vector<std::uint8_t> ids(q.data.size(), 0);
  for (auto v : handle.voxels) ids[v] = 1;
  vk::uploadToImage(ctx, mask, ids.data(), ids.size(), VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL);
  vk::DeformSetup setup;
  setup.interpolation = &data;
  setup.fineTets = &sc.meshes.fine.tets;
  setup.regionLo = sc.lo;
  setup.regionHi = sc.hi;
  setup.background = q.toNormalized(image.valueRange().first);
  setup.worldToIndex = g.worldToIndex();
  setup.commitVoxels = args.number("--commit-voxels", 1e-3, 0.0, 10.0);
  vk::GpuDeformer dirty(ctx, volume, mask, setup, 1), whole(ctx, volume, mask, setup, 1);
  Eigen::Vector3i rlo, rhi;
  regionVoxelBox(g, sc.lo, sc.hi, rlo, rhi);
  const std::uint64_t regionBox = std::uint64_t((rhi - rlo + Eigen::Vector3i::Ones()).prod());
  std::cout << std::fixed << std::setprecision(1) << "volume " << g.dims.x() << "x" << g.dims.y() << "x" << g.dims.z() << " (" << g.voxelCount() / 1e6
            << " M voxels); region " << regionBox << " voxels; coarse " << sc.meshes.coarse.tets.size() << ", fine " << sc.meshes.fine.tets.size()
            << " tets, " << sc.meshes.fine.nodes.size() << " fine nodes; preprocessing " << tPre / 1e3 << " s; device " << ctx.properties().deviceName
            << (ctx.timestampPeriodNs() > 0 ? "" : " (no timestamps: wall times only)") << "\n";

  std::ofstream csv(out / "deform_frames.csv");
  csv << "frame,coarse_solve_ms,upload_bytes,moved_tets,box_voxels,dirty_interpolate_ms,dirty_resample_ms,dirty_frame_wall_ms,whole_resample_ms,whole_frame_wall_ms\n";
  auto xc = model.restState();
  std::vector<double> dirtyMs, wholeMs, dirtyWall, wholeWall, interpMs, solveMs, boxFrac;
  CoarseFrameState state;
  std::vector<RigidTransform> T;
  for (int f = 1; f <= frames; ++f) {
    T = {RigidTransform::about(sc.handleCentroid[0], Eigen::Vector3d(0, 0, f * stepDeg * M_PI / 180), Eigen::Vector3d(f * stepMm, 0, 0))};
    t0 = std::chrono::steady_clock::now();
    model.solve(T, xc, 3);
    state = packFrameState(xc, model.elementRotations(xc), T);
    const double tSolve = since(t0);
    t0 = std::chrono::steady_clock::now();
    const auto a = dirty.runFrame(state, vk::Redo::Moved);
    const double wa = since(t0);
    t0 = std::chrono::steady_clock::now();
    const auto b = whole.runFrame(state, vk::Redo::WholeVolume);
    const double wb = since(t0);
    const double ra = passMs(a.timings, kResamplePasses), rb = passMs(b.timings, kResamplePasses), ia = passMs(a.timings, {"deform-interpolate"});
    csv << f << "," << tSolve << "," << state.bytes() << "," << a.movedTets << "," << a.boxVoxels() << "," << ia << "," << ra << "," << wa << "," << rb
        << "," << wb << "\n";
    if (f > 1) {  // frame 1 starts from rest: not a steady drag frame
      dirtyMs.push_back(ra);
      wholeMs.push_back(rb);
      dirtyWall.push_back(wa);
      wholeWall.push_back(wb);
      interpMs.push_back(ia);
      solveMs.push_back(tSolve);
      boxFrac.push_back(double(a.boxVoxels()) / double(g.voxelCount()));
    }
    if (!quiet && f == frames) {
      std::cout << "  passes of the last frame (moved box / whole volume, ms):";
      for (const char* n : {"deform-interpolate", "deform-reset", "deform-bounds", "deform-args", "deform-clear", "deform-claim", "deform-resolve"})
        std::cout << " " << n << " " << std::setprecision(2) << passMs(a.timings, {n}) << "/" << passMs(b.timings, {n});
      std::cout << "\n";
    }
    if (!quiet)
      std::cout << std::setprecision(2) << "frame " << f << ": moved " << a.movedTets << " tets, box " << a.boxVoxels() << " voxels; resampling moved box "
                << ra << " ms GPU (" << wa << " ms wall), whole volume " << rb << " ms GPU (" << wb << " ms wall)\n";
  }
  csv.close();
  const bool identical = dirty.readVolume() == whole.readVolume() && dirty.readMask() == whole.readMask();

  // CPU references on the last frame: interpolation and the region's rasterization.
  const RegionCheck rc = checkRegionAgainstCpu(ctx, volume, mask, setup, image, q, sc, model, data, state, T, xc);
  const double cpuInterp = rc.cpuInterp, cpuReconstruct = rc.cpuReconstruct, cpuRaster = rc.cpuRaster, gpuRegionWall = rc.gpuRegionWall,
               gpuRegion = rc.gpuRegion, gpuInterp = rc.gpuInterp;
  if (ctx.validationMessageCount()) throw Error("Vulkan validation messages were reported");

  const double dm = median(dirtyMs), wm = median(wholeMs), dw = median(dirtyWall), ww = median(wholeWall);
  const bool haveTs = ctx.timestampPeriodNs() > 0;
  std::ofstream sum(out / "deform_summary.csv");
  sum << "quantity,value\n"
      << "voxels," << g.voxelCount() << "\nfine_tets," << sc.meshes.fine.tets.size() << "\nfine_nodes," << sc.meshes.fine.nodes.size()
      << "\nupload_bytes_per_frame," << state.bytes() << "\nmedian_box_fraction," << median(boxFrac) << "\nmedian_dirty_resample_ms," << dm
      << "\nmedian_whole_resample_ms," << wm << "\nwhole_over_dirty_gpu," << (dm > 0 ? wm / dm : 0) << "\nmedian_dirty_frame_wall_ms," << dw
      << "\nmedian_whole_frame_wall_ms," << ww << "\nwhole_over_dirty_wall," << ww / dw << "\ngpu_interpolate_ms," << gpuInterp
      << "\ncpu_interpolate_reference_ms," << cpuInterp << "\ncpu_reconstruct_double_ms," << cpuReconstruct << "\ngpu_region_resample_ms," << gpuRegion
      << "\ngpu_region_frame_wall_ms," << gpuRegionWall << "\ncpu_region_resample_ms," << cpuRaster << "\nmedian_coarse_solve_ms," << median(solveMs)
      << "\nmedian_interpolate_ms," << median(interpMs) << "\ngpu_cpu_within_1hu," << rc.withinFraction
      << "\ndirty_equals_whole," << (identical ? 1 : 0) << "\n";
  sum.close();
  std::cout << std::setprecision(2) << "\nkidney drag, frames 2.." << frames << " (medians; " << (haveTs ? "GPU timestamps" : "wall") << "):\n"
            << "  resampling: moved box " << (haveTs ? dm : dw) << " ms (" << std::setprecision(1) << 100 * median(boxFrac) << " % of the volume), whole volume "
            << std::setprecision(2) << (haveTs ? wm : ww) << " ms: " << (haveTs ? wm / dm : ww / dw) << "x; results identical: " << (identical ? "yes" : "NO")
            << "\n  frame wall time (interpolation + resampling, submitted and waited for): moved box " << dw << " ms, whole volume " << ww << " ms: " << ww / dw
            << "x\n  interpolation of " << sc.meshes.fine.nodes.size() << " fine nodes: GPU " << gpuInterp << " ms, CPU float reference " << cpuInterp
            << " ms, CoarseModel::reconstruct " << cpuReconstruct << " ms\n  resampling the region: GPU " << gpuRegion << " ms (" << gpuRegionWall
            << " ms wall), CPU reference " << cpuRaster << " ms: " << cpuRaster / (haveTs ? gpuRegion : gpuRegionWall) << "x; within 1 HU on "
            << std::setprecision(4) << 100.0 * rc.withinFraction << " % of voxels\n"
            << std::setprecision(2) << "  whole deformation frame: coarse solve " << median(solveMs) << " ms (CPU, worker thread) + " << state.bytes() / 1024.0
            << " KB upload + GPU " << dw << " ms\n";
  writeDeformChart(out, haveTs);
  std::cout << "wrote " << (out / "deform_frames.csv").string() << ", " << (out / "deform_summary.csv").string() << " and deform_frames.png\n";
  return identical ? 0 : 1;
}

}  // namespace handson::cli
