#include "soak.h"

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <limits>
#include <iostream>
#include <sstream>
#include <vector>

#include "app/session/console.h"
#include "app/session/replay.h"
#include "render/vk_resources.h"
#include "scripts/scenario_kidney_translate_two_fingers.h"
#include "sim/base/error.h"

namespace handson {

namespace {

constexpr double kCycleSeconds = 4.0;

double residentBytes() {
  std::ifstream in("/proc/self/statm");
  double size = 0, resident = 0;
  if (!(in >> size >> resident)) return 0.0;
  return resident * double(sysconf(_SC_PAGESIZE));
}

struct Sample {
  int frame = 0;
  double rssMiB = 0, vkMiB = 0;
  std::int64_t vkAllocations = 0;
  std::uint64_t validation = 0;
};

}  // namespace

SessionScript soakScript(int frames, double fps) {
  if (frames < 1 || !(fps > 0.0)) throw Error("soak: frames and fps must be positive");
  // The selection of the scenario "kidney-translate-two-fingers": its pinch and the switch to
  // manipulate mode (everything before its drag).
  SessionScript s = parseSessionScript(kScenario_kidney_translate_two_fingers, "kidney-translate-two-fingers.json");
  s.events.erase(std::remove_if(s.events.begin(), s.events.end(), [](const ScriptEvent& e) { return e.t >= 1.0; }), s.events.end());
  std::int64_t id = 100;
  double t = 0.0;
  auto ui = [&](double at, UiAction action, const std::string& value = "") { s.events.push_back(uiEvent(at, action, value)); };
  auto touch = [&](double at, TouchPhase phase, std::int64_t finger, double x, double y) {
    s.events.push_back(touchEvent(at, phase, finger, {x, y}));
  };
  // Fingers put down at `at`, moved `steps` times by (dx, dy) each 0.05 s (and, with `back`, as many
  // steps back to where they came down), lifted 0.05 s later. Returns the time of the lift.
  auto stroke = [&](double at, std::vector<glm::dvec2> fingers, const std::vector<glm::dvec2>& step, int steps, bool back) {
    std::vector<std::int64_t> ids;
    for (const auto& p : fingers) {
      ids.push_back(++id);
      touch(at, TouchPhase::Down, ids.back(), p.x, p.y);
    }
    const int moves = back ? 2 * steps : steps;
    for (int k = 1; k <= moves; ++k)
      for (std::size_t f = 0; f < fingers.size(); ++f) {
        fingers[f] += k <= steps ? step[f] : -step[f];
        touch(at + 0.05 * k, TouchPhase::Move, ids[f], fingers[f].x, fingers[f].y);
      }
    const double lift = at + 0.05 * (moves + 1);
    for (std::size_t f = 0; f < fingers.size(); ++f) touch(lift, TouchPhase::Up, ids[f], fingers[f].x, fingers[f].y);
    return lift;
  };
  const double needed = (frames + 1) / fps;
  for (t = 1.0; t < needed; t += kCycleSeconds) {
    // The kidney dragged 20 px forward with two fingers, then the drag undone, redone and undone:
    // the handle is back exactly where it was (a gesture is one undo step). The same with one
    // finger, 12 px down. Every cycle solves the same poses again, from the same state.
    double at = stroke(t, {{192, 262}, {212, 262}}, {{2, 0}, {2, 0}}, 10, false);  // lifted at t + 0.55
    ui(at + 0.1, UiAction::Undo);
    ui(at + 0.2, UiAction::Redo);
    ui(at + 0.3, UiAction::Undo);
    at = stroke(at + 0.4, {{202, 266}}, {{0, 2}}, 6, false);  // t + 1.3
    ui(at + 0.1, UiAction::Undo);
    // A tap on it in select mode (picked), then the view orbited 40 px and back, zoomed and back.
    ui(at + 0.2, UiAction::SetMode, "select");
    touch(at + 0.3, TouchPhase::Down, ++id, 202, 270);
    touch(at + 0.35, TouchPhase::Up, id, 202, 270);
    ui(at + 0.45, UiAction::SetMode, "navigate");
    at = stroke(at + 0.5, {{100, 450}}, {{5, 0}}, 8, true);                     // t + 2.65
    at = stroke(at + 0.1, {{200, 100}, {260, 100}}, {{-3, 0}, {3, 0}}, 4, true);  // t + 3.2
    ui(t + 3.9, UiAction::SetMode, "manipulate");
  }
  std::stable_sort(s.events.begin(), s.events.end(), [](const ScriptEvent& a, const ScriptEvent& b) { return a.t < b.t; });
  return s;
}

namespace {

// The soak's replay: the script, the size, the simulation; quiet, the handles printed at the end.
ReplayOptions soakReplayOptions(const SoakOptions& o, const std::filesystem::path& out) {
  ReplayOptions r;
  r.scriptData = soakScript(o.frames, o.fps);
  r.frames = o.frames;
  r.fps = o.fps;
  r.width = o.width;
  r.height = o.height;
  r.device = o.device;
  r.validation = o.validation;
  r.quiet = true;
  r.printHandles = true;
  r.exportDir = (out / "recovery").string();
  r.sim = o.sim;
  return r;
}

// Every frame's memory and validation count, and the CSV's rows: a row every `sampleEvery` frames
// with the largest values since the previous row, so a transient peak between rows is never missed.
struct SoakSamples {
  std::vector<Sample> frames, rows;
  void add(const Sample& s, int sampleEvery, bool last) {
    frames.push_back(s);
    if (s.frame % sampleEvery != 0 && !last) return;
    Sample row = frames.back();
    for (std::size_t i = frames.size() - std::min<std::size_t>(frames.size(), std::size_t(sampleEvery)); i < frames.size(); ++i) {
      row.rssMiB = std::max(row.rssMiB, frames[i].rssMiB);
      row.vkMiB = std::max(row.vkMiB, frames[i].vkMiB);
      row.vkAllocations = std::max(row.vkAllocations, frames[i].vkAllocations);
    }
    rows.push_back(row);
  }
};

// The largest values over the frames [from, to).
Sample largestOver(const std::vector<Sample>& frames, int from, int to) {
  Sample m{from, 0, 0, 0, 0};
  for (const Sample& f : frames) {
    if (f.frame < from || f.frame >= to) continue;
    m.rssMiB = std::max(m.rssMiB, f.rssMiB);
    m.vkMiB = std::max(m.vkMiB, f.vkMiB);
    m.vkAllocations = std::max(m.vkAllocations, f.vkAllocations);
  }
  return m;
}

// Growth of the peak over the baseline (a quantity that starts at zero and appears counts as 100 %).
double growth(double peakValue, double baseValue) { return baseValue > 0 ? peakValue / baseValue - 1.0 : (peakValue > 0 ? 1.0 : 0.0); }

// What the soak found: the warm-up's last cycle against everything after it.
struct SoakVerdict {
  int warmup = 0, cycleFrames = 0;
  Sample base, peak;
  double rss = 0, vk = 0, allocations = 0;  ///< growths
  std::uint64_t validation = 0;
};

void writeSoakCsv(const std::filesystem::path& out, const std::vector<Sample>& rows) {
  std::ofstream csv(out / "soak.csv");
  csv << "frame,resident_mib,vulkan_live_allocations,vulkan_live_mib,validation_messages\n" << std::fixed << std::setprecision(3);
  for (const Sample& s : rows) csv << s.frame << "," << s.rssMiB << "," << s.vkAllocations << "," << s.vkMiB << "," << s.validation << "\n";
}

void printVerdict(const SoakOptions& o, const SoakSamples& samples, const SoakVerdict& v, const std::filesystem::path& out) {
  const std::vector<Sample>& frames = samples.frames;
  std::cout << std::fixed << std::setprecision(1) << "soak: " << o.frames << " frames at " << o.width << "x" << o.height
            << (o.sim.enabled ? ", simulation on" : ", simulation off") << "; baseline: the largest values over frames "
            << v.warmup - v.cycleFrames << ".." << v.warmup - 1 << " (the warm-up's last cycle), against the largest after\n"
            << "  resident memory: " << v.base.rssMiB << " MiB at the baseline, at most " << v.peak.rssMiB << " MiB after (" << std::showpos
            << 100.0 * v.rss << std::noshowpos << " %); " << frames.front().rssMiB << " MiB at frame 0, " << frames.back().rssMiB
            << " MiB at the end\n"
            << "  Vulkan device memory: " << v.base.vkAllocations << " live allocations, " << v.base.vkMiB << " MiB at the baseline; at most "
            << v.peak.vkAllocations << " and " << v.peak.vkMiB << " MiB after (" << std::showpos << 100.0 * v.allocations << " %, " << 100.0 * v.vk
            << std::noshowpos << " %)\n"
            << "  validation messages: " << v.validation << "\n"
            << "wrote " << (out / "soak.csv").string();
}

// soak.png beside the CSV, where gnuplot is installed.
void chartSoak(const SoakOptions& o, const SoakVerdict& v, const std::filesystem::path& out) {
  if (std::system("command -v gnuplot > /dev/null 2>&1") != 0) return;
  const auto gp = out / "soak.gp";
  std::ofstream(gp) << "set datafile separator ','\nset terminal pngcairo size 900,520 font ',11'\nset output '" << (out / "soak.png").string()
                    << "'\nset termoption noenhanced\nset title 'Soak: " << o.frames << " frames (" << o.width << "x" << o.height
                    << (o.sim.enabled ? ", simulation on" : "") << ")'\nset xlabel 'frame'\nset ylabel 'MiB'\nset y2label 'live Vulkan allocations'\n"
                    << "set ytics nomirror\nset y2tics\nset yrange [0:*]\nset y2range [0:"
                    << std::max<std::int64_t>({4, v.base.vkAllocations * 5 / 4, v.peak.vkAllocations * 5 / 4}) << "]\nset grid\nset key bottom right\n"
                    << "set arrow from " << v.warmup << ", graph 0 to " << v.warmup << ", graph 1 nohead dt 2\n"
                    << "plot '" << (out / "soak.csv").string() << "' every ::1 using 1:2 with lines lw 2 title 'resident memory (MiB)', "
                    << "'' every ::1 using 1:4 with lines lw 2 title 'Vulkan device memory (MiB)', "
                    << "'' every ::1 using 1:3 axes x1y2 with steps title 'live Vulkan allocations'\n";
  if (std::system(("gnuplot " + gp.string() + " 2>/dev/null").c_str()) == 0) std::cout << " and " << (out / "soak.png").string();
}

bool withinTolerance(const SoakOptions& o, const SoakVerdict& v) {
  bool ok = true;
  auto fail = [&](const std::string& what, double g) {
    std::cerr << "error: " << what << " grew by " << std::fixed << std::setprecision(1) << 100.0 * g << " % after the warm-up (allowed "
              << 100.0 * o.tolerance << " %)\n";
    ok = false;
  };
  if (v.rss > o.tolerance) fail("resident memory", v.rss);
  if (v.vk > o.tolerance) fail("Vulkan device memory", v.vk);
  if (v.allocations > o.tolerance) fail("the number of live Vulkan allocations", v.allocations);
  if (v.validation > 0) {
    std::cerr << "error: " << v.validation << " Vulkan validation message(s)\n";
    ok = false;
  }
  return ok;
}

}  // namespace

int runSoak(const SoakOptions& o) {
  if (o.frames < 10 || o.frames > 10'000'000) throw Error("soak: --frames must be in 10..10000000");
  if (o.sampleEvery < 1) throw Error("soak: the sampling interval must be at least one frame");
  if (!(o.warmupFraction >= 0.0 && o.warmupFraction < 1.0)) throw Error("soak: the warm-up fraction must be in [0, 1)");
  const std::filesystem::path out(o.outDir);
  std::error_code ec;
  std::filesystem::create_directories(out, ec);
  if (!std::filesystem::is_directory(out)) throw Error("soak: cannot create the output directory '" + o.outDir + "'");

  // Every frame is measured (a read of /proc/self/statm and of the allocation registry).
  ReplayOptions r = soakReplayOptions(o, out);
  SoakSamples samples;
  const ProgressFn progress = o.quiet ? ProgressFn{} : consoleProgress();
  r.afterFrame = [&](int k, int count, std::uint64_t validation) {
    const vk::DeviceMemoryStats vm = vk::deviceMemoryStats();
    samples.add({k, residentBytes() / double(1u << 20), double(vm.liveBytes) / double(1u << 20), vm.liveAllocations, validation}, o.sampleEvery, k == count - 1);
    reportProgress(progress, double(k + 1) / count, "soak");
  };
  const int replayStatus = runReplay(r);

  // The baseline: the largest values over the last cycle of the warm-up (at least two cycles: the
  // simulation built, the undo history and the caches filled), against the largest after it. A
  // cycle's own peaks (a rebuilt simulation region, a pick's readback) are in both.
  SoakVerdict v;
  v.cycleFrames = int(std::ceil(kCycleSeconds * o.fps));
  v.warmup = std::max(int(o.warmupFraction * o.frames), 2 * v.cycleFrames);
  writeSoakCsv(out, samples.rows);
  if (int(samples.frames.size()) < v.warmup + v.cycleFrames)
    throw Error("soak: too few frames after the warm-up (" + std::to_string(v.warmup) + " frames) to judge growth: at least one more cycle (" +
                std::to_string(v.cycleFrames) + " frames) is needed");
  v.base = largestOver(samples.frames, v.warmup - v.cycleFrames, v.warmup);
  v.peak = largestOver(samples.frames, v.warmup, std::numeric_limits<int>::max());
  v.base.frame = v.peak.frame = v.warmup;
  v.rss = growth(v.peak.rssMiB, v.base.rssMiB);
  v.vk = growth(v.peak.vkMiB, v.base.vkMiB);
  v.allocations = growth(double(v.peak.vkAllocations), double(v.base.vkAllocations));
  v.validation = samples.frames.back().validation;
  printVerdict(o, samples, v, out);
  chartSoak(o, v, out);
  std::cout << "\n";
  const bool ok = withinTolerance(o, v);
  return replayStatus == 0 && ok ? 0 : 1;
}

}  // namespace handson
