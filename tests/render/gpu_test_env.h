#pragma once
// One Vulkan context for all GPU tests, with the Khronos validation layer required. GpuTest
// fails any test during which the layer reported a message.
#include <gtest/gtest.h>

#include "render/vk_context.h"

namespace handson::test {

/// The shared context (created on first use). Device: HANDSON_DEVICE or automatic.
vk::Context& gpuContext();

class GpuTest : public ::testing::Test {
 protected:
  void SetUp() override { gpuContext().resetValidationMessages(); }
  void TearDown() override {
    const auto& ctx = gpuContext();
    EXPECT_EQ(ctx.validationMessageCount(), 0u) << "Vulkan validation messages:\n" << [&] {
      std::string all;
      for (const auto& m : ctx.validationMessages()) all += m + "\n";
      return all;
    }();
  }
};

}  // namespace handson::test
