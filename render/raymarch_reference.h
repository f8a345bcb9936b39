#pragma once
// CPU references of the raymarch and pick passes (shaders/raymarch.comp, shaders/pick.comp): the
// same ray setup, sampling, transfer function, compositing, shading, skipping and termination,
// written in C++ for GPU-vs-CPU tests. Trilinear sampling follows Vulkan's clamp-to-edge linear
// filter rule; GPUs may filter with reduced weight precision, hence tolerances in the tests.
#include <glm/glm.hpp>
#include <cstdint>
#include <vector>

#include "shaders/shared.h"
#include "tf_table.h"
#include "volume_texture.h"

namespace handson {

struct ReferenceScene {
  const QuantizedVolume* volume = nullptr;
  const TfTable* lut = nullptr;
  const std::vector<std::uint32_t>* occupancy = nullptr;
  const std::vector<std::uint8_t>* mask = nullptr;         ///< handle ids on the volume grid (null: none)
  const std::vector<glm::vec4>* handleTints = nullptr;     ///< gpu::kMaxHandleIds entries
  const std::vector<float>* strain = nullptr;              ///< strain on the volume grid (the overlay; null: none)
  const std::vector<std::uint16_t>* labels = nullptr;      ///< organ labels on the volume grid (the label tint; null: none)
  const std::vector<float>* strainOverLimit = nullptr;     ///< strain over its tissue's limit on the volume grid (the highlight; null: none)
};

/// RGBA8 image (width = params.outputWidth, height = params.outputHeight), row 0 at the top. With
/// gpu::kFlagAccumulate, `accumulation` is the still frame's running sum (rgb per pixel, resized and
/// zeroed when its size differs), read and written as the raymarch reads and writes kBindAccum.
std::vector<std::uint8_t> raymarchReference(const ReferenceScene& scene, const gpu::RenderParams& params,
                                            std::vector<glm::vec3>* accumulation = nullptr);

/// One result per NDC point, as pick.comp writes them.
std::vector<gpu::PickResult> pickReference(const ReferenceScene& scene, const gpu::RenderParams& params,
                                           const std::vector<glm::vec2>& ndcPoints);

}  // namespace handson
