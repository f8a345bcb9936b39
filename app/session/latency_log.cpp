#include "latency_log.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <iomanip>
#include <set>
#include <sstream>

#include "sim/base/atomic_file.h"
#include "sim/base/error.h"

namespace handson {

double percentile(std::vector<double> v, double p) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  const std::size_t rank = std::size_t(std::ceil(std::clamp(p, 0.0, 1.0) * double(v.size())));
  return v[std::min(v.size() - 1, rank == 0 ? 0 : rank - 1)];
}

void LatencyLog::setGpuTimes(std::uint64_t frame, const std::vector<std::pair<std::string, double>>& passes) {
  for (auto it = frames_.rbegin(); it != frames_.rend(); ++it)
    if (it->frame == frame) {
      it->gpuMs = passes;
      return;
    }
}

double LatencyLog::setDisplayed(std::uint64_t frame, double t) {
  for (auto it = frames_.rbegin(); it != frames_.rend(); ++it)
    if (it->frame == frame) {
      it->displayed = t;
      return it->displayLatencyMs();
    }
  return -1.0;
}

void LatencyLog::writeCsv(const std::string& path) const {
  std::set<std::string> passNames, stageNames;
  std::set<int> handleIds;
  for (const auto& f : frames_) {
    for (const auto& [name, ms] : f.gpuMs) passNames.insert(name);
    for (const auto& [name, ms] : f.cpuMs) stageNames.insert(name);
    for (const auto& [id, r] : f.reactions) handleIds.insert(id);
  }
  // -1: no value that frame.
  auto valueOf = [](const std::vector<std::pair<std::string, double>>& v, const std::string& n) {
    for (const auto& [name, ms] : v)
      if (name == n) return ms;
    return -1.0;
  };
  AtomicFile file(path);
  {
    std::ofstream out(file.tempPath());
    for (const auto& note : notes_) out << "# " << note << "\n";
    out << "frame,input_count,input_first_s,input_last_s,cpu_start_s,cpu_end_s,submit_s,present_s,displayed_s,frame_ms,input_to_submit_ms,"
           "input_to_present_ms,input_to_display_ms,wait_ms";
    for (const auto& n : passNames) out << ",gpu_" << n << "_ms";
    for (const auto& n : stageNames) out << ",cpu_" << n << "_ms";
    out << ",sim_state,sim_state_s,quality_scale,quality_step,still_phases";
    // Each simulated handle's reaction (empty fields on frames without it).
    for (int id : handleIds)
      for (const char* q : {"force_x_N", "force_y_N", "force_z_N", "torque_x_Nmm", "torque_y_Nmm", "torque_z_Nmm"}) out << ",handle" << id << "_" << q;
    out << "\n" << std::fixed << std::setprecision(6);
    for (const auto& f : frames_) {
      out << f.frame << "," << f.inputCount << "," << f.inputFirst << "," << f.inputLast << "," << f.cpuStart << "," << f.cpuEnd << ","
          << f.submit << "," << f.present << "," << f.displayed << "," << f.frameMs() << "," << f.submitLatencyMs() << "," << f.latencyMs() << "," << f.displayLatencyMs()
          << "," << f.waitMs;
      for (const auto& n : passNames) out << "," << valueOf(f.gpuMs, n);
      for (const auto& n : stageNames) out << "," << valueOf(f.cpuMs, n);
      out << "," << (f.simState.empty() ? "off" : f.simState) << "," << f.simStateS << "," << f.qualityScale << "," << f.qualityStep << "," << f.stillPhases;
      for (int id : handleIds) {
        const auto it = std::find_if(f.reactions.begin(), f.reactions.end(), [&](const auto& p) { return p.first == id; });
        for (int i = 0; i < 6; ++i) {
          out << ",";
          if (it != f.reactions.end()) out << (i < 3 ? it->second.forceN[i] : it->second.torqueNmm[i - 3]);
        }
      }
      out << "\n";
    }
    if (!out) throw Error("cannot write '" + path + "'");
  }
  file.commit();
}

std::string LatencyLog::summary() const {
  std::vector<double> frame, latency, display;
  double wait = 0.0, total = 0.0;
  for (const auto& f : frames_) {
    frame.push_back(f.frameMs());
    if (f.latencyMs() >= 0.0) latency.push_back(f.latencyMs());
    if (f.displayLatencyMs() >= 0.0) display.push_back(f.displayLatencyMs());
    wait += f.waitMs;
    total += f.frameMs();
  }
  std::ostringstream s;
  s << std::fixed << std::setprecision(1);
  s << frames_.size() << " frames; frame time median " << percentile(frame, 0.5) << " ms, p95 " << percentile(frame, 0.95) << " ms, p99 "
    << percentile(frame, 0.99) << " ms";
  if (!latency.empty())
    s << "; input-to-present latency (" << latency.size() << " frames with input) median " << percentile(latency, 0.5) << " ms, p95 "
      << percentile(latency, 0.95) << " ms, p99 " << percentile(latency, 0.99) << " ms";
  if (!display.empty())
    s << "; input-to-display latency (" << display.size() << " frames) median " << percentile(display, 0.5) << " ms, p95 "
      << percentile(display, 0.95) << " ms, p99 " << percentile(display, 0.99) << " ms";
  if (total > 0.0) s << "; waiting " << std::setprecision(1) << 100.0 * wait / total << " % of frame time";
  return s.str();
}

}  // namespace handson
