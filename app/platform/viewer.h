#pragma once
// The interactive viewer: an SDL2 window with a Vulkan swapchain presenting the frame graph's
// output, native multi-touch and the mouse fallback, the touch UI, recording and the latency log.
#include <cstdint>
#include <array>
#include <memory>
#include <string>

#include "app/session/deformation_controller.h"
#include "app/session/selection_backend.h"
#include "interaction/region_grow.h"
#include "interaction/selection_edit.h"
#include "interaction/touch.h"

struct SDL_Window;

namespace handson {

struct ViewerOptions {
  std::string path;  ///< volume (empty: the built-in phantom)
  std::int64_t frame = 0;  ///< the volume of a 4D NIfTI image
  int width = 1280, height = 800;
  std::string presentMode = "fifo";
  int frames = 0;           ///< 0: until the window is closed
  std::string screenshot;   ///< PNG of the last presented frame (UI included)
  std::string record;       ///< session script of what the user did
  std::string exportDir = "handson-export";  ///< where the Export button writes (app/session/session_export.h)
  std::string exportExtension = ".nii.gz";  ///< the Export button's volumes: ".nii.gz", ".nrrd" or ".mha"
  std::string play;         ///< a session script fed in as live input, in real time (latency studies)
  int playRepeat = 1;       ///< times to play it
  /// A played script's clock stops while the simulation of its handles builds, as a user waits for
  /// the handle panel's "building" to end before dragging (replay waits likewise); false: every
  /// event at its recorded time, a drag then landing before the model exists.
  bool playWaitsForSimulation = true;
  std::string timings;      ///< latency log CSV
  std::string preset;       ///< empty: by the volume's values
  std::string labels;       ///< organ labels for taps in select mode (empty: none)
  SelectionBackend selectionBackend = SelectionBackend::Auto;  ///< where pinches grow (app/session/selection_backend.h)
  bool selectionRim = true;  ///< finished pinches end with their boundary rim (GrowParams::boundaryRim)
  GrowBound selectionBound = GrowParams{}.bound;  ///< how the fingers' extent bounds growth (GrowParams::bound)
  CorrectionRule selectionCorrections = CorrectionRule::Neck;  ///< handle-union and handle-difference (interaction/selection_edit.h)
  std::string device;
  bool validation = false;
  int framesInFlight = 2;   ///< 1 lowers latency, 2 keeps the GPU busy while the CPU records
  double renderScale = 0.0; ///< raymarch resolution / window resolution; 0: 1 on a GPU, 0.5 on a CPU device
  double frameBudgetMs = 33.0;  ///< GPU time a changing frame may take (app/session/frame_budget.h); 0: off
  bool printCamera = false; ///< print the final camera (tests, scripting)
  bool quiet = false;
  DeformationOptions sim;   ///< the simulation of moved handles (solved asynchronously)
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
