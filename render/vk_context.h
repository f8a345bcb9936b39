#pragma once
// Vulkan instance and device: device choice (discrete GPU, then integrated, then CPU/lavapipe,
// overridable), the Khronos validation layer with a messenger that counts every message, one
// compute-capable queue, and helpers for one-shot command submission. Headless: no surface needed.
#include <vulkan/vulkan.h>

#include <atomic>
#include <cstdint>
#include <functional>
#include <mutex>
#include <string>
#include <vector>

namespace handson::vk {

/// Throws handson::Error naming `what` if r is not VK_SUCCESS.
void check(VkResult r, const char* what);
const char* resultName(VkResult r);

struct ContextOptions {
  /// Enable VK_LAYER_KHRONOS_validation. Default: on if HANDSON_VALIDATION=1 or in debug builds.
  bool validation = false;
  /// Fail if validation was requested but the layer is missing (tests want this).
  bool requireValidation = false;
  /// With validation on, also its synchronization validation (VK_EXT_validation_features): missing
  /// or wrong barriers between commands are reported as SYNC- hazards. It tracks the command stream on
  /// the CPU, so it finds on lavapipe the hazards a discrete GPU would show as corrupt frames. Off by
  /// HANDSON_NO_SYNC_VALIDATION=1 (it slows recording).
  bool syncValidation = true;
  /// With validation on, also GPU-assisted validation: shaders instrumented to report out-of-bounds
  /// descriptor and buffer accesses. Default: off unless HANDSON_GPU_VALIDATION=1 (it slows every
  /// dispatch; the tests run it as their own ctest label).
  bool gpuAssistedValidation = false;
  /// Device choice: "" = automatic (discrete > integrated > virtual > CPU), "gpu" = any non-CPU
  /// device, "cpu" = a CPU implementation (lavapipe), a number = index in enumeration order, or
  /// any other text = a substring of the device name. The HANDSON_DEVICE environment variable
  /// is used when this is empty.
  std::string device;
  /// Print the chosen device on stderr.
  bool verbose = false;
  /// Instance extensions the caller needs (e.g. from SDL_Vulkan_GetInstanceExtensions).
  std::vector<std::string> instanceExtensions;
  /// Device extensions the caller needs (e.g. VK_KHR_swapchain).
  std::vector<std::string> deviceExtensions;
  /// Fault injection, to test how the app fails (empty: the HANDSON_FAULT environment variable).
  /// A comma-separated list of "alloc:N" (the N-th vkAllocateMemory fails with
  /// VK_ERROR_OUT_OF_DEVICE_MEMORY) and "device-lost:N" (the N-th queue submission and every one
  /// after it fail with VK_ERROR_DEVICE_LOST, as a lost device stays lost); N counts from 1.
  std::string faults;
  /// Window path: enable VK_KHR_present_id and VK_KHR_present_wait where the device has them, so
  /// that each present is timed on screen (render/present_timer.h). Needs VK_KHR_swapchain.
  bool presentTiming = false;
  /// Window path: creates the presentation surface once the instance exists. The chosen queue
  /// family must then be able to present to it. The context owns and destroys the surface.
  std::function<VkSurfaceKHR(VkInstance)> makeSurface;
};

struct DeviceSummary {
  std::string name;
  VkPhysicalDeviceType type;
  std::uint32_t apiVersion;
};

const char* deviceTypeName(VkPhysicalDeviceType t);

/// Where an injected fault (ContextOptions::faults) can strike.
enum class FaultSite { AllocateMemory, Submit };

class Context {
 public:
  explicit Context(const ContextOptions& options = {});
  ~Context();
  Context(const Context&) = delete;
  Context& operator=(const Context&) = delete;

  VkInstance instance() const { return instance_; }
  VkPhysicalDevice physicalDevice() const { return physical_; }
  VkDevice device() const { return device_; }
  VkQueue queue() const { return queue_; }
  VkSurfaceKHR surface() const { return surface_; }
  std::uint32_t queueFamily() const { return queueFamily_; }
  const VkPhysicalDeviceProperties& properties() const { return props_; }
  const DeviceSummary& summary() const { return summary_; }
  bool validationEnabled() const { return validation_; }
  /// Whether synchronization validation runs (validation on, ContextOptions::syncValidation).
  bool syncValidationEnabled() const { return syncValidation_; }
  /// Whether GPU-assisted validation runs (validation on, ContextOptions::gpuAssistedValidation).
  bool gpuAssistedValidationEnabled() const { return gpuAssisted_; }
  /// Nanoseconds per timestamp tick, 0 if the queue has no timestamps.
  double timestampPeriodNs() const { return timestampPeriod_; }
  /// shaderStorageImageExtendedFormats (r16 / r8 storage images) is supported and enabled.
  bool storageExtendedFormats() const { return storageExtendedFormats_; }
  /// VK_KHR_present_id and VK_KHR_present_wait are enabled (ContextOptions::presentTiming and the
  /// device has both features); then waitForPresent is set.
  bool presentWait() const { return presentWait_; }

  /// Number of validation messages (warnings and errors) since creation or the last reset.
  std::uint64_t validationMessageCount() const { return messageCount_.load(); }
  std::vector<std::string> validationMessages() const;
  void resetValidationMessages();

  std::uint32_t findMemoryType(std::uint32_t typeBits, VkMemoryPropertyFlags want) const;
  /// Size of the largest device-local memory heap (the most one resource set can hope for), or
  /// the HANDSON_GPU_MEMORY_LIMIT_MB environment variable when smaller (a GPU shared with other work).
  VkDeviceSize deviceLocalHeapBytes() const;
  /// Records with `record` into a fresh command buffer, submits, waits. For uploads and tools.
  void submitAndWait(const std::function<void(VkCommandBuffer)>& record) const;

  PFN_vkCmdPushDescriptorSetKHR cmdPushDescriptorSet = nullptr;
  PFN_vkWaitForPresentKHR waitForPresent = nullptr;

  /// Counts one call at `site` and says whether it must fail (ContextOptions::faults). Callers
  /// then return the site's error code instead of calling Vulkan.
  bool injectedFault(FaultSite site) const;

  /// All devices visible to the loader (for `handson devices` and error messages).
  static std::vector<DeviceSummary> listDevices();

 private:
  static VKAPI_ATTR VkBool32 VKAPI_CALL debugCallback(VkDebugUtilsMessageSeverityFlagBitsEXT severity,
                                                      VkDebugUtilsMessageTypeFlagsEXT types,
                                                      const VkDebugUtilsMessengerCallbackDataEXT* data, void* user);
  struct DeviceCandidate {
    VkPhysicalDevice dev;
    VkPhysicalDeviceProperties props;
    std::uint32_t family;
    int index;
  };
  void pickDevice(const ContextOptions& options);
  std::vector<DeviceCandidate> usableDevices(const ContextOptions& options) const;
  static const DeviceCandidate& chooseDevice(const std::vector<DeviceCandidate>& usable, const std::string& want);
  void createDevice(const ContextOptions& options);
  void parseFaults(const std::string& spec);
  void release();

  VkInstance instance_ = VK_NULL_HANDLE;
  VkDebugUtilsMessengerEXT messenger_ = VK_NULL_HANDLE;
  VkSurfaceKHR surface_ = VK_NULL_HANDLE;
  VkPhysicalDevice physical_ = VK_NULL_HANDLE;
  VkDevice device_ = VK_NULL_HANDLE;
  VkQueue queue_ = VK_NULL_HANDLE;
  VkCommandPool pool_ = VK_NULL_HANDLE;
  std::uint32_t queueFamily_ = 0;
  VkPhysicalDeviceProperties props_{};
  VkPhysicalDeviceMemoryProperties memProps_{};
  DeviceSummary summary_{};
  bool validation_ = false;
  bool syncValidation_ = false;
  bool gpuAssisted_ = false;
  double timestampPeriod_ = 0.0;
  bool storageExtendedFormats_ = false;
  bool presentWait_ = false;
  std::atomic<std::uint64_t> messageCount_{0};
  mutable std::mutex messageMutex_;
  std::vector<std::string> messages_;
  mutable std::mutex submitMutex_;
  struct Fault {
    std::uint64_t at = 0;  ///< 0: none
    bool sticky = false;   ///< every call from `at` on fails
    mutable std::atomic<std::uint64_t> calls{0};
  };
  Fault faults_[2];
};

}  // namespace handson::vk
