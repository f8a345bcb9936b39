// `handson select`: seeded region growing from the command line, on the CPU reference or the GPU pass.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <iomanip>
#include <iostream>
#include <sstream>

#include "app/cli/args.h"
#include "app/cli/commands.h"
#include "app/io/nifti_io.h"
#include "app/io/volume_io.h"
#include "app/session/console.h"
#include "interaction/label_map.h"
#include "interaction/region_grow.h"
#include "render/region_grow_pass.h"
#include "render/vk_context.h"
#include "render/vk_resources.h"
#include "sim/base/error.h"
#include "sim/quantized_volume.h"

namespace handson::cli {

namespace {
const char* const kSelectHelp =
    "usage: handson select PATH (--seed-voxel I,J,K | --seed-mm X,Y,Z) --extent-mm D -o MASK.nii.gz [options]\n"
    "       handson select PATH --labels LABELS (--seed-voxel I,J,K | --seed-mm X,Y,Z) -o MASK.nii.gz\n"
    "  Seeded region growing, or with --labels the labelled organ under the seed (the 26-connected\n"
    "  component of its label, exactly); writes a uint8 mask (1 = selected) on the input's exact grid\n"
    "  and geometry (NIfTI, or NRRD when -o ends in .nrrd)\n"
    "  and prints the voxel count and the time. --seed-voxel is a 0-based index in the file's own index\n"
    "  order; --seed-mm a RAS+ point in mm (the nearest voxel is used).\n"
    "  --extent-mm D          selection extent (radius about the seed)\n"
    "  --frame N              the volume of a 4D NIfTI image to load (default 0)\n"
    "  --hmax H               homogeneity threshold in seed standard deviations (default 1.1)\n"
    "  --criterion NAME       core (default: 3x3x3 means, statistics refined from the region,\n"
    "                         growth passing only through the organ's core so thin bridges to a neighbour\n"
    "                         are cut; a seed in a structure too thin for a core grows smoothed), smoothed\n"
    "                         (the same without the core) or paper (the paper's rule: raw values,\n"
    "                         breadth-first passes)\n"
    "  --statistics NAME      how core and smoothed refine their statistics from the region near the seed:\n"
    "                         robust (default: its median and median absolute deviation, so a minority of\n"
    "                         other tissue there does not widen the tolerance) or moments (mean and\n"
    "                         standard deviation, the earlier rule)\n"
    "  --bound path|ball      how the extent bounds core and smoothed growth: path (default: the region\n"
    "                         reached by paths through it no longer than D, so a neighbour joined by a\n"
    "                         detour through a neck or a vein waits) or ball (the earlier rule: the region\n"
    "                         joined to the seed inside the ball of radius D)\n"
    "  --backend cpu|gpu      CPU reference (default) or the Vulkan compute pass\n"
    "  --rim on|off           end with the selection's partial-volume boundary rim: the surface voxels\n"
    "                         nearer the selection's value than the tissue beyond (default on)\n"
    "  --labels LABELS        a label map (any volume format; 0 = background): select the seed's organ\n"
    "                         instead of growing. On another grid of the same space it is resampled by\n"
    "                         nearest neighbour (with a warning); growth options do not apply\n"
    "  --device NAME, --validation, --quiet\n";

/// The seed voxel of --seed-voxel or --seed-mm, inside the grid. Throws UsageError or Error.
Eigen::Vector3i seedVoxel(const Args& args, const VolumeGeometry& g) {
  Eigen::Vector3i seed;
  if (auto s = args.value("--seed-voxel")) {
    const auto n = parseNumberList(*s, "--seed-voxel");
    if (n.size() != 3 || n[0] != std::floor(n[0]) || n[1] != std::floor(n[1]) || n[2] != std::floor(n[2]))
      throw UsageError("--seed-voxel takes three integers I,J,K");
    seed = Eigen::Vector3i(int(std::clamp(n[0], -1e9, 1e9)), int(std::clamp(n[1], -1e9, 1e9)), int(std::clamp(n[2], -1e9, 1e9)));
  } else {
    const auto n = parseNumberList(*args.value("--seed-mm"), "--seed-mm");
    if (n.size() != 3) throw UsageError("--seed-mm takes three numbers X,Y,Z");
    const Eigen::Vector3d idx = g.toIndex(Eigen::Vector3d(n[0], n[1], n[2])).array().round();
    if (!idx.allFinite() || (idx.array().abs() > 1e9).any()) throw Error("the seed point lies outside the volume");
    seed = idx.cast<int>();
  }
  if (!g.contains(seed)) {
    std::ostringstream msg;
    msg << "the seed voxel (" << seed.x() << ", " << seed.y() << ", " << seed.z() << ") lies outside the volume (" << g.dims.x() << "x"
        << g.dims.y() << "x" << g.dims.z() << ")";
    throw Error(msg.str());
  }
  return seed;
}

void writeMask(const VolumeGeometry& g, const std::vector<std::uint8_t>& mask, const std::string& path) {
  Volume out(g, ScalarType::UInt8);
  std::copy(mask.begin(), mask.end(), out.data<std::uint8_t>());
  writeVolume(out, path);
}

/// `select --labels`: the labelled component under the seed, exactly.
int selectLabelled(const Args& args, const Volume& v, const Eigen::Vector3i& seed) {
  const auto t0 = std::chrono::steady_clock::now();
  const LabelMap labels = loadLabelMap(*args.value("--labels"), v.geometry());
  const std::uint16_t label = labels.at(seed);
  const auto voxels = labelComponent(labels, seed);
  const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  std::vector<std::uint8_t> mask(v.voxelCount(), 0);
  for (std::uint32_t i : voxels) mask[i] = 1;
  writeMask(v.geometry(), mask, *args.value("-o"));
  const std::size_t all = std::size_t(std::count(labels.labels.begin(), labels.labels.end(), label));
  std::cout << std::fixed << std::setprecision(1) << "selected " << voxels.size() << " voxels (" << double(voxels.size()) * v.geometry().spacing.prod() / 1000.0
            << " ml): label " << label << "'s connected component at seed (" << seed.x() << ", " << seed.y() << ", " << seed.z() << "), "
            << 100.0 * double(voxels.size()) / double(all) << " % of that label's voxels, in " << ms << " ms\n"
            << "wrote " << *args.value("-o") << "\n";
  return 0;
}

}  // namespace

namespace {

// The region-growing parameters from the command line.
GrowParams growParams(const Args& args) {
  GrowParams p;
  p.hMax = args.number("--hmax", 1.1, 1e-3, 1e3);
  if (!parseGrowCriterion(args.valueOr("--criterion", "core"), p.criterion)) throw UsageError("--criterion must be core, smoothed or paper");
  if (!parseRegionStatistics(args.valueOr("--statistics", "robust"), p.statistics)) throw UsageError("--statistics must be robust or moments");
  if (!parseGrowBound(args.valueOr("--bound", growBoundName(p.bound)), p.bound)) throw UsageError("--bound must be ball or path");
  p.boundaryRim = onOffOption(args, "--rim", true);
  return p;
}

// A selection grown to an extent: its mask on the volume's grid and its voxel count.
struct Grown {
  std::vector<std::uint8_t> mask;
  std::size_t count = 0;
  double gpuRounds = 0;
};

// The selection grown on the GPU passes (their keys read back and bounded as the CPU's).
Grown growOnGpu(const Args& args, const QuantizedVolume& q, const RegionGrower& grower, const Eigen::Vector3i& seed, double extent) {
  const VolumeGeometry& g = q.geometry;
  vk::ContextOptions co;
  co.device = args.valueOr("--device", "");
  co.validation = args.flag("--validation");
  co.verbose = !args.flag("--quiet");
  vk::Context ctx(co);
  vk::Image volume(ctx, {std::uint32_t(g.dims.x()), std::uint32_t(g.dims.y()), std::uint32_t(g.dims.z()), fg::Format::R16Unorm},
                   VK_IMAGE_USAGE_SAMPLED_BIT | VK_IMAGE_USAGE_TRANSFER_DST_BIT, true);
  vk::uploadToImage(ctx, volume, q.data.data(), q.data.size() * 2, VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL);
  vk::Sampler sampler(ctx, false);
  vk::GpuRegionGrower gpu(ctx, volume, sampler);
  const Eigen::Vector3i r = growReach(grower.setup().criterion, grower.setup().bound, extent, g.spacing) + Eigen::Vector3i::Ones();
  const Eigen::Vector3i boxLo = (seed - r).cwiseMax(Eigen::Vector3i::Zero());
  const Eigen::Vector3i boxHi = (seed + r).cwiseMin(g.dims - Eigen::Vector3i::Ones());
  const Eigen::Vector3i box = boxHi - boxLo + Eigen::Vector3i::Ones();
  gpu.begin(grower.setup(), boxLo, box);
  const std::uint32_t bound = grower.bound(extent);
  Grown out;
  out.gpuRounds = gpu.growTo(bound);
  const auto keys = gpu.readKeys();
  out.mask.assign(g.voxelCount(), 0);
  for (int k = 0; k < box.z(); ++k)
    for (int j = 0; j < box.y(); ++j)
      for (int i = 0; i < box.x(); ++i)
        if (keys[std::size_t(i) + std::size_t(box.x()) * (std::size_t(j) + std::size_t(box.y()) * std::size_t(k))] <= bound) {
          out.mask[std::size_t(boxLo.x() + i) + std::size_t(g.dims.x()) * (std::size_t(boxLo.y() + j) + std::size_t(g.dims.y()) * std::size_t(boxLo.z() + k))] = 1;
          ++out.count;
        }
  if (ctx.validationMessageCount()) throw Error("Vulkan validation messages were reported");
  return out;
}

// The selection's boundary rim added; returns how many voxels it added.
std::size_t addBoundaryRim(const RegionGrower& grower, Grown& grown) {
  std::vector<std::uint32_t> voxels;
  for (std::size_t i = 0; i < grown.mask.size(); ++i)
    if (grown.mask[i]) voxels.push_back(std::uint32_t(i));
  const std::vector<std::uint32_t> withRim = withBoundaryRim(grower, voxels);
  for (std::uint32_t i : withRim) grown.mask[i] = 1;
  grown.count = withRim.size();
  return withRim.size() - voxels.size();
}

// A CT's seed in air or lung is refused: nothing to grab there.
void checkSeedOnTissue(const Volume& v, const Eigen::Vector3i& seed) {
  const float seedValue = v.value(seed.x(), seed.y(), seed.z());
  if (v.valueRange().first <= -900.0f && seedValue < -400.0f) {
    std::ostringstream msg;
    msg << "the seed lies in air (" << seedValue << " HU): choose a point on tissue";
    throw Error(msg.str());
  }
}

}  // namespace

int cmdSelect(const Words& words) {
  Args args(words, {"--frame", "--seed-voxel", "--seed-mm", "--extent-mm", "--hmax", "--criterion", "--statistics", "--bound", "--backend", "-o", "--device", "--labels", "--rim"},
            {"--validation", "--quiet"});
  const bool labelled = bool(args.value("--labels"));
  if (args.help() || args.positional().size() != 1 || !args.value("-o") || (!labelled && !args.value("--extent-mm")) ||
      (!args.value("--seed-voxel") && !args.value("--seed-mm"))) {
    usageStream(args) << kSelectHelp;
    return args.help() ? 0 : 2;
  }
  if (args.value("--seed-voxel") && args.value("--seed-mm")) throw UsageError("give --seed-voxel or --seed-mm, not both");
  if (labelled)
    for (const char* o : {"--extent-mm", "--hmax", "--criterion", "--statistics", "--bound", "--backend", "--device", "--rim"})
      if (args.value(o)) throw UsageError(std::string(o) + " is for region growing: --labels selects the labelled organ");
  const ProgressFn progress = args.flag("--quiet") ? ProgressFn{} : consoleProgress();
  if (labelled) {
    const Volume v = loadVolume(args.positional()[0], nullptr, progress, loadOptions(args));
    return selectLabelled(args, v, seedVoxel(args, v.geometry()));
  }
  const double extent = args.number("--extent-mm", 0, -1e300, 1e300);
  if (!(extent > 0.0) || !std::isfinite(extent)) throw UsageError("--extent-mm must be a number > 0");
  const GrowParams p = growParams(args);
  const std::string backend = args.valueOr("--backend", "cpu");
  if (backend != "cpu" && backend != "gpu") throw UsageError("--backend must be cpu or gpu");
  const Volume v = loadVolume(args.positional()[0], nullptr, progress, loadOptions(args));
  const auto& g = v.geometry();
  const Eigen::Vector3i seed = seedVoxel(args, g);
  checkSeedOnTissue(v, seed);
  const QuantizedVolume q = quantizeVolume(v);
  const auto t0 = std::chrono::steady_clock::now();
  RegionGrower grower(q, seed, p);
  Grown grown;
  if (backend == "cpu") {
    grower.growTo(extent);
    grown.mask = grower.mask(extent);
    grown.count = grower.count(extent);
  } else {
    grown = growOnGpu(args, q, grower, seed, extent);
  }
  const std::size_t rimCount = p.boundaryRim ? addBoundaryRim(grower, grown) : 0;
  const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  writeMask(g, grown.mask, *args.value("-o"));
  std::cout << std::fixed << std::setprecision(1) << "selected " << grown.count << " voxels (" << grown.count * g.spacing.prod() / 1000.0 << " ml) from seed ("
            << seed.x() << ", " << seed.y() << ", " << seed.z() << "), criterion " << growCriterionName(grower.setup().criterion)
            << (grower.setup().criterion != p.criterion ? " (the seed's structure is too thin for a core)" : "") << ", " << backend << " in " << ms << " ms";
  if (backend == "gpu") std::cout << " (" << grown.gpuRounds << " rounds)";
  if (p.boundaryRim) std::cout << "; " << rimCount << " of the voxels are its boundary rim";
  std::cout << "\nwrote " << *args.value("-o") << "\n";
  return 0;
}

}  // namespace handson::cli
