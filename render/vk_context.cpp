#include "vk_context.h"

#include <algorithm>
#include <cstdlib>
#include <cstring>
#include <iostream>
#include <sstream>

#include "sim/base/error.h"

namespace handson::vk {

const char* resultName(VkResult r) {
  switch (r) {
    case VK_SUCCESS: return "VK_SUCCESS";
    case VK_NOT_READY: return "VK_NOT_READY";
    case VK_TIMEOUT: return "VK_TIMEOUT";
    case VK_ERROR_OUT_OF_HOST_MEMORY: return "VK_ERROR_OUT_OF_HOST_MEMORY";
    case VK_ERROR_OUT_OF_DEVICE_MEMORY: return "VK_ERROR_OUT_OF_DEVICE_MEMORY";
    case VK_ERROR_INITIALIZATION_FAILED: return "VK_ERROR_INITIALIZATION_FAILED";
    case VK_ERROR_DEVICE_LOST: return "VK_ERROR_DEVICE_LOST";
    case VK_ERROR_LAYER_NOT_PRESENT: return "VK_ERROR_LAYER_NOT_PRESENT";
    case VK_ERROR_EXTENSION_NOT_PRESENT: return "VK_ERROR_EXTENSION_NOT_PRESENT";
    case VK_ERROR_FEATURE_NOT_PRESENT: return "VK_ERROR_FEATURE_NOT_PRESENT";
    case VK_ERROR_INCOMPATIBLE_DRIVER: return "VK_ERROR_INCOMPATIBLE_DRIVER";
    case VK_ERROR_FORMAT_NOT_SUPPORTED: return "VK_ERROR_FORMAT_NOT_SUPPORTED";
    case VK_ERROR_OUT_OF_DATE_KHR: return "VK_ERROR_OUT_OF_DATE_KHR";
    case VK_SUBOPTIMAL_KHR: return "VK_SUBOPTIMAL_KHR";
    case VK_ERROR_SURFACE_LOST_KHR: return "VK_ERROR_SURFACE_LOST_KHR";
    default: return "VkResult error";
  }
}

void check(VkResult r, const char* what) {
  if (r == VK_SUCCESS) return;
  std::ostringstream msg;
  msg << "Vulkan: " << what << " failed (" << resultName(r) << ", " << int(r) << ")";
  if (r == VK_ERROR_DEVICE_LOST) msg << ": the GPU device was lost";
  if (r == VK_ERROR_OUT_OF_DEVICE_MEMORY || r == VK_ERROR_OUT_OF_HOST_MEMORY) msg << ": out of memory";
  throw Error(msg.str());
}

const char* deviceTypeName(VkPhysicalDeviceType t) {
  switch (t) {
    case VK_PHYSICAL_DEVICE_TYPE_DISCRETE_GPU: return "discrete GPU";
    case VK_PHYSICAL_DEVICE_TYPE_INTEGRATED_GPU: return "integrated GPU";
    case VK_PHYSICAL_DEVICE_TYPE_VIRTUAL_GPU: return "virtual GPU";
    case VK_PHYSICAL_DEVICE_TYPE_CPU: return "CPU";
    default: return "other";
  }
}

namespace {

bool hasLayer(const char* name) {
  std::uint32_t n = 0;
  vkEnumerateInstanceLayerProperties(&n, nullptr);
  std::vector<VkLayerProperties> layers(n);
  vkEnumerateInstanceLayerProperties(&n, layers.data());
  for (const auto& l : layers)
    if (std::strcmp(l.layerName, name) == 0) return true;
  return false;
}

bool envFlag(const char* name) {
  const char* v = std::getenv(name);
  return v && *v && std::strcmp(v, "0") != 0;
}

int typeScore(VkPhysicalDeviceType t) {
  switch (t) {
    case VK_PHYSICAL_DEVICE_TYPE_DISCRETE_GPU: return 4;
    case VK_PHYSICAL_DEVICE_TYPE_INTEGRATED_GPU: return 3;
    case VK_PHYSICAL_DEVICE_TYPE_VIRTUAL_GPU: return 2;
    case VK_PHYSICAL_DEVICE_TYPE_CPU: return 1;
    default: return 0;
  }
}

VkInstance createBareInstance() {
  VkApplicationInfo app{VK_STRUCTURE_TYPE_APPLICATION_INFO};
  app.pApplicationName = "handson";
  app.apiVersion = VK_API_VERSION_1_3;
  VkInstanceCreateInfo ci{VK_STRUCTURE_TYPE_INSTANCE_CREATE_INFO};
  ci.pApplicationInfo = &app;
  VkInstance inst = VK_NULL_HANDLE;
  if (vkCreateInstance(&ci, nullptr, &inst) != VK_SUCCESS) return VK_NULL_HANDLE;
  return inst;
}

}  // namespace

std::vector<DeviceSummary> Context::listDevices() {
  std::vector<DeviceSummary> out;
  VkInstance inst = createBareInstance();
  if (!inst) return out;
  std::uint32_t n = 0;
  vkEnumeratePhysicalDevices(inst, &n, nullptr);
  std::vector<VkPhysicalDevice> devs(n);
  vkEnumeratePhysicalDevices(inst, &n, devs.data());
  for (auto d : devs) {
    VkPhysicalDeviceProperties p;
    vkGetPhysicalDeviceProperties(d, &p);
    out.push_back({p.deviceName, p.deviceType, p.apiVersion});
  }
  vkDestroyInstance(inst, nullptr);
  return out;
}

namespace {

bool deviceHasExtension(VkPhysicalDevice dev, const char* name) {
  std::uint32_t n = 0;
  vkEnumerateDeviceExtensionProperties(dev, nullptr, &n, nullptr);
  std::vector<VkExtensionProperties> ext(n);
  vkEnumerateDeviceExtensionProperties(dev, nullptr, &n, ext.data());
  return std::any_of(ext.begin(), ext.end(), [&](const auto& e) { return std::strcmp(e.extensionName, name) == 0; });
}

}  // namespace

VKAPI_ATTR VkBool32 VKAPI_CALL Context::debugCallback(VkDebugUtilsMessageSeverityFlagBitsEXT severity,
                                                     VkDebugUtilsMessageTypeFlagsEXT /*types*/,
                                                     const VkDebugUtilsMessengerCallbackDataEXT* data, void* user) {
  auto* self = static_cast<Context*>(user);
  if (severity < VK_DEBUG_UTILS_MESSAGE_SEVERITY_WARNING_BIT_EXT) return VK_FALSE;
  const std::string text = data && data->pMessage ? data->pMessage : "(no message)";
  // vkWaitForPresentKHR may run beside acquire and present on the same swapchain (the spec's
  // exception to external synchronization); validation layers before 1.3.270 report it as a
  // threading error. Only that report is ignored (a swapchain used by one of those three calls),
  // and only with present wait on: creating, retiring or destroying one during a wait is not.
  if (self->presentWait_ && data && data->pMessageIdName && std::strncmp(data->pMessageIdName, "UNASSIGNED-Threading", 20) == 0) {
    const bool presentCalls = (text.find("vkWaitForPresentKHR") != std::string::npos || text.find("vkAcquireNextImageKHR") != std::string::npos ||
                               text.find("vkQueuePresentKHR") != std::string::npos) &&
                              text.find("vkCreateSwapchainKHR") == std::string::npos && text.find("vkDestroySwapchainKHR") == std::string::npos;
    for (std::uint32_t i = 0; i < data->objectCount && presentCalls; ++i)
      if (data->pObjects[i].objectType == VK_OBJECT_TYPE_SWAPCHAIN_KHR) return VK_FALSE;
  }
  self->messageCount_.fetch_add(1);
  {
    std::lock_guard<std::mutex> lock(self->messageMutex_);
    if (self->messages_.size() < 64) self->messages_.push_back(text);
  }
  std::cerr << "[vulkan validation] " << text << "\n";
  return VK_FALSE;
}

std::vector<std::string> Context::validationMessages() const {
  std::lock_guard<std::mutex> lock(messageMutex_);
  return messages_;
}

void Context::resetValidationMessages() {
  std::lock_guard<std::mutex> lock(messageMutex_);
  messages_.clear();
  messageCount_ = 0;
}

Context::Context(const ContextOptions& options) {
#ifndef NDEBUG
  const bool debugBuild = !envFlag("HANDSON_NO_VALIDATION");  // debug builds validate by default
#else
  const bool debugBuild = false;
#endif
  const bool wantValidation = options.validation || debugBuild || envFlag("HANDSON_VALIDATION");
  validation_ = wantValidation && hasLayer("VK_LAYER_KHRONOS_validation");
  if (wantValidation && !validation_) {
    if (options.requireValidation)
      throw Error("Vulkan validation was requested but VK_LAYER_KHRONOS_validation is not installed "
                  "(Debian: apt-get install vulkan-validationlayers)");
    std::cerr << "warning: VK_LAYER_KHRONOS_validation not found; running without validation\n";
  }

  parseFaults(options.faults);

  VkApplicationInfo app{VK_STRUCTURE_TYPE_APPLICATION_INFO};
  app.pApplicationName = "handson";
  app.applicationVersion = VK_MAKE_VERSION(0, 1, 0);
  app.pEngineName = "handson";
  app.apiVersion = VK_API_VERSION_1_3;

  std::vector<const char*> layers;
  std::vector<const char*> exts;
  for (const auto& e : options.instanceExtensions) exts.push_back(e.c_str());
  syncValidation_ = validation_ && options.syncValidation && !envFlag("HANDSON_NO_SYNC_VALIDATION");
  gpuAssisted_ = validation_ && (options.gpuAssistedValidation || envFlag("HANDSON_GPU_VALIDATION"));
  std::vector<VkValidationFeatureEnableEXT> enables;
  if (syncValidation_) enables.push_back(VK_VALIDATION_FEATURE_ENABLE_SYNCHRONIZATION_VALIDATION_EXT);
  if (gpuAssisted_) {
    enables.push_back(VK_VALIDATION_FEATURE_ENABLE_GPU_ASSISTED_EXT);
    enables.push_back(VK_VALIDATION_FEATURE_ENABLE_GPU_ASSISTED_RESERVE_BINDING_SLOT_EXT);
  }
  if (validation_) {
    layers.push_back("VK_LAYER_KHRONOS_validation");
    exts.push_back(VK_EXT_DEBUG_UTILS_EXTENSION_NAME);
  }
  if (!enables.empty()) exts.push_back(VK_EXT_VALIDATION_FEATURES_EXTENSION_NAME);
  VkDebugUtilsMessengerCreateInfoEXT dbg{VK_STRUCTURE_TYPE_DEBUG_UTILS_MESSENGER_CREATE_INFO_EXT};
  dbg.messageSeverity = VK_DEBUG_UTILS_MESSAGE_SEVERITY_WARNING_BIT_EXT | VK_DEBUG_UTILS_MESSAGE_SEVERITY_ERROR_BIT_EXT;
  dbg.messageType = VK_DEBUG_UTILS_MESSAGE_TYPE_GENERAL_BIT_EXT | VK_DEBUG_UTILS_MESSAGE_TYPE_VALIDATION_BIT_EXT |
                    VK_DEBUG_UTILS_MESSAGE_TYPE_PERFORMANCE_BIT_EXT;
  dbg.pfnUserCallback = &Context::debugCallback;
  dbg.pUserData = this;

  VkInstanceCreateInfo ci{VK_STRUCTURE_TYPE_INSTANCE_CREATE_INFO};
  ci.pApplicationInfo = &app;
  ci.enabledLayerCount = std::uint32_t(layers.size());
  ci.ppEnabledLayerNames = layers.data();
  ci.enabledExtensionCount = std::uint32_t(exts.size());
  ci.ppEnabledExtensionNames = exts.data();
  // Synchronization and GPU-assisted validation ride on the messenger's chain: features -> debug info.
  VkValidationFeaturesEXT features{VK_STRUCTURE_TYPE_VALIDATION_FEATURES_EXT};
  features.enabledValidationFeatureCount = std::uint32_t(enables.size());
  features.pEnabledValidationFeatures = enables.data();
  features.pNext = &dbg;
  if (validation_) ci.pNext = enables.empty() ? static_cast<const void*>(&dbg) : static_cast<const void*>(&features);
  VkResult r = vkCreateInstance(&ci, nullptr, &instance_);
  if (r == VK_ERROR_INCOMPATIBLE_DRIVER || r == VK_ERROR_INITIALIZATION_FAILED)
    throw Error("no Vulkan 1.3 driver found (on Debian: apt-get install mesa-vulkan-drivers for the CPU driver lavapipe)");
  check(r, "vkCreateInstance");
  try {
    if (validation_) {
      auto create = reinterpret_cast<PFN_vkCreateDebugUtilsMessengerEXT>(
          vkGetInstanceProcAddr(instance_, "vkCreateDebugUtilsMessengerEXT"));
      if (create) check(create(instance_, &dbg, nullptr, &messenger_), "vkCreateDebugUtilsMessengerEXT");
    }
    if (options.makeSurface) {
      surface_ = options.makeSurface(instance_);
      if (!surface_) throw Error("could not create a Vulkan surface for the window");
    }
    pickDevice(options);
  } catch (...) {
    release();
    throw;
  }
}

// The devices this context can use: Vulkan 1.3, a queue family with compute (and graphics that
// can present, with a window), push descriptors and the extensions asked for.
std::vector<Context::DeviceCandidate> Context::usableDevices(const ContextOptions& options) const {
  std::uint32_t n = 0;
  check(vkEnumeratePhysicalDevices(instance_, &n, nullptr), "vkEnumeratePhysicalDevices");
  if (n == 0) throw Error("no Vulkan device found (on Debian: apt-get install mesa-vulkan-drivers for lavapipe)");
  std::vector<VkPhysicalDevice> devs(n);
  check(vkEnumeratePhysicalDevices(instance_, &n, devs.data()), "vkEnumeratePhysicalDevices");

  std::vector<DeviceCandidate> usable;
  for (std::uint32_t i = 0; i < n; ++i) {
    VkPhysicalDeviceProperties p;
    vkGetPhysicalDeviceProperties(devs[i], &p);
    if (p.apiVersion < VK_API_VERSION_1_3) continue;
    std::uint32_t qn = 0;
    vkGetPhysicalDeviceQueueFamilyProperties(devs[i], &qn, nullptr);
    std::vector<VkQueueFamilyProperties> q(qn);
    vkGetPhysicalDeviceQueueFamilyProperties(devs[i], &qn, q.data());
    int family = -1;
    // Prefer a family that can also draw (the window path presents from it), else compute only.
    auto canPresent = [&](std::uint32_t f) {
      if (!surface_) return true;
      VkBool32 ok = VK_FALSE;
      return vkGetPhysicalDeviceSurfaceSupportKHR(devs[i], f, surface_, &ok) == VK_SUCCESS && ok;
    };
    for (std::uint32_t f = 0; f < qn && family < 0; ++f)
      if ((q[f].queueFlags & VK_QUEUE_COMPUTE_BIT) && (q[f].queueFlags & VK_QUEUE_GRAPHICS_BIT) && canPresent(f)) family = int(f);
    for (std::uint32_t f = 0; f < qn && family < 0 && !surface_; ++f)
      if (q[f].queueFlags & VK_QUEUE_COMPUTE_BIT) family = int(f);
    if (family < 0) continue;
    // Push descriptors are required.
    bool ok = deviceHasExtension(devs[i], VK_KHR_PUSH_DESCRIPTOR_EXTENSION_NAME);
    for (const auto& need : options.deviceExtensions) ok = ok && deviceHasExtension(devs[i], need.c_str());
    if (!ok) continue;
    usable.push_back({devs[i], p, std::uint32_t(family), int(i)});
  }
  if (usable.empty())
    throw Error(surface_ ? "no Vulkan 1.3 device can present to this window with compute and VK_KHR_push_descriptor"
                         : "no Vulkan 1.3 device with compute and VK_KHR_push_descriptor was found");

  return usable;
}

// The device asked for (`want`: "cpu", "gpu", an index or part of a name; empty: the best type).
const Context::DeviceCandidate& Context::chooseDevice(const std::vector<DeviceCandidate>& usable, const std::string& want) {
  const DeviceCandidate* chosen = nullptr;
  if (want.empty()) {
    chosen = &*std::max_element(usable.begin(), usable.end(), [](const DeviceCandidate& a, const DeviceCandidate& b) {
      return typeScore(a.props.deviceType) < typeScore(b.props.deviceType);
    });
  } else {
    std::string lw = want;
    std::transform(lw.begin(), lw.end(), lw.begin(), ::tolower);
    const bool numeric = std::all_of(lw.begin(), lw.end(), ::isdigit);
    for (const auto& c : usable) {
      std::string name = c.props.deviceName;
      std::transform(name.begin(), name.end(), name.begin(), ::tolower);
      const bool isCpu = c.props.deviceType == VK_PHYSICAL_DEVICE_TYPE_CPU;
      if ((lw == "cpu" && isCpu) || (lw == "gpu" && !isCpu) || (numeric && std::to_string(c.index) == lw) ||
          (!numeric && lw != "cpu" && lw != "gpu" && name.find(lw) != std::string::npos)) {
        if (!chosen || typeScore(c.props.deviceType) > typeScore(chosen->props.deviceType)) chosen = &c;
      }
    }
    if (!chosen) {
      std::ostringstream msg;
      msg << "no Vulkan device matches '" << want << "'; available:";
      for (const auto& c : usable) msg << " [" << c.index << "] " << c.props.deviceName << " (" << deviceTypeName(c.props.deviceType) << ")";
      throw Error(msg.str());
    }
  }

  return *chosen;
}

void Context::pickDevice(const ContextOptions& options) {
  std::string want = options.device;
  if (want.empty())
    if (const char* env = std::getenv("HANDSON_DEVICE")) want = env;
  const std::vector<DeviceCandidate> usable = usableDevices(options);
  const DeviceCandidate* chosen = &chooseDevice(usable, want);
  physical_ = chosen->dev;
  props_ = chosen->props;
  queueFamily_ = chosen->family;
  summary_ = {props_.deviceName, props_.deviceType, props_.apiVersion};
  vkGetPhysicalDeviceMemoryProperties(physical_, &memProps_);
  {
    std::uint32_t qn = 0;
    vkGetPhysicalDeviceQueueFamilyProperties(physical_, &qn, nullptr);
    std::vector<VkQueueFamilyProperties> q(qn);
    vkGetPhysicalDeviceQueueFamilyProperties(physical_, &qn, q.data());
    timestampPeriod_ = q[queueFamily_].timestampValidBits ? double(props_.limits.timestampPeriod) : 0.0;
  }
  if (options.verbose)
    std::cerr << "Vulkan device: " << props_.deviceName << " (" << deviceTypeName(props_.deviceType) << ")\n";

  createDevice(options);
}

// The logical device on physical_ with its queue, features, extensions and command pool.
void Context::createDevice(const ContextOptions& options) {
  const float priority = 1.0f;
  VkDeviceQueueCreateInfo qci{VK_STRUCTURE_TYPE_DEVICE_QUEUE_CREATE_INFO};
  qci.queueFamilyIndex = queueFamily_;
  qci.queueCount = 1;
  qci.pQueuePriorities = &priority;
  std::vector<const char*> dexts{VK_KHR_PUSH_DESCRIPTOR_EXTENSION_NAME};
  for (const auto& e : options.deviceExtensions) dexts.push_back(e.c_str());
  VkPhysicalDeviceVulkan13Features f13{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_3_FEATURES};
  f13.synchronization2 = VK_TRUE;
  VkPhysicalDeviceFeatures2 f2{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_FEATURES_2};
  f2.pNext = &f13;
  {
    // The deformation passes write R16_UNORM / R8_UNORM storage images (r16, r8 in GLSL).
    VkPhysicalDeviceFeatures have{};
    vkGetPhysicalDeviceFeatures(physical_, &have);
    f2.features.shaderStorageImageExtendedFormats = have.shaderStorageImageExtendedFormats;
    storageExtendedFormats_ = have.shaderStorageImageExtendedFormats == VK_TRUE;
  }
  // Present timing: both extensions and both features, or neither.
  VkPhysicalDevicePresentIdFeaturesKHR presentId{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_PRESENT_ID_FEATURES_KHR};
  VkPhysicalDevicePresentWaitFeaturesKHR presentWait{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_PRESENT_WAIT_FEATURES_KHR};
  if (options.presentTiming && deviceHasExtension(physical_, VK_KHR_PRESENT_ID_EXTENSION_NAME) &&
      deviceHasExtension(physical_, VK_KHR_PRESENT_WAIT_EXTENSION_NAME)) {
    presentId.pNext = &presentWait;
    VkPhysicalDeviceFeatures2 query{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_FEATURES_2};
    query.pNext = &presentId;
    vkGetPhysicalDeviceFeatures2(physical_, &query);
    presentWait_ = presentId.presentId == VK_TRUE && presentWait.presentWait == VK_TRUE;
    if (presentWait_) {
      dexts.push_back(VK_KHR_PRESENT_ID_EXTENSION_NAME);
      dexts.push_back(VK_KHR_PRESENT_WAIT_EXTENSION_NAME);
      presentWait.pNext = nullptr;
      f13.pNext = &presentId;
    }
  }
  VkDeviceCreateInfo dci{VK_STRUCTURE_TYPE_DEVICE_CREATE_INFO};
  dci.pNext = &f2;
  dci.queueCreateInfoCount = 1;
  dci.pQueueCreateInfos = &qci;
  dci.enabledExtensionCount = std::uint32_t(dexts.size());
  dci.ppEnabledExtensionNames = dexts.data();
  check(vkCreateDevice(physical_, &dci, nullptr, &device_), "vkCreateDevice");
  vkGetDeviceQueue(device_, queueFamily_, 0, &queue_);
  cmdPushDescriptorSet =
      reinterpret_cast<PFN_vkCmdPushDescriptorSetKHR>(vkGetDeviceProcAddr(device_, "vkCmdPushDescriptorSetKHR"));
  if (!cmdPushDescriptorSet) throw Error("Vulkan: vkCmdPushDescriptorSetKHR is not available");
  if (presentWait_) {
    waitForPresent = reinterpret_cast<PFN_vkWaitForPresentKHR>(vkGetDeviceProcAddr(device_, "vkWaitForPresentKHR"));
    presentWait_ = waitForPresent != nullptr;
  }
  VkCommandPoolCreateInfo pci{VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO};
  pci.flags = VK_COMMAND_POOL_CREATE_RESET_COMMAND_BUFFER_BIT | VK_COMMAND_POOL_CREATE_TRANSIENT_BIT;
  pci.queueFamilyIndex = queueFamily_;
  check(vkCreateCommandPool(device_, &pci, nullptr, &pool_), "vkCreateCommandPool");
}

Context::~Context() { release(); }

void Context::release() {
  if (device_) {
    vkDeviceWaitIdle(device_);
    if (pool_) vkDestroyCommandPool(device_, pool_, nullptr);
    vkDestroyDevice(device_, nullptr);
    device_ = VK_NULL_HANDLE;
  }
  if (surface_) {
    vkDestroySurfaceKHR(instance_, surface_, nullptr);
    surface_ = VK_NULL_HANDLE;
  }
  if (messenger_) {
    auto destroy = reinterpret_cast<PFN_vkDestroyDebugUtilsMessengerEXT>(
        vkGetInstanceProcAddr(instance_, "vkDestroyDebugUtilsMessengerEXT"));
    if (destroy) destroy(instance_, messenger_, nullptr);
    messenger_ = VK_NULL_HANDLE;
  }
  if (instance_) {
    vkDestroyInstance(instance_, nullptr);
    instance_ = VK_NULL_HANDLE;
  }
}

std::uint32_t Context::findMemoryType(std::uint32_t typeBits, VkMemoryPropertyFlags want) const {
  for (std::uint32_t i = 0; i < memProps_.memoryTypeCount; ++i)
    if ((typeBits & (1u << i)) && (memProps_.memoryTypes[i].propertyFlags & want) == want) return i;
  throw Error("Vulkan: no memory type with the required properties");
}

void Context::submitAndWait(const std::function<void(VkCommandBuffer)>& record) const {
  std::lock_guard<std::mutex> lock(submitMutex_);
  VkCommandBufferAllocateInfo ai{VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO};
  ai.commandPool = pool_;
  ai.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
  ai.commandBufferCount = 1;
  VkCommandBuffer cmd = VK_NULL_HANDLE;
  check(vkAllocateCommandBuffers(device_, &ai, &cmd), "vkAllocateCommandBuffers");
  VkFence fence = VK_NULL_HANDLE;
  auto cleanup = [&] {
    if (fence) vkDestroyFence(device_, fence, nullptr);
    vkFreeCommandBuffers(device_, pool_, 1, &cmd);
  };
  try {
    VkCommandBufferBeginInfo bi{VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO};
    bi.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT;
    check(vkBeginCommandBuffer(cmd, &bi), "vkBeginCommandBuffer");
    record(cmd);
    check(vkEndCommandBuffer(cmd), "vkEndCommandBuffer");
    VkFenceCreateInfo fci{VK_STRUCTURE_TYPE_FENCE_CREATE_INFO};
    check(vkCreateFence(device_, &fci, nullptr, &fence), "vkCreateFence");
    VkSubmitInfo si{VK_STRUCTURE_TYPE_SUBMIT_INFO};
    si.commandBufferCount = 1;
    si.pCommandBuffers = &cmd;
    check(injectedFault(FaultSite::Submit) ? VK_ERROR_DEVICE_LOST : vkQueueSubmit(queue_, 1, &si, fence), "vkQueueSubmit");
    check(vkWaitForFences(device_, 1, &fence, VK_TRUE, UINT64_MAX), "vkWaitForFences");
  } catch (...) {
    vkQueueWaitIdle(queue_);
    cleanup();
    throw;
  }
  cleanup();
}

VkDeviceSize Context::deviceLocalHeapBytes() const {
  VkDeviceSize best = 0;
  for (std::uint32_t h = 0; h < memProps_.memoryHeapCount; ++h)
    if (memProps_.memoryHeaps[h].flags & VK_MEMORY_HEAP_DEVICE_LOCAL_BIT) best = std::max(best, memProps_.memoryHeaps[h].size);
  // A user's cap (a GPU shared with other work).
  if (const char* env = std::getenv("HANDSON_GPU_MEMORY_LIMIT_MB"); env && *env) {
    char* end = nullptr;
    const double mb = std::strtod(env, &end);
    if (end && *end == '\0' && mb > 0 && mb * double(1u << 20) < double(best)) best = VkDeviceSize(mb * double(1u << 20));
  }
  return best;
}

void Context::parseFaults(const std::string& given) {
  std::string spec = given;
  if (spec.empty())
    if (const char* env = std::getenv("HANDSON_FAULT")) spec = env;
  std::stringstream list(spec);
  std::string item;
  while (std::getline(list, item, ',')) {
    if (item.empty()) continue;
    const auto colon = item.find(':');
    const std::string site = item.substr(0, colon);
    long long n = 0;
    std::size_t used = 0;
    try {
      n = colon == std::string::npos ? 0 : std::stoll(item.substr(colon + 1), &used);
    } catch (const std::exception&) {
      n = 0;
    }
    if (colon == std::string::npos || n < 1 || used != item.size() - colon - 1 || (site != "alloc" && site != "device-lost"))
      throw Error("HANDSON_FAULT: '" + item + "' is not alloc:N or device-lost:N (N >= 1)");
    Fault& f = faults_[site == "alloc" ? int(FaultSite::AllocateMemory) : int(FaultSite::Submit)];
    f.at = std::uint64_t(n);
    f.sticky = site == "device-lost";
  }
}

bool Context::injectedFault(FaultSite site) const {
  const Fault& f = faults_[int(site)];
  if (f.at == 0) return false;
  const std::uint64_t call = ++f.calls;
  const bool fail = f.sticky ? call >= f.at : call == f.at;
  if (fail && call == f.at)
    std::cerr << "note: injected fault: " << (site == FaultSite::AllocateMemory ? "vkAllocateMemory" : "queue submission") << " #" << call
              << " fails (HANDSON_FAULT)\n";
  return fail;
}

}  // namespace handson::vk
