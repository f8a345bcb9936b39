#include "latency_log.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <iomanip>
#include <set>
#include <sstream>

#include "app/atomic_file.h"
#include "sim/error.h"

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

void LatencyLog::writeCsv(const std::string& path) const {
  std::set<std::string> passNames, stageNames;
  for (const auto& f : frames_) {
    for (const auto& [name, ms] : f.gpuMs) passNames.insert(name);
    for (const auto& [name, ms] : f.cpuMs) stageNames.insert(name);
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
    out << "frame,input_count,input_first_s,input_last_s,cpu_start_s,cpu_end_s,submit_s,present_s,frame_ms,input_to_present_ms,wait_ms";
    for (const auto& n : passNames) out << ",gpu_" << n << "_ms";
    for (const auto& n : stageNames) out << ",cpu_" << n << "_ms";
    out << ",sim_state,sim_state_s\n" << std::fixed << std::setprecision(6);
    for (const auto& f : frames_) {
      out << f.frame << "," << f.inputCount << "," << f.inputFirst << "," << f.inputLast << "," << f.cpuStart << "," << f.cpuEnd << ","
          << f.submit << "," << f.present << "," << f.frameMs() << "," << f.latencyMs() << "," << f.waitMs;
      for (const auto& n : passNames) out << "," << valueOf(f.gpuMs, n);
      for (const auto& n : stageNames) out << "," << valueOf(f.cpuMs, n);
      out << "," << (f.simState.empty() ? "off" : f.simState) << "," << f.simStateS << "\n";
    }
    if (!out) throw Error("cannot write '" + path + "'");
  }
  file.commit();
}

std::string LatencyLog::summary() const {
  std::vector<double> frame, latency;
  double wait = 0.0, total = 0.0;
  for (const auto& f : frames_) {
    frame.push_back(f.frameMs());
    if (f.latencyMs() >= 0.0) latency.push_back(f.latencyMs());
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
  if (total > 0.0) s << "; waiting " << std::setprecision(1) << 100.0 * wait / total << " % of frame time";
  return s.str();
}

}  // namespace handson
