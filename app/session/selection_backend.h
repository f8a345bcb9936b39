#pragma once
// Where the app grows a pinch's selection (`--selection-backend auto|gpu|cpu` on view and replay):
// the GPU pass inside the renderer's frames (render/live_selection.h: rounds spread over frames,
// the live selection painted into the handle-id mask on the GPU, the voxels read back once when the
// pinch ends) or the CPU reference (interaction/region_grow.h). Both select the same voxels.
// Auto takes the GPU on a GPU device and the CPU on a CPU device (lavapipe), where the CPU search
// was measured faster (docs/region-growing.md, "Growth in the app").
#include <cstdint>
#include <string>

namespace handson {

enum class SelectionBackend : std::uint8_t { Auto, Gpu, Cpu };
bool parseSelectionBackend(const std::string& text, SelectionBackend& out);
const char* selectionBackendName(SelectionBackend b);

/// What `requested` becomes on a device (Gpu or Cpu), and a line for the UI's status saying why.
struct SelectionBackendChoice {
  SelectionBackend backend = SelectionBackend::Cpu;
  std::string status;
};
SelectionBackendChoice resolveSelectionBackend(SelectionBackend requested, bool cpuDevice, const std::string& deviceName);

}  // namespace handson
