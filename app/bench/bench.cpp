// `handson bench`: raymarch throughput with and without empty-space skipping and early ray
// termination, measured in the same run so the ratio holds on a shared, noisy machine.
#include <algorithm>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>

#include "app/bench/bench.h"
#include "app/cli/args.h"
#include "app/cli/headless_scene.h"
#include "sim/base/error.h"

namespace handson::cli {

double median(std::vector<double> v) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  return v.size() % 2 ? v[v.size() / 2] : 0.5 * (v[v.size() / 2 - 1] + v[v.size() / 2]);
}

namespace {

struct Sample {
  double wallMs, gpuMs;
};

Sample measure(HeadlessScene& scene, int repeat) {
  std::vector<double> wall, gpu;
  for (int i = 0; i < repeat + 1; ++i) {  // first frame warms up
    FrameRequest req;
    req.params = scene.params();
    req.readbackImage = false;
    const auto t0 = std::chrono::steady_clock::now();
    scene.renderer->submit(req);
    const FrameResult r = scene.renderer->waitLast();
    const auto t1 = std::chrono::steady_clock::now();
    if (i == 0) continue;
    wall.push_back(std::chrono::duration<double, std::milli>(t1 - t0).count());
    for (const auto& t : r.timings)
      if (t.id == PassId::Raymarch) gpu.push_back(t.gpuMs);
  }
  return {median(wall), median(gpu)};
}

}  // namespace

namespace {
int benchRaymarch(const Words& words);
}  // namespace

int cmdBench(const Words& words) {
  if (!words.empty() && words[0] == "selection") return cmdBenchSelection(Words(words.begin() + 1, words.end()));
  if (!words.empty() && words[0] == "gesture") return cmdBenchGesture(Words(words.begin() + 1, words.end()));
  if (!words.empty() && words[0] == "sim") return cmdBenchSim(Words(words.begin() + 1, words.end()));
  if (!words.empty() && words[0] == "deform") return cmdBenchDeform(Words(words.begin() + 1, words.end()));
  if (!words.empty() && words[0] == "mesh") return cmdBenchMesh(Words(words.begin() + 1, words.end()));
  if (!words.empty() && words[0] == "stability") return cmdBenchStability(Words(words.begin() + 1, words.end()));
  if (!words.empty() && words[0] == "tissue") return cmdBenchTissue(Words(words.begin() + 1, words.end()));
  if (!words.empty() && words[0] == "cut") return cmdBenchCut(Words(words.begin() + 1, words.end()));
  if (!words.empty() && words[0] == "hyperelastic") return cmdBenchHyperelastic(Words(words.begin() + 1, words.end()));
  if (!words.empty() && words[0] == "visibility") return cmdBenchVisibility(Words(words.begin() + 1, words.end()));
  if (!words.empty() && words[0] == "raymarch") return benchRaymarch(Words(words.begin() + 1, words.end()));
  // The suite: `handson bench --out DIR [--quick]` (the raymarch benchmark writes --csv, not --out).
  if (std::find(words.begin(), words.end(), "--out") != words.end() || std::find(words.begin(), words.end(), "--quick") != words.end())
    return cmdBenchSuite(words);
  return benchRaymarch(words);
}

namespace {
int benchRaymarch(const Words& words) {
  std::vector<std::string> valueOptions = kRenderValueOptions;
  valueOptions.insert(valueOptions.end(), {"--sizes", "--repeat", "--csv"});
  Args args(words, valueOptions, kRenderFlagOptions);
  if (args.help() || args.positional().size() > 1) {
    usageStream(args) << "usage: handson bench [raymarch] [PATH] [--voxels N] [--sizes 256,512] [--repeat N] [--csv OUT.csv] [options]\n"
                 "  Raymarch time (median of N frames, GPU timestamps and wall clock) at each size, plain\n"
                 "  versus empty-space skipping + early ray termination, and their ratio. PATH omitted: the\n"
                 "  built-in phantom. For the paper-scale case: ../shared/data/ircadb1.1/ct.nii.gz --voxels 5000000.\n"
                 "  The whole benchmark suite: handson bench --out DIR [--quick] (--help with it for more).\n"
              << kRenderOptionsHelp << "  'handson bench selection --help': region growing; 'handson bench gesture --help': the gesture solve;\n  'handson bench sim --help': the simulation (coarse model against the fine reference);\n  'handson bench deform --help': the GPU deformation passes (moved-box vs whole-volume resampling).\n";
    return args.help() ? 0 : 2;
  }
  const int repeat = int(args.integer("--repeat", 5, 1, 1000));
  std::vector<int> sizes;
  for (double s : parseNumberList(args.valueOr("--sizes", "256,512"), "--sizes")) {
    if (s < 16 || s > 8192 || s != std::floor(s)) throw UsageError("--sizes: each size must be an integer in 16..8192");
    sizes.push_back(int(s));
  }
  HeadlessScene scene = openHeadlessScene(args.positional().empty() ? "" : args.positional()[0], args);
  std::cout << "device: " << scene.context->summary().name << " (" << vk::deviceTypeName(scene.context->summary().type) << ")\n"
            << "volume: " << scene.source << ", " << scene.volume.dims().x() << "x" << scene.volume.dims().y() << "x" << scene.volume.dims().z()
            << " = " << scene.volume.voxelCount() << " voxels; transfer function " << scene.tf.name << "\n";
  std::ofstream csv;
  if (auto path = args.value("--csv")) {
    csv.open(*path);
    if (!csv) throw Error("cannot write '" + *path + "'");
    csv << "size,mode,wall_ms,gpu_ms\n";
  }
  std::cout << std::fixed << std::setprecision(1);
  std::cout << "size      plain gpu ms  skip+ert gpu ms  plain wall ms  skip+ert wall ms  speedup (gpu)\n";
  for (int size : sizes) {
    scene.settings.width = scene.settings.height = size;
    scene.settings.emptySpaceSkipping = false;
    scene.settings.earlyTermination = false;
    const Sample plain = measure(scene, repeat);
    scene.settings.emptySpaceSkipping = true;
    scene.settings.earlyTermination = true;
    const Sample fast = measure(scene, repeat);
    const double ratio = fast.gpuMs > 0 ? plain.gpuMs / fast.gpuMs : plain.wallMs / fast.wallMs;
    std::cout << std::setw(4) << size << "²   " << std::setw(12) << plain.gpuMs << "  " << std::setw(15) << fast.gpuMs << "  " << std::setw(13)
              << plain.wallMs << "  " << std::setw(16) << fast.wallMs << "  " << std::setw(12) << std::setprecision(2) << ratio << "x\n"
              << std::setprecision(1);
    if (csv) {
      csv << size << ",plain," << plain.wallMs << "," << plain.gpuMs << "\n";
      csv << size << ",skip+ert," << fast.wallMs << "," << fast.gpuMs << "\n";
    }
  }
  return scene.context->validationMessageCount() > 0 ? 1 : 0;
}

}  // namespace

}  // namespace handson::cli
