#pragma once
// Transfer functions: piecewise-linear colour and opacity over image values, sampled into a lookup
// table (gpu::kTfEntries entries) spanning the volume's value window. Presets for CT (abdomen soft
// tissue with contrast-enhanced vessels, bone) and a generic MRI preset defined on percentiles.
// Opacities are per millimetre of ray (the raymarch corrects them for its step).
#include <glm/glm.hpp>
#include <string>
#include <vector>

#include "volume_texture.h"

namespace handson {

struct TfPoint {
  float value;      ///< image value (HU for CT), or a fraction of the [p1, p99] range if relative
  glm::vec4 rgba;   ///< colour 0..1 and opacity per mm 0..1
};

struct TransferFunction {
  std::string name;
  bool relative = false;  ///< values are fractions of the volume's [1st, 99th] percentile range
  std::vector<TfPoint> points;  ///< sorted by value; constant extension outside

  /// Colour and opacity at an image value (linear between points).
  glm::vec4 evaluate(float value) const;
  /// Lookup table over the quantized volume's value window; relative presets use its percentiles.
  std::vector<glm::vec4> lookupTable(const QuantizedVolume& volume) const;
};

/// Names: "ct-abdomen", "ct-bone", "mri". Throws handson::Error on an unknown name, listing them.
TransferFunction transferFunctionPreset(const std::string& name);
std::vector<std::string> transferFunctionPresetNames();
/// Reads a text file: optional "relative" line, then lines "value r g b a" ('#' comments).
TransferFunction loadTransferFunction(const std::string& path);
/// Opaque white above `threshold` (a step), transparent below: for picking tests and iso-surfaces.
TransferFunction thresholdTransferFunction(float threshold);

}  // namespace handson
