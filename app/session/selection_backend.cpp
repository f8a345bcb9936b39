#include "selection_backend.h"

namespace handson {

bool parseSelectionBackend(const std::string& text, SelectionBackend& out) {
  if (text == "auto") out = SelectionBackend::Auto;
  else if (text == "gpu") out = SelectionBackend::Gpu;
  else if (text == "cpu") out = SelectionBackend::Cpu;
  else return false;
  return true;
}

const char* selectionBackendName(SelectionBackend b) {
  switch (b) {
    case SelectionBackend::Auto: return "auto";
    case SelectionBackend::Gpu: return "gpu";
    case SelectionBackend::Cpu: return "cpu";
  }
  return "?";
}

SelectionBackendChoice resolveSelectionBackend(SelectionBackend requested, bool cpuDevice, const std::string& deviceName) {
  switch (requested) {
    case SelectionBackend::Gpu: return {SelectionBackend::Gpu, "selection grows on the GPU (" + deviceName + "; --selection-backend gpu)"};
    case SelectionBackend::Cpu: return {SelectionBackend::Cpu, "selection grows on the CPU (--selection-backend cpu)"};
    case SelectionBackend::Auto: break;
  }
  if (cpuDevice)
    return {SelectionBackend::Cpu, "selection grows on the CPU (auto: " + deviceName + " is a CPU device, where the CPU search is faster)"};
  return {SelectionBackend::Gpu, "selection grows on the GPU (auto: " + deviceName + ")"};
}

}  // namespace handson
