#include "ui.h"

#include <imgui.h>
#include <backends/imgui_impl_sdl.h>
#include <backends/imgui_impl_vulkan.h>

#include <algorithm>
#include <cstdio>

#include "render/transfer_function.h"
#include "render/vk_context.h"
#include "render/vk_swapchain.h"
#include "shaders/shared.h"
#include "sim/base/error.h"

namespace handson {

namespace {
void checkVk(VkResult r) {
  if (r != VK_SUCCESS) vk::check(r, "ImGui Vulkan backend");
}
}  // namespace

Ui::Ui(SDL_Window* window, const vk::Context& ctx, const vk::Swapchain& swapchain, float scale)
    : ctx_(ctx), renderPass_(swapchain.uiRenderPass()), scale_(std::clamp(scale, 0.5f, 4.0f)) {
  IMGUI_CHECKVERSION();
  ImGui::CreateContext();
  ImGuiIO& io = ImGui::GetIO();
  io.IniFilename = nullptr;  // no imgui.ini next to the user's files
  ImGui::StyleColorsDark();
  ImGuiStyle& style = ImGui::GetStyle();
  style.WindowRounding = 6.0f;
  style.FrameRounding = 6.0f;
  style.FramePadding = ImVec2(14, 12);
  style.ItemSpacing = ImVec2(10, 10);
  style.TouchExtraPadding = ImVec2(4, 4);
  style.ScaleAllSizes(scale_);
  baseStyle_ = style;
  ImFontConfig font;
  font.SizePixels = 20.0f * scale_;
  io.Fonts->AddFontDefault(&font);

  const VkDescriptorPoolSize sizes[] = {{VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 16}};
  VkDescriptorPoolCreateInfo pi{VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO};
  pi.flags = VK_DESCRIPTOR_POOL_CREATE_FREE_DESCRIPTOR_SET_BIT;
  pi.maxSets = 16;
  pi.poolSizeCount = 1;
  pi.pPoolSizes = sizes;
  vk::check(vkCreateDescriptorPool(ctx.device(), &pi, nullptr, &pool_), "vkCreateDescriptorPool");

  if (!ImGui_ImplSDL2_InitForVulkan(window)) throw Error("ImGui: SDL2 backend initialisation failed");
  ImGui_ImplVulkan_InitInfo info{};
  info.Instance = ctx.instance();
  info.PhysicalDevice = ctx.physicalDevice();
  info.Device = ctx.device();
  info.QueueFamily = ctx.queueFamily();
  info.Queue = ctx.queue();
  info.DescriptorPool = pool_;
  info.MinImageCount = std::max(2u, swapchain.minImageCount());
  info.ImageCount = std::max(info.MinImageCount, swapchain.imageCount());
  info.MSAASamples = VK_SAMPLE_COUNT_1_BIT;
  info.CheckVkResultFn = checkVk;
  if (!ImGui_ImplVulkan_Init(&info, renderPass_)) throw Error("ImGui: Vulkan backend initialisation failed");
  ctx.submitAndWait([](VkCommandBuffer cmd) { ImGui_ImplVulkan_CreateFontsTexture(cmd); });
  ImGui_ImplVulkan_DestroyFontUploadObjects();
}

Ui::~Ui() {
  vkDeviceWaitIdle(ctx_.device());
  ImGui_ImplVulkan_Shutdown();
  ImGui_ImplSDL2_Shutdown();
  ImGui::DestroyContext();
  if (pool_) vkDestroyDescriptorPool(ctx_.device(), pool_, nullptr);
}

void Ui::processEvent(const SDL_Event& e) { ImGui_ImplSDL2_ProcessEvent(&e); }

bool Ui::wantsPointer() const { return ImGui::GetIO().WantCaptureMouse; }
bool Ui::wantsKeyboard() const { return ImGui::GetIO().WantCaptureKeyboard; }
bool Ui::covers(double x, double y) const {
  const float px = float(x) / pixelsPerPoint_, py = float(y) / pixelsPerPoint_;
  for (const Rect& r : panels_)
    if (px >= r.x0 && px <= r.x1 && py >= r.y0 && py <= r.y1) return true;
  return false;
}

std::vector<std::array<double, 4>> Ui::panelRects() const {
  std::vector<std::array<double, 4>> rects;
  std::vector<Rect> all = panels_;
  if (overlay_.x1 > overlay_.x0) all.push_back(overlay_);
  for (const Rect& r : all)
    rects.push_back({double(r.x0) * pixelsPerPoint_, double(r.y0) * pixelsPerPoint_, double(r.x1) * pixelsPerPoint_, double(r.y1) * pixelsPerPoint_});
  return rects;
}

void Ui::swapchainRecreated(const vk::Swapchain& swapchain) {
  ImGui_ImplVulkan_SetMinImageCount(std::max(2u, swapchain.minImageCount()));
}

// The strain overlay's colour bar, bottom left (returns its top edge): the raymarch's ramp (shaders/raymarch.comp,
// strainTint) from the strain where colour starts to where it is full; and the limit highlight's
// colour (limitTint) with what it means.
float Ui::strainColourBar(const UiStatus& st, const Remember& remember) {
  const float s = scale_;
  const ImVec2 display = ImGui::GetIO().DisplaySize;
  ImGui::SetNextWindowPos(ImVec2(10 * s, display.y - 10 * s), ImGuiCond_Always, ImVec2(0.0f, 1.0f));
  ImGui::SetNextWindowBgAlpha(0.75f);
  ImGui::Begin("strain-bar", nullptr,
               ImGuiWindowFlags_NoTitleBar | ImGuiWindowFlags_NoResize | ImGuiWindowFlags_NoMove | ImGuiWindowFlags_AlwaysAutoResize |
                   ImGuiWindowFlags_NoSavedSettings | ImGuiWindowFlags_NoFocusOnAppearing);
  const ImVec2 size(220 * s, 18 * s);
  if (st.strainOverlay) {
    ImGui::TextUnformatted(st.simulation.empty() ? "Strain (largest stretch), no simulation" : "Strain (largest stretch)");
    const ImVec2 p = ImGui::GetCursorScreenPos();
    const ImU32 from = ImGui::GetColorU32(ImVec4(1.0f, 0.85f, 0.1f, 1.0f)), to = ImGui::GetColorU32(ImVec4(0.9f, 0.05f, 0.05f, 1.0f));
    ImGui::GetWindowDrawList()->AddRectFilledMultiColor(p, ImVec2(p.x + size.x, p.y + size.y), from, to, to, from);
    ImGui::Dummy(size);
    ImGui::Text("%.0f %%", 100.0 * st.strainFrom);
    ImGui::SameLine(size.x - 30 * s);
    ImGui::Text("%.0f %%", 100.0 * st.strainTo);
  }
  if (st.limitHighlight) {  // the highlight's colour (shaders/shared.h HANDSON_LIMIT_COLOUR) and what it means
    static constexpr float kLimit[3] = {HANDSON_LIMIT_COLOUR};
    const ImVec2 p = ImGui::GetCursorScreenPos(), swatch(size.y, size.y);
    ImGui::GetWindowDrawList()->AddRectFilled(p, ImVec2(p.x + swatch.x, p.y + swatch.y), ImGui::GetColorU32(ImVec4(kLimit[0], kLimit[1], kLimit[2], 1.0f)));
    ImGui::Dummy(swatch);
    ImGui::SameLine();
    ImGui::TextUnformatted(st.simulation.empty() ? "past its tissue's strain limit, no simulation" : "past its tissue's strain limit");
  }
  remember();
  const float top = ImGui::GetWindowPos().y;
  ImGui::End();
  return top;
}

namespace {
const ImVec4 kOn(0.20f, 0.45f, 0.85f, 1.0f);  // a button whose state is on (the mode, the preset, a fold)
const ImVec4 kOptionOn(0.85f, 0.45f, 0.20f, 1.0f);  // a mode's option that is on (a lock, what a pinch does)
constexpr ImGuiWindowFlags kPanel = ImGuiWindowFlags_NoTitleBar | ImGuiWindowFlags_NoResize | ImGuiWindowFlags_NoMove |
                                    ImGuiWindowFlags_AlwaysAutoResize | ImGuiWindowFlags_NoSavedSettings | ImGuiWindowFlags_NoFocusOnAppearing;
// A button drawn in `colour` while `on`; true when tapped.
bool colouredButton(const char* label, ImVec2 size, bool on, const ImVec4& colour = kOn) {
  if (on) ImGui::PushStyleColor(ImGuiCol_Button, colour);
  const bool tapped = ImGui::Button(label, size);
  if (on) ImGui::PopStyleColor();
  return tapped;
}
}  // namespace

// The current mode's own controls under the mode bar: Clip's and Window's hints and reset buttons,
// Manipulate's axis locks.
void Ui::modeOptions(const UiStatus& st, const Action& action, float buttonWidth, float buttonHeight) {
  const ImVec2 button(buttonWidth, buttonHeight);
  if (st.mode == "clip") {
    ImGui::NewLine();
    ImGui::PushTextWrapPos(ImGui::GetCursorPosX() + 3.0f * button.x);
    ImGui::TextUnformatted("Drag from a box face's middle to move it; drag elsewhere to cut through the point under the finger (up: deeper)");
    ImGui::PopTextWrapPos();
    if (st.clipped && ImGui::Button("Clear clip", button)) action(UiAction::ClearClip, "");
    if (st.clipped) ImGui::SameLine();
    if (st.clipped && ImGui::Button("Frame clip", button)) action(UiAction::FrameClip, "");
    if (st.canGoBack) ImGui::SameLine();
    if (st.canGoBack && ImGui::Button("Previous view", button)) action(UiAction::CameraBack, "");
  }
  if (st.mode == "window") {
    ImGui::NewLine();
    ImGui::PushTextWrapPos(ImGui::GetCursorPosX() + 3.0f * button.x);
    ImGui::TextWrapped("Drag up/down: level, left/right: window, spread two fingers: opacity (window x%.2f, level %+.0f, opacity x%.2f)",
                       st.window.scale, st.window.shift, st.window.opacity);
    ImGui::PopTextWrapPos();
    if (!st.window.identity() && ImGui::Button("Reset window", button)) action(UiAction::ResetWindow, "");
    if (!st.window.identity()) ImGui::SameLine();
    if (ImGui::Button("Auto window", button)) action(UiAction::AutoWindow, "");
  }
  if (st.mode == "select") {
    // What the next pinches do: a new handle, or a correction of the handle tapped last (else the newest).
    ImGui::NewLine();
    const std::pair<const char*, const char*> ops[] = {{"new", "New handle"}, {"add", "Add to handle"}, {"remove", "Remove from handle"}};
    for (const auto& [op, label] : ops) {
      if (colouredButton(label, ImVec2(button.x * 1.4f, button.y), st.pinchOp == op, kOptionOn)) action(UiAction::PinchOp, op);
      ImGui::SameLine();
    }
    ImGui::NewLine();
  }
  if (st.mode == "manipulate") {
    // Axis locks for the manipulation (the finger count chooses the rest).
    ImGui::NewLine();
    const std::pair<unsigned, const char*> locks[] = {{1u, "z-translation"}, {2u, "z-rotation"}, {4u, "xy-translation"}};
    for (const auto& [bit, name] : locks) {
      const std::string label = std::string("Lock ") + name;
      if (colouredButton(label.c_str(), ImVec2(button.x * 1.4f, button.y), (st.locks & bit) != 0, kOptionOn)) action(UiAction::ToggleLock, name);
      ImGui::SameLine();
    }
    ImGui::NewLine();
  }
}

void Ui::fitToWindow() {
  ImGuiIO& io = ImGui::GetIO();
  const float shorter = std::min(io.DisplaySize.x, io.DisplaySize.y) / scale_;  // in points at 100 %
  if (!(shorter > 0.0f)) return;
  fit_ = std::clamp(shorter / 800.0f, 0.7f, 1.0f);
  ImGui::GetStyle() = baseStyle_;
  ImGui::GetStyle().ScaleAllSizes(fit_);
  io.FontGlobalScale = fit_;
  if (!folded_) {
    // The first window size sets the folds: below a 1400-point width the view's actions fold; the
    // presets and the overlay's details start folded (one tap opens them).
    actionsOpen_ = io.DisplaySize.x / scale_ >= 1400.0f;
    presetsOpen_ = false;
    infoOpen_ = false;
    folded_ = true;
  }
}

ImVec2 Ui::buttonSize() const { return ImVec2(std::max(kMinTarget, 150.0f * fit_) * scale_, std::max(kMinTarget, 56.0f * fit_) * scale_); }

// A button as wide as its label (at least a touch target): what lets the bar fit small windows.
ImVec2 Ui::labelButton(const char* label) const {
  return ImVec2(std::max(kMinTarget * scale_, ImGui::CalcTextSize(label).x + 24.0f * scale_ * fit_), buttonSize().y);
}

void Ui::build(const UiStatus& st, double time, std::vector<ScriptEvent>& actions) {
  ImGui_ImplVulkan_NewFrame();
  ImGui_ImplSDL2_NewFrame();
  fitToWindow();
  ImGui::NewFrame();
  pixelsPerPoint_ = ImGui::GetIO().DisplayFramebufferScale.x > 0 ? ImGui::GetIO().DisplayFramebufferScale.x : 1.0f;
  panels_.clear();
  const Remember remember = [&] {
    const ImVec2 p = ImGui::GetWindowPos(), sz = ImGui::GetWindowSize();
    panels_.push_back({p.x, p.y, p.x + sz.x, p.y + sz.y});
  };
  const Action action = [&](UiAction a, const std::string& value) { actions.push_back(uiEvent(time, a, value)); };
  const float barBottom = modeBar(st, action, remember);
  // The strain colour bar and the timing overlay share the bottom left corner: the overlay above the bar.
  float bottom = ImGui::GetIO().DisplaySize.y - 10 * scale_;
  if (st.strainOverlay || st.limitHighlight) bottom = strainColourBar(st, remember) - 6 * scale_;
  presetsAndHandles(st, action, remember, barBottom);
  timingOverlay(st, 10 * scale_, bottom, kPanel);
  ImGui::Render();
}

// Mode bar, top left: five modes on the first row (narrower buttons, still touch-sized) and the fold
// of the view's actions, which are below it. Returns its bottom edge.
float Ui::modeBar(const UiStatus& st, const Action& action, const Remember& remember) {
  const float s = scale_;
  ImGui::SetNextWindowPos(ImVec2(10 * s, 10 * s));
  ImGui::SetNextWindowBgAlpha(0.75f);
  ImGui::Begin("modes", nullptr, kPanel);
  for (const char* m : {"navigate", "select", "manipulate", "clip", "window"}) {
    const bool active = st.mode == m;
    char label[32];
    std::snprintf(label, sizeof(label), "%c%s", m[0] - 32, m + 1);
    if (colouredButton(label, labelButton(label), active) && !active) action(UiAction::SetMode, m);
    ImGui::SameLine();
  }
  if (ImGui::Button(actionsOpen_ ? "Less" : "More", labelButton("More"))) actionsOpen_ = !actionsOpen_;
  if (actionsOpen_) {
    if (ImGui::Button("Reset view", labelButton("Reset view"))) action(UiAction::ResetCamera, "");
    ImGui::SameLine();
    if (ImGui::Button("Export", labelButton("Export"))) action(UiAction::Export, "");
    ImGui::SameLine();
    if (colouredButton("Strain", labelButton("Strain"), st.strainOverlay, ImVec4(0.85f, 0.35f, 0.10f, 1.0f))) action(UiAction::ToggleStrain, "");
    ImGui::SameLine();
    if (colouredButton("Limits", labelButton("Limits"), st.limitHighlight, ImVec4(0.75f, 0.10f, 0.70f, 1.0f))) action(UiAction::ToggleLimits, "");
    ImGui::SameLine();
    // The handles' interface with the tissue: the button names the current one, a tap switches.
    if (ImGui::Button(st.sliding ? "Sliding" : "Glued", labelButton("Sliding"))) action(UiAction::SetInterface, st.sliding ? "glued" : "sliding");
    if (st.hasLabels) {
      ImGui::SameLine();
      if (colouredButton("Labels", labelButton("Labels"), st.labelTint, ImVec4(0.25f, 0.60f, 0.35f, 1.0f))) action(UiAction::ToggleLabels, "");
    }
    ImGui::SameLine();
    if (colouredButton("Info", labelButton("Info"), infoOpen_)) infoOpen_ = !infoOpen_;
  }
  const ImVec2 button = buttonSize();
  modeOptions(st, action, button.x, button.y);
  remember();
  const float bottom = ImGui::GetWindowPos().y + ImGui::GetWindowSize().y;
  ImGui::End();
  return bottom;
}

// Transfer-function presets and the handle list, right side: centred, but never over the mode bar.
void Ui::presetsAndHandles(const UiStatus& st, const Action& action, const Remember& remember, float barBottom) {
  const float s = scale_;
  const ImVec2 button = buttonSize(), display = ImGui::GetIO().DisplaySize;
  const float panelHeight = panelHeight_ > 0.0f ? panelHeight_ : 0.6f * display.y;
  ImGui::SetNextWindowPos(ImVec2(display.x - 10 * s, std::max(0.5f * (display.y - panelHeight), barBottom + 10 * s)), ImGuiCond_Always, ImVec2(1.0f, 0.0f));
  ImGui::SetNextWindowBgAlpha(0.75f);
  ImGui::Begin("presets", nullptr, kPanel);
  ImGui::PushTextWrapPos(ImGui::GetCursorPosX() + 1.3f * button.x);  // hints wrap at the buttons' width
  // The presets fold under their header, which names the one in use.
  const std::string header = presetsOpen_ ? std::string("Presets -") : "Preset: " + st.preset + " +";
  if (ImGui::Button(header.c_str(), labelButton(header.c_str()))) presetsOpen_ = !presetsOpen_;
  if (presetsOpen_)
    for (const auto& p : transferFunctionPresetNames()) {
      const bool active = st.preset == p;
      if (colouredButton(p.c_str(), ImVec2(std::max(button.x, labelButton(p.c_str()).x), button.y), active) && !active) action(UiAction::SetPreset, p);
    }
  ImGui::Separator();
  handleList(st, action);
  ImGui::PopTextWrapPos();
  panelHeight_ = ImGui::GetWindowSize().y;
  remember();
  ImGui::End();
}

// The handle list under the presets: what is being selected, the simulation's and the tissue
// limits' state, each handle's status buttons, union and difference of the two picked, undo.
void Ui::handleList(const UiStatus& st, const Action& action) {
  const float s = scale_;
  const ImVec2 button = buttonSize(), small(std::max(kMinTarget, 64.0f * fit_) * s, kMinTarget * s);
  ImGui::TextUnformatted("Handles");
  if (st.liveVoxels) ImGui::TextColored(ImVec4(0.3f, 1.0f, 0.4f, 1.0f), "selecting: %zu voxels", st.liveVoxels);
  if (st.liveOnGpuMm >= 0) ImGui::TextColored(ImVec4(0.3f, 1.0f, 0.4f, 1.0f), "selecting on the GPU: %.0f mm", st.liveOnGpuMm);
  if (!st.feedback.empty()) ImGui::TextColored(ImVec4(1.0f, 0.5f, 0.3f, 1.0f), "%s", st.feedback.c_str());
  if (!st.simulation.empty()) ImGui::TextUnformatted(st.simulation.c_str());
  if (!st.tissueLimits.empty()) {
    const bool none = st.tissueLimits == "none";
    const ImVec4 colour = none ? ImVec4(0.6f, 0.8f, 0.6f, 1.0f) : ImVec4(1.0f, 0.35f, 0.8f, 1.0f);
    ImGui::PushStyleColor(ImGuiCol_Text, colour);
    ImGui::TextWrapped("past the strain limit: %s", st.tissueLimits.c_str());
    ImGui::PopStyleColor();
  }
  if (!st.exported.empty()) ImGui::TextWrapped("%s", st.exported.c_str());
  if (st.handles.empty()) ImGui::TextDisabled("none: pinch an organ (Select)");
  else if (st.picked.size() < 2) ImGui::TextDisabled("tap two handles to unite or subtract them");
  for (const auto& h : st.handles) {
    ImGui::PushID(h.id);
    const bool isPicked = std::find(st.picked.begin(), st.picked.end(), h.id) != st.picked.end();
    ImGui::Text("%s#%d %s, %zu voxels", isPicked ? "> " : "", h.id, h.status.c_str(), h.voxels);
    if (!h.reaction.empty()) ImGui::TextUnformatted(h.reaction.c_str());
    for (const char* stName : {"active", "fixed", "idle"}) {
      const bool on = h.status == stName;
      const char label[2] = {char(stName[0] - 32), 0};
      if (colouredButton(label, small, on) && !on) action(UiAction::HandleStatus, std::to_string(h.id) + ":" + stName);
      ImGui::SameLine();
    }
    if (ImGui::Button("Del", small)) action(UiAction::HandleDelete, std::to_string(h.id));
    ImGui::PopID();
  }
  if (st.picked.size() == 2) {
    char unite[32], subtract[32], pair[32];
    std::snprintf(unite, sizeof(unite), "#%d + #%d", st.picked[0], st.picked[1]);
    std::snprintf(subtract, sizeof(subtract), "#%d - #%d", st.picked[0], st.picked[1]);
    std::snprintf(pair, sizeof(pair), "%d,%d", st.picked[0], st.picked[1]);
    if (ImGui::Button(unite, button)) action(UiAction::HandleUnion, pair);
    ImGui::SameLine();
    if (ImGui::Button(subtract, button)) action(UiAction::HandleDifference, pair);
  }
  if (st.canUndo || st.canRedo) {  // with nothing to undo or redo they take no room
    ImGui::BeginDisabled(!st.canUndo);
    if (ImGui::Button("Undo", small)) action(UiAction::Undo, "");
    ImGui::EndDisabled();
    ImGui::SameLine();
    ImGui::BeginDisabled(!st.canRedo);
    if (ImGui::Button("Redo", small)) action(UiAction::Redo, "");
    ImGui::EndDisabled();
  }
}

// Frame-time overlay, bottom left: times, device, the frame budget's quality, where pinches grow.
void Ui::timingOverlay(const UiStatus& st, float left, float bottom, int panelFlags) {
  ImGui::SetNextWindowPos(ImVec2(left, bottom), ImGuiCond_Always, ImVec2(0.0f, 1.0f));
  ImGui::SetNextWindowBgAlpha(0.55f);
  ImGui::Begin("timing", nullptr, panelFlags | ImGuiWindowFlags_NoInputs);
  // Fixed widths: the auto-sized overlay takes its size from the last frame's text.
  ImGui::Text("%5.1f fps   CPU %5.1f ms   raymarch %6.1f ms", st.fps, st.cpuFrameMs, st.gpuRaymarchMs);
  if (st.latencyMs >= 0) ImGui::Text("input to present %.1f ms", st.latencyMs);
  if (st.displayLatencyMs >= 0) ImGui::Text("input to display %.1f ms", st.displayLatencyMs);
  if (infoOpen_) ImGui::Text("%s   %dx%d   fingers %d", st.device.c_str(), st.renderWidth, st.renderHeight, st.fingers);
  // The frame budget's indicator, on a line of its own from the start (the panels are measured
  // once, for the first view's framing): amber while the frame is reduced.
  const bool reduced = st.qualityScale != 1.0 || st.qualityStep != 1.0;
  ImGui::TextColored(reduced ? ImVec4(1.0f, 0.75f, 0.25f, 1.0f) : ImGui::GetStyleColorVec4(ImGuiCol_Text), "quality: resolution %3.0f %%, step %.1fx", 100.0 * st.qualityScale,
                     st.qualityStep);
  if (infoOpen_ && st.stillPhases > 0) ImGui::Text("still frame: %d of %d jitter phases", st.stillPhases, st.stillPhasesTotal);
  if (infoOpen_ && !st.selectionBackend.empty()) ImGui::TextUnformatted(st.selectionBackend.c_str());
  overlay_ = Rect{ImGui::GetWindowPos().x, ImGui::GetWindowPos().y, ImGui::GetWindowPos().x + ImGui::GetWindowSize().x,
                  ImGui::GetWindowPos().y + ImGui::GetWindowSize().y};
  ImGui::End();
}

void Ui::record(VkCommandBuffer cmd, VkFramebuffer framebuffer, VkExtent2D extent) {
  VkRenderPassBeginInfo rb{VK_STRUCTURE_TYPE_RENDER_PASS_BEGIN_INFO};
  rb.renderPass = renderPass_;
  rb.framebuffer = framebuffer;
  rb.renderArea = {{0, 0}, extent};
  vkCmdBeginRenderPass(cmd, &rb, VK_SUBPASS_CONTENTS_INLINE);
  ImGui_ImplVulkan_RenderDrawData(ImGui::GetDrawData(), cmd);
  vkCmdEndRenderPass(cmd);
}

}  // namespace handson
