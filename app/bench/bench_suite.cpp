// `handson bench --out DIR [--quick]`: the benchmark suite. The paper's four scenarios replayed on the
// default scene with the simulation on (per-stage GPU times, frame time and input-to-present latency
// from each replay's timing log), then every component benchmark into its own folder (raymarch,
// gesture, selection when ../shared/data is there, sim, deform, mesh, stability), and a summary.
// --quick shrinks each so the whole suite takes a few minutes on 2 cores; --smoke runs every part at
// the smallest size that still runs it (the test suite's check of the suite itself).
#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <map>
#include <optional>
#include <sstream>

#include "app/bench/bench.h"
#include "app/cli/args.h"
#include "app/io/nifti_io.h"
#include "app/session/replay.h"
#include "app/tools/scenario_retarget.h"
#include "scripts/scenario_kidney_rotate_in_plane.h"
#include "scripts/scenario_kidney_rotate_out_of_plane_three_fingers.h"
#include "scripts/scenario_kidney_translate_two_fingers.h"
#include "scripts/scenario_vessel_translate_one_finger.h"
#include "sim/base/error.h"
#include "sim/resample.h"

namespace handson::cli {

namespace {
const char* const kBenchSuiteHelp =
    "usage: handson bench --out DIR [--quick | --smoke] [--data DIR]\n"
    "  The benchmark suite: the paper's scenarios (assets/gestures: kidney translated with two fingers,\n"
    "  rotated in plane, rotated out of plane with three, a vessel moved with one) replayed headless with\n"
    "  the simulation on, on each scene: the phantom, and with DIR/ircadb1.1 present (--data, default\n"
    "  ../shared/data) ircadb1.1 resampled to ~5 M voxels and at full size (34 M), the scripts re-aimed\n"
    "  at the organ by its label; per-stage GPU and CPU times and latency (scenario_stages.csv,\n"
    "  scenario_stages_wide.csv, stages.png, latency.csv, latency.png). Then the component benchmarks\n"
    "  into DIR/raymarch, gesture, selection, sim (phantom, and sim-ircadb1.1: the right kidney of the real\n"
    "  CT), deform, mesh and stability; summary.txt lists what ran and took how long.\n"
    "  --quick: smaller scenes and sweeps, no 34 M scene (a few minutes on 2 cores).\n"
    "  --smoke: every scenario and component at the smallest size that runs it: a check that the suite\n"
    "  works (about a minute), its figures are not measurements.\n";

double percentile(std::vector<double> v, double p) {
  if (v.empty()) return std::nan("");
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, std::size_t(p * double(v.size() - 1) + 0.5))];
}

// Columns of a replay timing log (app/session/latency_log.cpp).
std::map<std::string, std::vector<double>> readTimings(const std::filesystem::path& csv) {
  std::ifstream in(csv);
  std::string line;
  std::vector<std::string> names;
  std::map<std::string, std::vector<double>> cols;
  do {  // past the "# " notes to the column names
    if (!std::getline(in, line)) return cols;
  } while (line.rfind("#", 0) == 0);
  std::stringstream hs(line);
  for (std::string n; std::getline(hs, n, ',');) names.push_back(n);
  while (std::getline(in, line)) {
    std::stringstream ls(line);
    std::string cell;
    for (std::size_t i = 0; i < names.size() && std::getline(ls, cell, ','); ++i) {
      const double v = std::atof(cell.c_str());
      if (v >= 0.0) cols[names[i]].push_back(v);  // -1: no value this frame
    }
  }
  return cols;
}

// The paper's scenarios (assets/gestures), as built in.
const std::pair<const char*, const char*> kScenarios[] = {{"kidney-translate-two-fingers", kScenario_kidney_translate_two_fingers},
                                                         {"kidney-rotate-in-plane", kScenario_kidney_rotate_in_plane},
                                                         {"kidney-rotate-out-of-plane-three-fingers", kScenario_kidney_rotate_out_of_plane_three_fingers},
                                                         {"vessel-translate-one-finger", kScenario_vessel_translate_one_finger}};

struct Scene {
  std::string name, volume;      // volume "": the phantom
  std::vector<std::string> scripts;  // per scenario (paths)
};

// What the suite's parts share: where it writes, its size, its summary and its failure count.
struct SuiteRun {
  std::filesystem::path out;
  std::string data;
  bool quick = false, smoke = false;
  std::ofstream summary;
  int failures = 0;
};

double since(std::chrono::steady_clock::time_point t0) { return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(); }

// 1. The scenes: the phantom (the scripts as recorded), ircadb1.1 resampled to the paper's ~5 M
// voxels (--quick: 1 M) and at full size (34 M voxels; not with --quick). On real CT the scripts are
// re-aimed at the organ by its label (app/tools/scenario_retarget.h): the touches stay, the camera moves.
std::vector<Scene> prepareScenes(SuiteRun& run) {
  const std::filesystem::path& out = run.out;
  const bool quick = run.quick, smoke = run.smoke;
  std::ofstream& summary = run.summary;
  int& failures = run.failures;
  const std::string& data = run.data;
  std::vector<Scene> scenes;
  {
    Scene ph{"phantom", "", {}};
    for (const auto& [name, text] : kScenarios) {
      const auto script = out / "scenarios" / (std::string(name) + ".json");
      std::ofstream(script) << text;
      ph.scripts.push_back(script.string());
    }
    scenes.push_back(std::move(ph));
  }
  const std::filesystem::path ircadb = std::filesystem::path(data) / "ircadb1.1";
  if (std::filesystem::exists(ircadb / "ct.nii.gz") && std::filesystem::exists(ircadb / "labels.nii.gz")) {
    const auto t0 = std::chrono::steady_clock::now();
    try {
      std::filesystem::create_directories(out / "scenes");
      const Volume ct = readNifti((ircadb / "ct.nii.gz").string());
      const Volume labels = readNifti((ircadb / "labels.nii.gz").string());
      const std::size_t voxels = smoke ? 250'000 : quick ? 1'000'000 : 5'000'000;
      const std::string smallName =
          "ircadb1.1-" + (voxels >= 1'000'000 ? std::to_string(voxels / 1'000'000) + "M" : std::to_string(voxels / 1'000) + "k");
      const auto smallPath = out / "scenes" / (smallName + ".nii.gz");
      writeNifti(resampleToVoxelCount(ct, voxels), smallPath.string());
      Scene small{smallName, smallPath.string(), {}}, full{"ircadb1.1-34M", (ircadb / "ct.nii.gz").string(), {}};
      for (const auto& [name, text] : kScenarios) {
        const SessionScript recorded = parseSessionScript(text, name);
        const bool vessel = std::string(name).rfind("vessel", 0) == 0;
        // The phantom's organs: the right kidney and the inferior vena cava; on ircadb1.1 the right
        // kidney (4, else the left, 3) and the venous system (11, else the artery, 9).
        std::optional<RetargetedScript> r;
        std::string why;
        for (int label : vessel ? std::vector<int>{11, 9} : std::vector<int>{4, 3}) {
          try {
            r = retargetScript(recorded, ct, labels, label, (ircadb / "ct.nii.gz").string());
            break;
          } catch (const std::exception& e) {
            why = e.what();
          }
        }
        if (!r) throw Error(std::string("scenario ") + name + ": " + why);
        summary << "scenario " << name << " on ircadb1.1: camera azimuth " << r->azimuthDeg << ", elevation " << r->elevationDeg << " deg; "
                << r->onOrgan << " of " << r->touchDowns << " touch-downs on the organ\n";
        const auto script = out / "scenarios" / (std::string(name) + "-ircadb1.1.json");
        writeSessionScript(r->script, script.string());
        small.scripts.push_back(script.string());
        full.scripts.push_back(script.string());
      }
      scenes.push_back(std::move(small));
      if (!quick) scenes.push_back(std::move(full));
    } catch (const std::exception& e) {
      ++failures;
      summary << "ircadb1.1 scenes: FAILED: " << e.what() << "\n";
      std::cerr << "ircadb1.1 scenes failed: " << e.what() << "\n";
    }
    std::cout << "real-CT scenes prepared in " << since(t0) << " s\n";
  } else {
    summary << "real-CT scenes: skipped (no ircadb1.1 at " << ircadb.string() << ")\n";
  }
  return scenes;
}

// The scenes' latency distribution and per-stage medians as charts (gnuplot; none without it).
void writeScenarioCharts(const std::filesystem::path& out, const std::vector<Scene>& scenes, const std::map<std::string, std::vector<double>>& wide) {
  if (std::system("command -v gnuplot > /dev/null 2>&1") == 0) {
    const auto gp = out / "latency.gp";
    std::ofstream g(gp);
    g << "set datafile separator ','\nset terminal pngcairo size 900,520 font ',11'\nset output '" << (out / "latency.png").string()
      << "'\nset termoption noenhanced\nset title 'Input-to-present latency per scene (cumulative distribution over the scenarios frames with input)'\n"
      << "set xlabel 'ms'\nset ylabel 'fraction of frames'\nset logscale x\nset grid\nset key bottom right\nset yrange [0:1.02]\nplot ";
    for (std::size_t i = 0; i < scenes.size(); ++i)
      g << (i ? ", " : "") << "'" << (out / "latency.csv").string() << "' index " << i << " using 3:2 with steps lw 2 title '" << scenes[i].name << "'";
    g << "\n";
    g.close();
    if (std::system(("gnuplot " + gp.string() + " 2>/dev/null").c_str()) != 0) std::cerr << "gnuplot failed: no latency chart\n";
  }
  {
    std::ofstream w(out / "scenario_stages_wide.csv");
    w << "stage";
    for (const auto& sc : scenes) w << "," << sc.name;
    w << "\n";
    for (const auto& [stage, v] : wide) {
      w << stage;
      for (double x : v) {
        if (std::isnan(x)) w << ",?";
        else w << "," << x;
      }
      w << "\n";
    }
  }
  if (std::system("command -v gnuplot > /dev/null 2>&1") == 0) {
    const auto gp = out / "stages.gp";
    std::ofstream(gp) << "set datafile separator ','\nset datafile missing '?'\nset terminal pngcairo size 1100,560 font ',10'\nset output '"
                      << (out / "stages.png").string()
                      << "'\nset termoption noenhanced\nset title 'Per-stage time per scene: median over the four scenarios frames (GPU passes; (cpu): CPU stages)'\n"
                      << "set style data histogram\nset style histogram cluster gap 1\nset style fill solid 0.8\nset logscale y\nset ylabel 'ms'\n"
                      << "set xtics rotate by -30\nset key top left\nset grid ytics\n"
                      << "plot for [i=2:" << scenes.size() + 1 << "] '" << (out / "scenario_stages_wide.csv").string() << "' using i:xtic(1) title columnhead\n";
    if (std::system(("gnuplot " + gp.string() + " 2>/dev/null").c_str()) != 0) std::cerr << "gnuplot failed: no stages chart\n";
  }
}

// Each scenario replayed headless with the simulation on, on each scene: per-stage times and latency.
void replayScenarios(SuiteRun& run, const std::vector<Scene>& scenes) {
  const std::filesystem::path& out = run.out;
  const bool quick = run.quick, smoke = run.smoke;
  std::ofstream& summary = run.summary;
  int& failures = run.failures;
  std::ofstream stages(out / "scenario_stages.csv");
  stages << "scene,scenario,stage,median_ms,p95_ms,frames\n";
  std::map<std::string, std::vector<double>> wide;  // stage -> median per scene over its scenarios' frames (the chart's table)
  std::ofstream latency(out / "latency.csv");  // the distribution per scene: every frame's input-to-present latency, sorted
  latency << "scene,fraction,latency_ms\n";
  std::cout << std::fixed << std::setprecision(2);
  for (std::size_t si = 0; si < scenes.size(); ++si) {
    const Scene& scene = scenes[si];
    std::map<std::string, std::vector<double>> pooled;  // stage -> every frame's value, all scenarios
    for (std::size_t k = 0; k < scene.scripts.size(); ++k) {
      const std::string name = kScenarios[k].first;
      const auto t0 = std::chrono::steady_clock::now();
      const std::string tag = scene.name + "_" + name;
      ReplayOptions o;
      o.script = scene.scripts[k];
      o.volume = scene.volume;
      o.fps = 10;
      o.width = o.height = smoke ? 64 : quick ? 128 : 256;
      o.quiet = true;
      o.timings = (out / "scenarios" / (tag + "_timings.csv")).string();
      o.exportPath = (out / "scenarios" / (tag + "_deformed.nii.gz")).string();
      o.exportDir = (out / "scenarios" / "exports").string();
      if (quick) {
        o.sim.sim.coarseTets = smoke ? 300 : 1500;
        o.sim.sim.fineTets = smoke ? 19200 : 96000;
      }
      try {
        if (runReplay(o) != 0) throw Error("the replay reported an error");
      } catch (const std::exception& e) {
        ++failures;
        summary << "scenario " << name << " on " << scene.name << ": FAILED: " << e.what() << "\n";
        std::cerr << "scenario " << name << " on " << scene.name << " failed: " << e.what() << "\n";
        continue;
      }
      const auto cols = readTimings(o.timings);
      std::cout << scene.name << " / " << name << " (" << since(t0) << " s):";
      for (const auto& [col, v] : cols) {
        std::string stage;
        const bool ms = col.size() > 7 && col.compare(col.size() - 3, 3, "_ms") == 0;
        if (ms && col.rfind("gpu_", 0) == 0) stage = col.substr(4, col.size() - 7);
        else if (ms && col.rfind("cpu_", 0) == 0) stage = col.substr(4, col.size() - 7) + " (cpu)";
        else if (col == "frame_ms" || col == "input_to_present_ms") stage = col.substr(0, col.size() - 3);
        if (stage.empty() || v.empty()) continue;
        stages << scene.name << "," << name << "," << stage << "," << percentile(v, 0.5) << "," << percentile(v, 0.95) << "," << v.size() << "\n";
        pooled[stage].insert(pooled[stage].end(), v.begin(), v.end());
        std::cout << " " << stage << " " << percentile(v, 0.5) << " ms";
      }
      std::cout << "\n";
      if (const auto it = cols.find("input_to_present_ms"); it != cols.end())
        summary << "scenario " << name << " on " << scene.name << ": input-to-present latency p50/p95/p99 " << percentile(it->second, 0.5) << " / "
                << percentile(it->second, 0.95) << " / " << percentile(it->second, 0.99) << " ms (replay waits for the solve to settle each frame); "
                << since(t0) << " s\n";
    }
    for (const auto& [stage, v] : pooled) {
      auto [it, fresh] = wide.try_emplace(stage, scenes.size(), std::nan(""));
      it->second[si] = percentile(v, 0.5);
    }
    if (auto it = pooled.find("input_to_present"); it != pooled.end()) {
      std::vector<double> v = it->second;
      std::sort(v.begin(), v.end());
      for (std::size_t i = 0; i < v.size(); ++i) latency << scene.name << "," << double(i + 1) / double(v.size()) << "," << v[i] << "\n";
    }
    latency << "\n\n";  // a gnuplot data block per scene
  }
  latency.close();
  stages.close();
  writeScenarioCharts(out, scenes, wide);
}

// 2. The component benchmarks, each into its folder; a failure is noted and the suite goes on.
void componentBenchmarks(SuiteRun& run) {
  const std::filesystem::path& out = run.out;
  const bool quick = run.quick, smoke = run.smoke;
  std::ofstream& summary = run.summary;
  int& failures = run.failures;
  const std::string& data = run.data;
  const std::filesystem::path ircadb = std::filesystem::path(data) / "ircadb1.1";
  auto component = [&](const std::string& name, Words w, int (*fn)(const Words&)) {
    std::filesystem::create_directories(out / name);
    const auto t0 = std::chrono::steady_clock::now();
    std::cout << "\n== " << name << "\n";
    int rc = 1;
    try {
      rc = fn(w);
    } catch (const std::exception& e) {
      std::cerr << name << ": " << e.what() << "\n";
    }
    failures += rc != 0;
    summary << name << ": " << (rc == 0 ? "ok" : "FAILED") << ", " << std::setprecision(1) << since(t0) << " s, in " << (out / name).string() << "\n";
  };
  const std::string o = (out / "").string();
  // Each component's arguments: full, --quick, --smoke.
  const auto pick = [&](Words full, Words quickArgs, Words smokeArgs) { return smoke ? smokeArgs : quick ? quickArgs : full; };
  component("raymarch",
            pick({"--voxels", "5000000", "--sizes", "256,512", "--repeat", "5", "--csv", o + "raymarch/raymarch.csv", "--quiet"},
                 {"--voxels", "1000000", "--sizes", "256", "--repeat", "2", "--csv", o + "raymarch/raymarch.csv", "--quiet"},
                 {"--voxels", "250000", "--sizes", "64", "--repeat", "1", "--csv", o + "raymarch/raymarch.csv", "--quiet"}),
            cmdBench);
  component("gesture", pick({"--out", o + "gesture"}, {"--out", o + "gesture", "--cases", "50"}, {"--out", o + "gesture", "--cases", "5", "--quick"}),
            cmdBenchGesture);
  if (std::filesystem::is_directory(data))
    component("selection",
              pick({"--data", data, "--out", o + "selection"}, {"--data", data, "--out", o + "selection", "--repeat", "1"},
                   {"--data", data, "--out", o + "selection", "--repeat", "1", "--extents", "20"}),
              cmdBenchSelection);
  else
    summary << "selection: skipped (no data at " << data << ")\n";
  component("sim",
            pick({"--quiet", "--out", o + "sim"}, {"--coarse-list", "600,1500", "--refine-steps", "2", "--quiet", "--out", o + "sim"},
                 {"--coarse-list", "300", "--fine-per-coarse", "8", "--spacing", "4", "--refine-steps", "1", "--quiet", "--out", o + "sim"}),
            cmdBenchSim);
  if (std::filesystem::exists(ircadb / "labels.nii.gz")) {
    const Words realCt{(ircadb / "ct.nii.gz").string(), "--handle", (ircadb / "labels.nii.gz").string(), "--handle-label", "4", "--quiet", "--out",
                       o + "sim-ircadb1.1"};
    auto with = [&](Words w) {
      w.insert(w.begin(), realCt.begin(), realCt.end());
      return w;
    };
    component("sim-ircadb1.1",
              pick(realCt, with({"--coarse-list", "600", "--refine-steps", "1"}), with({"--coarse-list", "300", "--fine-per-coarse", "8", "--refine-steps", "1"})),
              cmdBenchSim);
  }
  component("deform",
            pick({"--quiet", "--out", o + "deform"}, {"--spacing", "3", "--frames", "5", "--quiet", "--out", o + "deform"},
                 {"--spacing", "6", "--frames", "2", "--coarse-tets", "300", "--fine-tets", "19200", "--quiet", "--out", o + "deform"}),
            cmdBenchDeform);
  component("mesh",
            pick({"--quiet", "--out", o + "mesh"},
                 {"--coarse-tets", "300", "--regular-list", "2,3,4", "--adapted-list", "2,3", "--truth-refinement", "6", "--quiet", "--out", o + "mesh"},
                 {"--coarse-tets", "300", "--regular-list", "2", "--adapted-list", "2", "--truth-refinement", "3", "--spacing", "4", "--quiet", "--out",
                  o + "mesh"}),
            cmdBenchMesh);
  component("stability",
            pick({"--out", o + "stability"}, {"--angles", "30,90,180", "--contrasts", "1,1000,1000000", "--quick", "--out", o + "stability"},
                 {"--angles", "30", "--contrasts", "1000", "--quick", "--out", o + "stability"}),
            cmdBenchStability);
}
}  // namespace

int cmdBenchSuite(const Words& words) {
  Args args(words, {"--out", "--data"}, {"--quick", "--smoke"});
  if (args.help() || !args.positional().empty() || !args.value("--out")) {
    usageStream(args) << kBenchSuiteHelp;
    return args.help() ? 0 : 2;
  }
  const bool smoke = args.flag("--smoke");
  const bool quick = smoke || args.flag("--quick");
  if (smoke && args.flag("--quick")) throw UsageError("--quick and --smoke: choose one");
  SuiteRun run;
  run.out = *args.value("--out");
  run.data = args.valueOr("--data", "../shared/data");
  run.quick = quick;
  run.smoke = smoke;
  std::filesystem::create_directories(run.out / "scenarios");
  run.summary.open(run.out / "summary.txt");
  run.summary << std::fixed << std::setprecision(1);
  run.summary << "handson benchmark suite" << (smoke ? " (--smoke: not measurements)" : quick ? " (--quick)" : "") << "\n";
  replayScenarios(run, prepareScenes(run));
  componentBenchmarks(run);

  run.summary.close();
  std::cout << "\nwrote " << (run.out / "summary.txt").string() << ", scenario_stages.csv, stages.png and the component folders in " << run.out.string()
            << (run.failures ? " (" + std::to_string(run.failures) + " failed)" : "") << "\n";
  return run.failures ? 1 : 0;
}

}  // namespace handson::cli
