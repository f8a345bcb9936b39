#pragma once
// The interactive viewer: an SDL2 window with a Vulkan swapchain presenting the frame graph's
// output, native multi-touch and the mouse fallback, the touch UI, recording and the latency log.
#include <cstdint>
#include <array>
#include <memory>
#include <string>

#include "app/session/session_options.h"
#include "interaction/touch.h"

struct SDL_Window;

namespace handson {

/// The window's options: the session's (app/session/session_options.h; `volume` empty: the
/// built-in phantom, `frames` 0: until the window is closed) and its own.
struct ViewerOptions : SessionOptions {
  int width = 1280, height = 800;
  std::string presentMode = "fifo";
  std::string screenshot;   ///< PNG of the last presented frame (UI included)
  std::string record;       ///< session script of what the user did
  std::string play;         ///< a session script fed in as live input, in real time (latency studies)
  int playRepeat = 1;       ///< times to play it
  /// A played script's clock stops while the simulation of its handles builds, as a user waits for
  /// the handle panel's "building" to end before dragging (replay waits likewise); false: every
  /// event at its recorded time, a drag then landing before the model exists.
  bool playWaitsForSimulation = true;
  std::string preset;       ///< empty: by the volume's values
  int framesInFlight = 2;   ///< 1 lowers latency, 2 keeps the GPU busy while the CPU records
  double renderScale = 0.0; ///< raymarch resolution / window resolution; 0: 1 on a GPU, 0.5 on a CPU device
  double frameBudgetMs = 33.0;  ///< GPU time a changing frame may take (app/session/frame_budget.h); 0: off
  ViewerOptions() { sim.refineSteps = 2; }  ///< a held pose refined toward the fine answer (a replay: 0, waited for)
};

/// True if a window can be opened (a display is available to SDL).
bool displayAvailable();

class Session;

/// The viewer, one frame at a time (tests drive it by pushing SDL events between steps).
class Viewer {
 public:
  /// Opens the window, the device and the scene. Throws handson::Error on failure.
  explicit Viewer(const ViewerOptions& options);
  ~Viewer();
  /// Handles pending events and renders and presents one frame; false once the app should stop.
  bool step();
  /// Writes the screenshot, recording and timing log; returns the exit status.
  int finish();
  Session& session();
  /// The handles the session has made (selections, their status and poses).
  const HandleSet& handles() const;
  std::uint64_t frames() const;
  SDL_Window* window() const;
  /// The UI's panels as last drawn (drawable pixels x0, y0, x1, y1) and the drawable size.
  std::vector<std::array<double, 4>> uiPanels() const;
  Viewport drawableSize() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// Runs the viewer until it is closed (or --frames); returns the exit status.
int runViewer(const ViewerOptions& options);

}  // namespace handson
