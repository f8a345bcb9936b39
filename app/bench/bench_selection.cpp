// `handson bench selection`: region-growing accuracy against organ labels (both criteria, a table
// and a chart) and grow/shrink update times: sparse-brick GPU pass vs dense dispatch vs the CPU
// reference, measured in one run.
#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <sstream>

#include "app/bench/bench.h"
#include "app/bench/bench_selection_gestures.h"
#include "app/cli/args.h"
#include "app/io/nifti_io.h"
#include "app/tools/selection_eval.h"
#include "render/region_grow_pass.h"
#include "render/vk_context.h"
#include "render/vk_resources.h"
#include "sim/base/error.h"
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
                        << "set multiplot layout 1,2 title 'Region growing at 20 mm, seeds at the deepest typical voxel of each organ: paper criterion vs smoothed'\n"
                        << "set style data histograms\nset style histogram clustered gap 1\nset style fill solid 0.85 border -1\n"
                        << "set termoption noenhanced\nset yrange [0:1.1]\nset grid ytics\nset xtics rotate by -40 font ',10'\nset key top right\nset bmargin 9\n"
                        << "set title 'Precision'\n"
                        << "plot '" << f << "' using 2:xtic(1) title 'paper' lc rgb '#b05fd0', '' using 3 title 'smoothed' lc rgb '#2aa876'\n"
                        << "set title 'Recall inside the 20 mm ball'\n"
                        << "plot '" << f << "' using 4:xtic(1) title 'paper' lc rgb '#b05fd0', '' using 5 title 'smoothed' lc rgb '#2aa876'\n"
                        << "unset multiplot\n";
  if (std::system(("gnuplot " + script.string() + " 2>/dev/null").c_str()) != 0) std::cerr << "gnuplot failed: no chart\n";
}


// The sweep's table (selection_dice.md, also printed) and chart (selection_dice.csv -> .png): per
// organ and criterion the best Dice over the sweep and the Dice at the largest extent; then the
// median and the lowest best, and how many organs keep >= 0.8 of their best at the largest extent.
using Variant = std::pair<GrowCriterion, bool>;  // a criterion, and whether its selections end with their boundary rim

void writeDice(const std::vector<OrganSweep>& sweeps, const std::vector<Variant>& criteria, const std::filesystem::path& out) {
  std::vector<std::pair<std::string, std::string>> organs;  // (dataset, organ) in order
  for (const auto& w : sweeps)
    if (std::find(organs.begin(), organs.end(), std::make_pair(w.dataset, w.organ)) == organs.end()) organs.emplace_back(w.dataset, w.organ);
  auto find = [&](const std::pair<std::string, std::string>& o, const Variant& c) -> const OrganSweep* {
    for (const auto& w : sweeps)
      if (w.dataset == o.first && w.organ == o.second && w.criterion == c.first && w.rim == c.second) return &w;
    return nullptr;
  };
  std::ofstream md(out / "selection_dice.md"), csv(out / "selection_dice.csv");
  if (organs.empty()) {
    md << "No labelled organ was found: nothing swept.\n";
    return;
  }
  const double last = sweeps.front().points.back().fraction;
  md << std::fixed << std::setprecision(2) << "Whole-organ Dice, extent swept " << sweeps.front().points.front().fraction << "-" << last
     << "x the organ's radius (95th percentile of its voxels' distances from the seed); best (at which fraction) and at " << last << "x\n\n"
     << "| dataset | organ | radius |";
  for (const Variant& c : criteria) md << " " << sweepVariantName(c.first, c.second) << " best | at " << last << "x |";
  md << "\n|---|---|---|";
  for (std::size_t i = 0; i < criteria.size(); ++i) md << "---|---|";
  md << "\n";
  for (const auto& o : organs) {
    const OrganSweep* any = find(o, criteria.front());
    md << "| " << o.first << " | " << o.second << " | " << std::setprecision(0) << (any ? any->radiusMm : 0.0) << " mm |" << std::setprecision(2);
    csv << o.first << " " << o.second;
    for (const Variant& c : criteria) {
      const OrganSweep* w = find(o, c);
      if (!w) {
        md << " - | - |";
        csv << ",0,0";
        continue;
      }
      md << " " << w->best().dice << " (" << std::setprecision(1) << w->best().fraction << std::setprecision(2) << "x) | " << w->points.back().dice << " |";
      csv << "," << w->best().dice << "," << w->points.back().dice;
    }
    md << "\n";
    csv << "\n";
  }
  auto summary = [&](const std::string& what, auto f) {
    md << "| " << what << " | | |";
    for (const Variant& c : criteria) {
      std::vector<double> best;
      std::size_t kept = 0;
      for (const auto& o : organs)
        if (const OrganSweep* w = find(o, c)) {
          best.push_back(w->best().dice);
          kept += w->points.back().dice >= 0.8 * w->best().dice;
        }
      md << " " << f(best, kept) << " | |";
    }
    md << "\n";
  };
  summary("median best", [](std::vector<double> b, std::size_t) {
    std::sort(b.begin(), b.end());
    std::ostringstream s;
    s << std::fixed << std::setprecision(2) << (b.size() % 2 ? b[b.size() / 2] : 0.5 * (b[b.size() / 2 - 1] + b[b.size() / 2]));
    return s.str();
  });
  summary("lowest best", [](std::vector<double> b, std::size_t) {
    std::ostringstream s;
    s << std::fixed << std::setprecision(2) << *std::min_element(b.begin(), b.end());
    return s.str();
  });
  summary("organs at >= 0.8 of best at " + std::to_string(last).substr(0, 3) + "x", [](std::vector<double> b, std::size_t kept) {
    return std::to_string(kept) + " of " + std::to_string(b.size());
  });
  md.close();
  csv.close();
  if (std::system("command -v gnuplot > /dev/null 2>&1") != 0) return;
  const auto script = out / "selection_dice.gp";
  const std::string f = (out / "selection_dice.csv").string();
  const std::vector<std::string> colours = {"#b05fd0", "#d9a8ec", "#2aa876", "#93d8bb", "#e07b39", "#f2bf9b", "#3b7dd8", "#9dbeec"};
  std::ofstream gp(script);
  gp << "set datafile separator ','\nset terminal pngcairo size 1400,600 font ',11'\nset output '" << (out / "selection_dice.png").string() << "'\n"
     << "set multiplot layout 1,2 title 'Whole-organ Dice of the selection grown from one seed per organ, extent swept as the fingers spread'\n"
     << "set style data histograms\nset style histogram clustered gap 1\nset style fill solid 0.85 border -1\n"
     << "set termoption noenhanced\nset yrange [0:1.05]\nset grid ytics\nset xtics rotate by -40 font ',10'\nset key top right\nset bmargin 9\n";
  for (int panel = 0; panel < 2; ++panel) {
    gp << "set title '" << (panel == 0 ? "Best over the sweep" : "At the largest extent (" + std::to_string(last).substr(0, 3) + "x the radius)") << "'\nplot ";
    for (std::size_t i = 0; i < criteria.size(); ++i)
      gp << (i ? ", ''" : "'" + f + "'") << " using " << 2 + 2 * i + std::size_t(panel) << (i ? "" : ":xtic(1)") << " title '" << sweepVariantName(criteria[i].first, criteria[i].second)
         << "' lc rgb '" << colours[i % colours.size()] << "'";
    gp << "\n";
  }
  gp << "unset multiplot\n";
  gp.close();
  if (std::system(("gnuplot " + script.string() + " 2>/dev/null").c_str()) != 0) std::cerr << "gnuplot failed: no Dice chart\n";
}

struct GrowTiming {
  GrowCriterion criterion;
  GrowBound bound;
  std::size_t voxels = 0;
  double cpuMs = 0, sparseMs = 0, denseMs = 0;  // medians; denseMs 0 when not measured
};

// The volume on the CPU and on the GPU, for the growth timings.
struct GrowthVolume {
  vk::Context& ctx;
  const QuantizedVolume& q;
  const vk::Image& volume;
  const vk::Sampler& sampler;
};

// A live update: the selection of a liver seed of ircadb1.1 grown from 20 to 25 mm, on the CPU
// reference and the GPU pass (sparse bricks, and optionally the dense dispatch over the box).
GrowTiming timeGrowth(const GrowthVolume& on, GrowCriterion criterion, GrowBound bound, int repeat, bool dense) {
  vk::Context& ctx = on.ctx;
  const QuantizedVolume& q = on.q;
  const vk::Image& volume = on.volume;
  const vk::Sampler& sampler = on.sampler;
  const Eigen::Vector3i seed(216, 150, 96);
  const double e1 = 20.0, e2 = 25.0;
  GrowParams p;
  p.criterion = criterion;
  p.bound = bound;
  RegionGrower setup(q, seed, p);
  const auto& d = q.geometry.dims;
  const Eigen::Vector3i r = growReach(setup.setup().criterion, setup.setup().bound, 50.0, q.geometry.spacing);  // a box beyond the 25 mm reach
  const Eigen::Vector3i lo = (seed - r).cwiseMax(Eigen::Vector3i::Zero()), hi = (seed + r).cwiseMin(d - Eigen::Vector3i::Ones());
  std::vector<double> cpuMs, sparseMs, denseMs;
  GrowTiming out{setup.setup().criterion, bound};  // the criterion that runs (a thin structure falls back to smoothed)
  for (int i = 0; i < repeat; ++i) {
    RegionGrower cpu(q, seed, p);
    cpu.growTo(e1);
    auto t = Clock::now();
    cpu.growTo(e2);
    cpuMs.push_back(msSince(t));
    out.voxels = cpu.count(e2);
    for (bool denseRun : {false, true}) {
      if (denseRun && !dense) continue;
      vk::GpuRegionGrower gpu(ctx, volume, sampler);
      gpu.begin(setup.setup(), lo, hi - lo + Eigen::Vector3i::Ones());
      gpu.growTo(setup.bound(e1), denseRun);
      t = Clock::now();
      gpu.growTo(setup.bound(e2), denseRun);
      (denseRun ? denseMs : sparseMs).push_back(msSince(t));
    }
  }
  auto median = [](std::vector<double> v) {
    if (v.empty()) return 0.0;
    std::sort(v.begin(), v.end());
    return v[v.size() / 2];
  };
  out.cpuMs = median(cpuMs);
  out.sparseMs = median(sparseMs);
  out.denseMs = median(denseMs);
  return out;
}

}  // namespace

namespace {

const char* const kBenchSelectionHelp =
    "usage: handson bench selection [--data DIR] [--out DIR] [--repeat N] [--criteria LIST] [--fractions LIST]\n"
    "                               [--extents MM,..] [--statistics robust|moments] [--bound path|ball]\n"
    "                               [--sweep-only] [--quick]\n"
    "       handson bench selection --protocol gestures [--data DIR] [--out DIR] [--gestures N] [--corrections neck|grown]\n"
    "  Region growing on labelled CT (default DIR ../shared/data: ircadb1.1 kidneys, artery, portal vein,\n"
    "  liver, venous system, spleen; totalseg-small kidneys, liver, spleen), seeds at each organ's deepest\n"
    "  typical voxel. Whole-organ Dice as the extent sweeps --fractions of the organ's radius (default\n"
    "  0.3,0.4,...,1.2) for each of --criteria (default paper,smoothed,core) -> selection_sweep.csv,\n"
    "  selection_dice.md and .png in --out (default bench-out); precision and recall at --extents (default\n"
    "  10,20,40 mm) -> selection_accuracy.csv, .md, .png; and grow update times of a ~120k-voxel liver\n"
    "  selection, smoothed and core: CPU reference, GPU sparse bricks, dense dispatch (median of N,\n"
    "  default 5) -> selection_timing.csv. --sweep-only stops after the Dice sweep. --statistics: how the\n"
    "  sweep's core and smoothed criteria refine their statistics (default robust; moments, the earlier\n"
    "  rule, to compare); --bound: how the extent bounds them (default path; ball, the earlier rule).\n"
    "  --protocol gestures: a simulated user instead (the interactive-segmentation challenges' protocol):\n"
    "  a first pinch at each organ's deepest voxel spread to its radius, then corrections, each a pinch at\n"
    "  the deepest voxel of the largest error region (missed organ: united; leaked tissue: subtracted)\n"
    "  spread to that region's radius, through the app's pinch, union and difference; N gestures in all\n"
    "  (default 10) -> selection_gestures.csv, .md and .png. --corrections: the app's rule for a union\n"
    "  and a difference (default neck; grown, the earlier rule, to compare).\n";

// What `bench selection` was asked.
struct SelectionBenchOptions {
  std::string data;
  std::filesystem::path out;
  int repeat = 5;
  std::vector<double> extents, fractions;
  std::vector<GrowCriterion> criteria;
  RegionStatistics statistics = RegionStatistics::Robust;
  GrowBound bound = GrowParams{}.bound;
  bool sweepOnly = false;
};

SelectionBenchOptions parseSelectionBenchOptions(const Args& args) {
  SelectionBenchOptions o;
  o.data = args.valueOr("--data", "../shared/data");
  o.out = args.valueOr("--out", "bench-out");
  o.repeat = int(args.integer("--repeat", args.flag("--quick") ? 3 : 5, 1, 1000));
  o.extents = parseNumberList(args.valueOr("--extents", "10,20,40"), "--extents");
  for (double e : o.extents)
    if (!(e > 0.0 && e <= 200.0)) throw UsageError("--extents are millimetres in (0, 200]");
  std::stringstream names(args.valueOr("--criteria", "paper,smoothed,core"));
  for (std::string w; std::getline(names, w, ',');) {
    GrowCriterion c;
    if (!parseGrowCriterion(w, c)) throw UsageError("--criteria: unknown criterion '" + w + "'");
    o.criteria.push_back(c);
  }
  if (o.criteria.empty()) throw UsageError("--criteria names at least one criterion (core, smoothed, paper)");
  if (!parseRegionStatistics(args.valueOr("--statistics", "robust"), o.statistics)) throw UsageError("--statistics must be robust or moments");
  if (!parseGrowBound(args.valueOr("--bound", growBoundName(o.bound)), o.bound)) throw UsageError("--bound must be ball or path");
  o.fractions = parseNumberList(args.valueOr("--fractions", "0.3,0.4,0.5,0.6,0.7,0.8,0.9,1,1.1,1.2"), "--fractions");
  for (double f : o.fractions)
    if (!(f > 0.0 && f <= 3.0)) throw UsageError("--fractions are fractions of the organ's radius in (0, 3]");
  std::sort(o.fractions.begin(), o.fractions.end());
  o.sweepOnly = args.flag("--sweep-only");
  return o;
}

// The benchmark's accuracy outputs, written as the datasets are measured.
struct SelectionOutputs {
  std::ofstream sweep, csv, md, chart;
  explicit SelectionOutputs(const std::filesystem::path& out)
      : sweep(out / "selection_sweep.csv"), csv(out / "selection_accuracy.csv"), md(out / "selection_accuracy.md"), chart(out / "selection_chart.csv") {
    sweep << "dataset,organ,criterion,radius_mm,organ_voxels,fraction,extent_mm,selected,dice,precision,recall,grow_ms\n";
    csv << "dataset,organ,criterion,extent_mm,seed,selected,precision,recall\n";
    md << "| dataset | organ | extent | paper precision | paper recall | smoothed precision | smoothed recall |\n|---|---|---|---|---|---|---|\n";
  }
};

// The Dice sweep of one dataset's organs, to the sweep CSV and `sweeps`.
void sweepDataset(const Dataset& s, const Volume& ct, const Volume& labels, const SelectionBenchOptions& o, SelectionOutputs& w, std::vector<OrganSweep>& sweeps) {
  std::cerr << s.name << ": sweeping " << s.organs.size() << " organs x " << o.criteria.size() << " criteria\n";
  for (auto& sw : sweepSelection({s.name, ct, labels, s.organs}, {o.fractions, o.criteria, true, o.statistics, o.bound})) {
    std::cerr << "  " << sw.organ << " " << sweepVariantName(sw.criterion, sw.rim) << ": best Dice " << std::fixed << std::setprecision(3)
              << sw.best().dice << " at " << std::setprecision(1) << sw.best().fraction << "x, " << std::setprecision(3) << sw.points.back().dice
              << " at " << std::setprecision(1) << sw.points.back().fraction << "x\n";
    for (const auto& p : sw.points)
      w.sweep << sw.dataset << "," << sw.organ << "," << sweepVariantName(sw.criterion, sw.rim) << "," << sw.radiusMm << "," << sw.organVoxels << ","
              << p.fraction << "," << p.extentMm << "," << p.selected << "," << p.dice << "," << p.precision << "," << p.recall << "," << p.milliseconds << "\n";
    sweeps.push_back(std::move(sw));
  }
}

// Precision and recall of one dataset's organs at the fixed extents, paper against smoothed.
void evaluateDataset(const Dataset& s, const Volume& ct, const Volume& labels, const SelectionBenchOptions& o, SelectionOutputs& w) {
  const auto rows = evaluateSelection({s.name, ct, labels, s.organs}, o.extents, {GrowCriterion::Paper, GrowCriterion::Smoothed});
  for (const auto& r : rows)
    w.csv << r.dataset << "," << r.organ << "," << growCriterionName(r.criterion) << "," << r.extentMm << "," << r.seed.x() << " " << r.seed.y() << " "
          << r.seed.z() << "," << r.selected << "," << r.precision << "," << r.recall << "\n";
  for (const auto& a : rows) {
    if (a.criterion != GrowCriterion::Paper) continue;
    for (const auto& b : rows)
      if (b.criterion == GrowCriterion::Smoothed && b.organ == a.organ && b.extentMm == a.extentMm) {
        w.md << std::fixed << std::setprecision(2) << "| " << a.dataset << " | " << a.organ << " | " << a.extentMm << " mm | " << a.precision << " | "
             << a.recall << " | " << b.precision << " | " << b.recall << " |\n";
        if (a.extentMm == 20.0) w.chart << a.dataset << " " << a.organ << "," << a.precision << "," << b.precision << "," << a.recall << "," << b.recall << "\n";
      }
  }
}

// Timing: a liver selection of ~100k voxels grown from 20 to 25 mm (shrinking is a threshold), on
// the CPU and the GPU. Non-zero when the validation layer reported anything.
int timeLiverGrowth(const Args& args, const Volume& ircadb, int repeat, const std::filesystem::path& out) {
  vk::ContextOptions co;
  co.device = args.valueOr("--device", "");
  co.validation = args.flag("--validation");
  vk::Context ctx(co);
  const QuantizedVolume q = quantizeVolume(ircadb);
  std::ofstream tcsv(out / "selection_timing.csv");
  tcsv << "criterion,bound,method,update_ms\n";
  std::cout << "\ngrow update 20 -> 25 mm of a liver selection of ircadb1.1 on " << ctx.summary().name << " (median of " << repeat << ")\n";
  const auto& d = q.geometry.dims;  // the volume uploaded once for both criteria
  vk::Image volume(ctx, {std::uint32_t(d.x()), std::uint32_t(d.y()), std::uint32_t(d.z()), fg::Format::R16Unorm},
                   VK_IMAGE_USAGE_SAMPLED_BIT | VK_IMAGE_USAGE_TRANSFER_DST_BIT, true);
  vk::uploadToImage(ctx, volume, q.data.data(), q.data.size() * 2, VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL);
  vk::Sampler sampler(ctx, false);
  const GrowthVolume on{ctx, q, volume, sampler};
  const GrowTiming base = timeGrowth(on, GrowCriterion::Smoothed, GrowBound::Ball, repeat, false);
  const GrowTiming ball = timeGrowth(on, GrowParams{}.criterion, GrowBound::Ball, repeat, false);
  const GrowTiming now = timeGrowth(on, GrowParams{}.criterion, GrowParams{}.bound, repeat, true);
  for (const GrowTiming* t : {&base, &ball, &now}) {
    const std::string name = std::string(growCriterionName(t->criterion)) + "," + growBoundName(t->bound);
    tcsv << name << ",cpu," << t->cpuMs << "\n" << name << ",gpu_sparse," << t->sparseMs << "\n";
    if (t->denseMs > 0) tcsv << name << ",gpu_dense," << t->denseMs << "\n";
    std::cout << std::fixed << std::setprecision(1) << "  " << growCriterionName(t->criterion) << ", " << growBoundName(t->bound) << " bound ("
              << t->voxels << " voxels): CPU reference " << t->cpuMs << " ms, GPU sparse bricks " << t->sparseMs << " ms";
    if (t->denseMs > 0) std::cout << ", GPU dense dispatch " << t->denseMs << " ms (sparse " << std::setprecision(2) << t->denseMs / t->sparseMs << "x faster)";
    std::cout << "\n";
  }
  std::cout << std::setprecision(2) << "  " << growCriterionName(now.criterion) << ", " << growBoundName(now.bound)
            << " bound against smoothed, ball bound, same run: CPU " << now.cpuMs / base.cpuMs << "x the time, GPU sparse "
            << now.sparseMs / base.sparseMs << "x; against " << growCriterionName(ball.criterion) << ", ball bound: CPU "
            << now.cpuMs / ball.cpuMs << "x, GPU sparse " << now.sparseMs / ball.sparseMs
            << "x\n  shrinking is a threshold on stored keys: no growth work\n";
  return ctx.validationMessageCount() ? 1 : 0;
}

}  // namespace

int cmdBenchSelection(const Words& words) {
  Args args(words, {"--data", "--out", "--repeat", "--device", "--extents", "--criteria", "--fractions", "--statistics", "--bound", "--protocol", "--gestures", "--corrections"},
            {"--quick", "--validation", "--sweep-only"});
  if (args.help() || !args.positional().empty()) {
    usageStream(args) << kBenchSelectionHelp;
    return args.help() ? 0 : 2;
  }
  const std::string protocol = args.valueOr("--protocol", "sweep");
  if (protocol != "sweep" && protocol != "gestures") throw UsageError("--protocol must be sweep or gestures");
  if (protocol == "gestures") {
    GestureProtocol p;
    p.gestures = int(args.integer("--gestures", 10, 1, 100));
    if (!parseCorrectionRule(args.valueOr("--corrections", correctionRuleName(p.corrections)), p.corrections))
      throw UsageError("--corrections must be neck or grown");
    return benchSelectionGestures(args.valueOr("--data", "../shared/data"), args.valueOr("--out", "bench-out"), p);
  }
  for (const char* o : {"--gestures", "--corrections"})
    if (args.value(o)) throw UsageError(std::string(o) + " is for --protocol gestures");
  const SelectionBenchOptions o = parseSelectionBenchOptions(args);
  std::filesystem::create_directories(o.out);
  const std::vector<Dataset> sets = {
      {"ircadb1.1", o.data + "/ircadb1.1", {{3, "kidney_left"}, {4, "kidney_right"}, {9, "artery"}, {10, "portal_vein"}, {8, "liver"}, {11, "venous_system"}, {7, "spleen"}}},
      {"totalseg-small", o.data + "/totalseg-small", {{2, "kidney_right"}, {3, "kidney_left"}, {5, "liver"}, {1, "spleen"}}}};
  // Whole-organ Dice as the extent sweeps (the headline figures), then precision and recall at
  // fixed extents.
  std::vector<OrganSweep> sweeps;
  std::unique_ptr<Volume> ircadb;
  {
    SelectionOutputs w(o.out);
    for (const auto& s : sets) {
      if (!std::filesystem::exists(s.dir + "/ct.nii.gz")) {
        std::cerr << "skipping " << s.name << ": " << s.dir << " not found\n";
        continue;
      }
      const Volume ct = readNifti(s.dir + "/ct.nii.gz");
      const Volume labels = readNifti(s.dir + "/labels.nii.gz");
      sweepDataset(s, ct, labels, o, w, sweeps);
      if (o.sweepOnly) continue;
      evaluateDataset(s, ct, labels, o, w);
      if (s.name == "ircadb1.1") ircadb = std::make_unique<Volume>(ct);
    }
  }
  std::vector<Variant> variants;
  for (GrowCriterion c : o.criteria) {
    variants.emplace_back(c, false);
    variants.emplace_back(c, true);
  }
  writeDice(sweeps, variants, o.out);
  std::cout << "whole-organ Dice: " << (o.out / "selection_dice.md").string() << "\n" << std::ifstream(o.out / "selection_dice.md").rdbuf() << "\n";
  if (o.sweepOnly) return 0;
  writeChart(o.out / "selection_chart.csv", o.out / "selection_accuracy.png");
  std::cout << "accuracy: " << (o.out / "selection_accuracy.md").string() << "\n" << std::ifstream(o.out / "selection_accuracy.md").rdbuf();
  return ircadb ? timeLiverGrowth(args, *ircadb, o.repeat, o.out) : 0;
}

}  // namespace handson::cli
