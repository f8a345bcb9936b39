// `handson bench selection`: region-growing accuracy against organ labels (both criteria, a table
// and a chart) and grow/shrink update times: sparse-brick GPU pass vs dense dispatch vs the CPU
// reference, measured in one run.
#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>

#include "app/cli.h"
#include "app/cli_args.h"
#include "app/nifti_io.h"
#include "app/selection_eval.h"
#include "render/region_grow_pass.h"
#include "render/vk_context.h"
#include "render/vk_resources.h"
#include "sim/error.h"
#include "sim/quantized_volume.h"

namespace handson::cli {

namespace {

using Clock = std::chrono::steady_clock;
double msSince(Clock::time_point t) { return std::chrono::duration<double, std::milli>(Clock::now() - t).count(); }

struct Dataset {
  std::string name, dir;
  std::vector<OrganLabel> organs;
};

// chart.csv: one row per organ at 20 mm: label, paper precision, smoothed precision, paper recall, smoothed recall.
void writeChart(const std::filesystem::path& chartCsv, const std::filesystem::path& png) {
  if (std::system("command -v gnuplot > /dev/null 2>&1") != 0) {
    std::cerr << "gnuplot not found: no chart (the CSV has the numbers)\n";
    return;
  }
  const auto script = chartCsv.parent_path() / "selection_accuracy.gp";
  const std::string f = chartCsv.string();
  std::ofstream(script) << "set datafile separator ','\n"
                        << "set terminal pngcairo size 1200,560 font ',11'\nset output '" << png.string() << "'\n"
                        << "set multiplot layout 1,2 title 'Region growing at 20 mm, seeds at the deepest typical voxel of each organ: paper criterion vs smoothed (default)'\n"
                        << "set style data histograms\nset style histogram clustered gap 1\nset style fill solid 0.85 border -1\n"
                        << "set termoption noenhanced\nset yrange [0:1.1]\nset grid ytics\nset xtics rotate by -40 font ',10'\nset key top right\nset bmargin 9\n"
                        << "set title 'Precision'\n"
                        << "plot '" << f << "' using 2:xtic(1) title 'paper' lc rgb '#b05fd0', '' using 3 title 'smoothed' lc rgb '#2aa876'\n"
                        << "set title 'Recall inside the 20 mm ball'\n"
                        << "plot '" << f << "' using 4:xtic(1) title 'paper' lc rgb '#b05fd0', '' using 5 title 'smoothed' lc rgb '#2aa876'\n"
                        << "unset multiplot\n";
  if (std::system(("gnuplot " + script.string() + " 2>/dev/null").c_str()) != 0) std::cerr << "gnuplot failed: no chart\n";
}

}  // namespace

int cmdBenchSelection(const Words& words) {
  Args args(words, {"--data", "--out", "--repeat", "--device", "--extents"}, {"--quick", "--validation"});
  if (args.help() || !args.positional().empty()) {
    usageStream(args) << "usage: handson bench selection [--data DIR] [--out DIR] [--repeat N] [--extents MM,..] [--quick]\n"
                         "  Region-growing accuracy on labelled CT (default DIR ../shared/data: ircadb1.1 kidneys, aorta,\n"
                         "  portal vein, liver; totalseg-small kidneys, liver), seeds at each organ's deepest typical voxel,\n"
                         "  extents 10, 20, 40 mm (--extents), both criteria -> selection_accuracy.csv, .md and .png in --out (default\n"
                         "  bench-out); and grow/shrink update times of a ~100k-voxel liver selection: sparse-brick GPU pass,\n"
                         "  dense dispatch, CPU reference (median of N, default 5) -> selection_timing.csv.\n";
    return args.help() ? 0 : 2;
  }
  const std::string data = args.valueOr("--data", "../shared/data");
  const std::filesystem::path out = args.valueOr("--out", "bench-out");
  std::filesystem::create_directories(out);
  const int repeat = int(args.integer("--repeat", args.flag("--quick") ? 3 : 5, 1, 1000));
  const std::vector<double> extents = parseNumberList(args.valueOr("--extents", "10,20,40"), "--extents");
  for (double e : extents)
    if (!(e > 0.0 && e <= 200.0)) throw UsageError("--extents are millimetres in (0, 200]");
  std::vector<Dataset> sets = {
      {"ircadb1.1", data + "/ircadb1.1", {{3, "kidney_left"}, {4, "kidney_right"}, {9, "artery"}, {10, "portal_vein"}, {8, "liver"}}},
      {"totalseg-small", data + "/totalseg-small", {{2, "kidney_right"}, {3, "kidney_left"}, {5, "liver"}}}};

  // Accuracy.
  std::ofstream csv(out / "selection_accuracy.csv");
  csv << "dataset,organ,criterion,extent_mm,seed,selected,precision,recall\n";
  std::ofstream md(out / "selection_accuracy.md");
  std::ofstream chart(out / "selection_chart.csv");
  md << "| dataset | organ | extent | paper precision | paper recall | smoothed precision | smoothed recall |\n|---|---|---|---|---|---|---|\n";
  std::unique_ptr<Volume> ircadb;
  for (const auto& s : sets) {
    if (!std::filesystem::exists(s.dir + "/ct.nii.gz")) {
      std::cerr << "skipping " << s.name << ": " << s.dir << " not found\n";
      continue;
    }
    const Volume ct = readNifti(s.dir + "/ct.nii.gz");
    const Volume labels = readNifti(s.dir + "/labels.nii.gz");
    const auto rows = evaluateSelection(s.name, ct, labels, s.organs, extents, {GrowCriterion::Paper, GrowCriterion::Smoothed});
    for (const auto& r : rows)
      csv << r.dataset << "," << r.organ << "," << growCriterionName(r.criterion) << "," << r.extentMm << "," << r.seed.x() << " " << r.seed.y()
          << " " << r.seed.z() << "," << r.selected << "," << r.precision << "," << r.recall << "\n";
    for (const auto& a : rows) {
      if (a.criterion != GrowCriterion::Paper) continue;
      for (const auto& b : rows)
        if (b.criterion == GrowCriterion::Smoothed && b.organ == a.organ && b.extentMm == a.extentMm) {
          md << std::fixed << std::setprecision(2) << "| " << a.dataset << " | " << a.organ << " | " << a.extentMm << " mm | " << a.precision
             << " | " << a.recall << " | " << b.precision << " | " << b.recall << " |\n";
          if (a.extentMm == 20.0)
            chart << a.dataset << " " << a.organ << "," << a.precision << "," << b.precision << "," << a.recall << "," << b.recall << "\n";
        }
    }
    if (s.name == "ircadb1.1") ircadb = std::make_unique<Volume>(ct);
  }
  csv.close();
  md.close();
  chart.close();
  writeChart(out / "selection_chart.csv", out / "selection_accuracy.png");
  std::cout << "accuracy: " << (out / "selection_accuracy.md").string() << "\n" << std::ifstream(out / "selection_accuracy.md").rdbuf();

  // Timing: a liver selection of ~100k voxels grown from 20 to 25 mm and shrunk back.
  if (!ircadb) return 0;
  const QuantizedVolume q = quantizeVolume(*ircadb);
  const Eigen::Vector3i seed(216, 150, 96);
  const double e1 = 20.0, e2 = 25.0;
  GrowParams p;
  RegionGrower setup(q, seed, p);
  vk::ContextOptions co;
  co.device = args.valueOr("--device", "");
  co.validation = args.flag("--validation");
  vk::Context ctx(co);
  const auto& d = q.geometry.dims;
  vk::Image volume(ctx, {std::uint32_t(d.x()), std::uint32_t(d.y()), std::uint32_t(d.z()), fg::Format::R16Unorm},
                   VK_IMAGE_USAGE_SAMPLED_BIT | VK_IMAGE_USAGE_TRANSFER_DST_BIT, true);
  vk::uploadToImage(ctx, volume, q.data.data(), q.data.size() * 2, VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL);
  vk::Sampler sampler(ctx, false);
  const Eigen::Vector3i r = (Eigen::Vector3d::Constant(50.0).array() / q.geometry.spacing.array()).ceil().cast<int>();
  const Eigen::Vector3i lo = (seed - r).cwiseMax(Eigen::Vector3i::Zero()), hi = (seed + r).cwiseMin(d - Eigen::Vector3i::Ones());
  std::vector<double> cpuMs, sparseMs, denseMs;
  std::size_t voxels = 0;
  std::uint64_t sparseBricks = 0, denseBricks = 0;
  for (int i = 0; i < repeat; ++i) {
    RegionGrower cpu(q, seed, p);
    cpu.growTo(e1);
    auto t = Clock::now();
    cpu.growTo(e2);
    cpuMs.push_back(msSince(t));
    voxels = cpu.count(e2);
    for (bool dense : {false, true}) {
      vk::GpuRegionGrower gpu(ctx, volume, sampler);
      gpu.begin(setup.setup(), lo, hi - lo + Eigen::Vector3i::Ones());
      gpu.growTo(setup.bound(e1), dense);
      t = Clock::now();
      gpu.growTo(setup.bound(e2), dense);
      (dense ? denseMs : sparseMs).push_back(msSince(t));
      (dense ? denseBricks : sparseBricks) = gpu.bricksDispatched();
    }
  }
  auto median = [](std::vector<double> v) {
    std::sort(v.begin(), v.end());
    return v[v.size() / 2];
  };
  const double c = median(cpuMs), s = median(sparseMs), dn = median(denseMs);
  std::ofstream tcsv(out / "selection_timing.csv");
  tcsv << "method,update_ms\ncpu," << c << "\ngpu_sparse," << s << "\ngpu_dense," << dn << "\n";
  std::cout << std::fixed << std::setprecision(1) << "\ngrow update " << e1 << " -> " << e2 << " mm of a " << voxels << "-voxel liver selection on "
            << ctx.summary().name << " (median of " << repeat << "):\n  CPU reference " << c << " ms\n  GPU sparse bricks " << s
            << " ms\n  GPU dense dispatch " << dn << " ms\n  sparse vs dense " << std::setprecision(2) << dn / s << "x, sparse vs CPU "
            << c / s << "x\n  shrinking is a threshold on stored keys: no growth work\n";
  return ctx.validationMessageCount() ? 1 : 0;
}

}  // namespace handson::cli
