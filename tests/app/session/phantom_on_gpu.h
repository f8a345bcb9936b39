#pragma once
// The session tests' GPU scene (test_deformation_controller.cpp, test_frame_driver.cpp): a Vulkan
// context with the validation layer required, the phantom, its quantized volume and a renderer
// holding it.
#include <memory>

#include "render/volume_renderer.h"
#include "render/vk_context.h"
#include "sim/phantom.h"
#include "sim/quantized_volume.h"

namespace handson::test {

struct PhantomOnGpu {
  std::unique_ptr<vk::Context> ctx;
  Phantom phantom;
  QuantizedVolume q;
  std::unique_ptr<VolumeRenderer> renderer;
  explicit PhantomOnGpu(double spacingMm = 4.0) {
    vk::ContextOptions co;
    co.validation = true;
    co.requireValidation = true;
    ctx = std::make_unique<vk::Context>(co);
    PhantomOptions po;
    po.spacingMm = spacingMm;
    phantom = makePhantom(po);
    q = quantizeVolume(phantom.ct);
    renderer = std::make_unique<VolumeRenderer>(*ctx);
    renderer->setVolume(q);
  }
};

}  // namespace handson::test
