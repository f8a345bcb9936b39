// Every test binary's main: the environment the suite runs in is set here, before any test, so that
// a test binary run by hand behaves as it does under ctest, and the `handson` processes the tests
// start inherit it. (ctest's ENVIRONMENT property cannot carry it: gtest_discover_tests flattens a
// list-valued property, so every variable after the first was silently dropped.)
//   HANDSON_VALIDATION=1   the Khronos validation layer in every Vulkan context (tests fail on any message)
//   HANDSON_CACHE_DIR      the build tree's test-cache/, never the user's preprocessing cache
//   HANDSON_CHECK_GRAPH=1  every frame graph's barriers checked when it compiles (render/graph_check.h)
// Under the sanitizers (HANDSON_SANITIZE), binaries that load a Vulkan driver run without
// LeakSanitizer: lavapipe and the validation layer leak on unload from modules already unmapped (no
// frames to suppress by name). Vulkan objects are still checked: the validation layer reports any we
// fail to destroy. The binaries without Vulkan keep leak detection.
#include <gtest/gtest.h>

#include <cstdlib>
#include <string>

#if defined(HANDSON_TEST_SANITIZED)
extern "C" {
// Read by the sanitizer runtimes at start-up (ASAN_OPTIONS / UBSAN_OPTIONS in the environment still win).
const char* __asan_default_options() {
#if defined(HANDSON_TEST_VULKAN)
  return "detect_leaks=0";
#else
  return "";
#endif
}
const char* __ubsan_default_options() { return "print_stacktrace=1"; }
}
#endif

#if defined(HANDSON_TEST_SANITIZED)
namespace {

/// `name` gets `option` appended (a sanitizer option list is colon-separated).
void appendOption(const char* name, const std::string& option) {
  const char* now = std::getenv(name);
  std::string value = now && *now ? std::string(now) + ":" + option : option;
  setenv(name, value.c_str(), 1);
}

}  // namespace
#endif

int main(int argc, char** argv) {
  setenv("HANDSON_VALIDATION", "1", 1);
  setenv("HANDSON_CACHE_DIR", HANDSON_TEST_CACHE_DIR, 1);
  setenv("HANDSON_CHECK_GRAPH", "1", 1);
#if defined(HANDSON_TEST_SANITIZED)
  // For the processes the tests start (the sanitized `handson` binary loads a Vulkan driver).
  appendOption("ASAN_OPTIONS", "detect_leaks=0");
  appendOption("UBSAN_OPTIONS", "print_stacktrace=1");
#endif
  ::testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
