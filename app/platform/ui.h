#pragma once
// The touch UI (Dear ImGui, Debian's libimgui-dev with its SDL2 and Vulkan backends): a mode bar,
// transfer-function presets, a frame-time overlay and the handle list. Every target is at least
// 48 px at 100 % scale and grows with the display scale; text and spacing shrink with a small
// window (down to 0.7 below an 800-point shorter side). The panels fold: the view's actions behind
// "More", the presets behind their header, the overlay's details behind "Info" — folded by default
// in a small window, so that the panels leave the picture (docs/touch-app.md, "The panels"). UI
// actions come out as script events, so they are recorded and replayed like touches; folding is
// the view's own and is not recorded.
#include <SDL2/SDL.h>
#include <imgui.h>
#include <vulkan/vulkan.h>

#include <array>
#include <functional>
#include <string>
#include <vector>

#include "app/session/session_script.h"
#include "interaction/view_adjust.h"

namespace handson {
namespace vk {
class Context;
class Swapchain;
}  // namespace vk

struct UiStatus {
  std::string mode, preset, device;
  double cpuFrameMs = 0, gpuRaymarchMs = 0, latencyMs = -1, fps = 0;
  double displayLatencyMs = -1;  ///< input to shown on screen, where the driver can say (VK_KHR_present_wait)
  int fingers = 0;
  int renderWidth = 0, renderHeight = 0;
  double qualityScale = 1.0, qualityStep = 1.0;  ///< the frame budget's resolution and step scale (1, 1: full quality)
  int stillPhases = 0, stillPhasesTotal = 0;      ///< jitter phases in the still frame shown, of how many (0: none)
  struct HandleRow {
    int id;
    std::string status;
    std::size_t voxels;
    std::string reaction;  ///< what the tissue does to it (force, torque), while simulated
  };
  std::vector<HandleRow> handles;
  std::vector<int> picked;     ///< handles picked by tapping (union / difference act on the last two)
  bool canUndo = false, canRedo = false;
  std::string feedback;        ///< e.g. a refused pinch
  std::string simulation;      ///< the simulation's state (building, size, settling)
  std::string tissueLimits;    ///< the shown state's tissue past its strain limit and whose handle ("": not known for it)
  std::string exported;        ///< the last export's summary (or failure)
  std::size_t liveVoxels = 0;  ///< the selection being pinched
  double liveOnGpuMm = -1.0;   ///< the extent of a selection being pinched on the GPU (< 0: none)
  std::string selectionBackend;  ///< where pinches grow, and why (app/session/selection_backend.h)
  unsigned locks = 0;          ///< manipulation locks (GestureLock bits)
  std::string pinchOp = "new"; ///< what a pinch does in Select mode: new, add or remove
  bool strainOverlay = false;  ///< the strain overlay is on: its colour bar shows
  bool limitHighlight = false; ///< tissue past its strain limit is highlighted: the bar's key shows
  bool hasLabels = false;      ///< a label map is loaded: the Labels button shows
  bool sliding = false;        ///< the handles' interface with the tissue is sliding (else glued)
  bool labelTint = false;      ///< ... and its tint is on
  bool clipped = false;        ///< a clip box or plane is on (Clip mode shows "Clear clip" and "Frame clip")
  bool canGoBack = false;      ///< a framing can be undone (Clip mode shows "Previous view")
  WindowLevel window;          ///< the preset's window (Window mode shows it and "Reset window")
  float strainFrom = 0.0f, strainTo = 0.30f;  ///< the overlay's range (RenderSettings)
};

class Ui {
 public:
  /// scale: display scale (HiDPI factor) applied to sizes and fonts.
  Ui(SDL_Window* window, const vk::Context& ctx, const vk::Swapchain& swapchain, float scale);
  ~Ui();
  Ui(const Ui&) = delete;
  Ui& operator=(const Ui&) = delete;

  /// Feeds an SDL event to the UI.
  void processEvent(const SDL_Event& e);
  /// True while the pointer or a touch is over a UI window (presses there are the UI's).
  bool wantsPointer() const;
  /// True if a point (drawable pixels) lies on one of the UI's panels as last drawn. Unlike
  /// wantsPointer(), this is exact for the first event of a touch.
  bool covers(double x, double y) const;
  bool wantsKeyboard() const;
  /// The panels (and the frame-time overlay, which takes no touches) as last drawn, in drawable
  /// pixels (x0, y0, x1, y1).
  std::vector<std::array<double, 4>> panelRects() const;
  /// Builds this frame's widgets; UI actions are appended to `actions` stamped with `time`.
  void build(const UiStatus& status, double time, std::vector<ScriptEvent>& actions);
  /// Records the UI into the swapchain framebuffer (inside its own render pass).
  void record(VkCommandBuffer cmd, VkFramebuffer framebuffer, VkExtent2D extent);
  void swapchainRecreated(const vk::Swapchain& swapchain);

  /// The display scale (HiDPI factor) the UI is drawn at.
  float scale() const { return scale_; }
  static constexpr float kMinTarget = 48.0f;  ///< smallest touch target, pixels at 100 %

 private:
  using Action = std::function<void(UiAction, const std::string&)>;  ///< a UI action (and its value) for the session
  using Remember = std::function<void()>;                              ///< notes the current panel's rectangle
  float modeBar(const UiStatus& st, const Action& action, const Remember& remember);
  void presetsAndHandles(const UiStatus& st, const Action& action, const Remember& remember, float barBottom);
  void handleList(const UiStatus& st, const Action& action);
  float strainColourBar(const UiStatus& st, const Remember& remember);  ///< returns its top edge
  void timingOverlay(const UiStatus& st, float left, float bottom, int panelFlags);
  void modeOptions(const UiStatus& st, const Action& action, float buttonWidth, float buttonHeight);
  ImVec2 buttonSize() const;                    ///< a full-width touch button at this frame's fit
  ImVec2 labelButton(const char* label) const;  ///< a button as wide as its label (at least a touch target)
  /// Sets this frame's text and spacing scale from the window's size (and the folds, once).
  void fitToWindow();

  const vk::Context& ctx_;
  VkRenderPass renderPass_;
  VkDescriptorPool pool_ = VK_NULL_HANDLE;
  float scale_;
  float pixelsPerPoint_ = 1.0f;
  float panelHeight_ = 0.0f;  ///< the right panel's height as last drawn (it is centred by it)
  ImGuiStyle baseStyle_;      ///< the style at the display scale, before fitting to the window
  float fit_ = 1.0f;          ///< text and spacing scale for the window's size (0.7-1)
  bool folded_ = false;       ///< the panels' folds have been set for the first window size
  bool actionsOpen_ = true, presetsOpen_ = true, infoOpen_ = true;
  struct Rect {
    float x0, y0, x1, y1;
  };
  Rect overlay_{0, 0, 0, 0};  ///< the frame-time overlay (not a touch target)
  std::vector<Rect> panels_;  // in ImGui points, from the last build()
};

}  // namespace handson
