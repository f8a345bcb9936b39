// Where pinches grow: the backend option and the automatic choice by device.
#include <gtest/gtest.h>

#include "app/session/selection_backend.h"

using namespace handson;

TEST(SelectionBackend, AutoTakesTheCpuOnACpuDeviceAndTheGpuElsewhereAndAForcedChoiceStands) {
  SelectionBackend b = SelectionBackend::Cpu;
  ASSERT_TRUE(parseSelectionBackend("auto", b));
  EXPECT_EQ(b, SelectionBackend::Auto);
  ASSERT_TRUE(parseSelectionBackend("gpu", b));
  EXPECT_EQ(b, SelectionBackend::Gpu);
  ASSERT_TRUE(parseSelectionBackend("cpu", b));
  EXPECT_EQ(b, SelectionBackend::Cpu);
  EXPECT_FALSE(parseSelectionBackend("GPU", b));
  EXPECT_FALSE(parseSelectionBackend("", b));
  EXPECT_STREQ(selectionBackendName(SelectionBackend::Auto), "auto");

  const auto lavapipe = resolveSelectionBackend(SelectionBackend::Auto, true, "llvmpipe");
  EXPECT_EQ(lavapipe.backend, SelectionBackend::Cpu);
  EXPECT_NE(lavapipe.status.find("auto: llvmpipe is a CPU device"), std::string::npos) << lavapipe.status;
  const auto gpu = resolveSelectionBackend(SelectionBackend::Auto, false, "NVIDIA H200");
  EXPECT_EQ(gpu.backend, SelectionBackend::Gpu);
  EXPECT_NE(gpu.status.find("GPU (auto: NVIDIA H200)"), std::string::npos) << gpu.status;
  EXPECT_EQ(resolveSelectionBackend(SelectionBackend::Gpu, true, "llvmpipe").backend, SelectionBackend::Gpu);
  EXPECT_EQ(resolveSelectionBackend(SelectionBackend::Cpu, false, "NVIDIA H200").backend, SelectionBackend::Cpu);
}
