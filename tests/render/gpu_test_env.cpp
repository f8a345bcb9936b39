#include "gpu_test_env.h"

#include <memory>

namespace handson::test {

vk::Context& gpuContext() {
  static std::unique_ptr<vk::Context> ctx = [] {
    vk::ContextOptions o;
    o.validation = true;
    o.requireValidation = true;
    o.verbose = true;
    return std::make_unique<vk::Context>(o);
  }();
  return *ctx;
}

}  // namespace handson::test
