#pragma once
// Transfer functions: piecewise-linear colour and opacity over image values, sampled into a lookup
// table (gpu::kTfEntries entries) spanning the volume's value window. Presets for CT (abdomen soft
// tissue with contrast-enhanced vessels, soft tissue without contrast, bone) and a generic MRI
// preset defined on percentiles. Any of them can be windowed (level, window, opacity) by touch.
// Opacities are per millimetre of ray (the raymarch corrects them for its step).
#include <glm/glm.hpp>
#include <cmath>
#include <string>
#include <vector>

#include "sim/volume.h"
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
  /// The soft tissue the preset was drawn to show: its peak (image units); the automatic window
  /// (render/auto_window.h) moves it onto a region's. NaN: none.
  float tissuePeak = std::nanf("");

  /// Colour and opacity at an image value (linear between points).
  glm::vec4 evaluate(float value) const;
  /// Lookup table over the quantized volume's value window; relative presets use its percentiles.
  std::vector<glm::vec4> lookupTable(const QuantizedVolume& volume) const;

  /// Where the function becomes visible: the last zero-opacity point before the first point with
  /// opacity (the first point's value if that one has opacity already). The window's anchor.
  float visibleFrom() const;
  /// The function's width: from visibleFrom() to the first value where opacity reaches half its
  /// largest, at least 1 % of the points' span (and > 0). The level moves by it per viewport height.
  float width() const;
  /// Windowed: each point's value v moves to a + (v - a) * scale + shift (a = visibleFrom()), its
  /// opacity multiplies by `opacity` (clamped to 1). scale > 0, all finite; identity at (1, 0, 1).
  TransferFunction windowed(double scale, double shift, double opacity) const;
};

/// Names: "ct-abdomen", "ct-soft-tissue", "ct-bone", "mri". Throws handson::Error on an unknown name, listing them.
TransferFunction transferFunctionPreset(const std::string& name);
std::vector<std::string> transferFunctionPresetNames();
/// The preset a volume opens with: "ct-abdomen" when its values look like Hounsfield units (air near
/// -1000 present and a signed range), else "mri".
std::string defaultPresetFor(const Volume& v);
/// Reads a text file: optional "relative" line, then lines "value r g b a" ('#' comments).
TransferFunction loadTransferFunction(const std::string& path);
/// Opaque white above `threshold` (a step), transparent below: for picking tests and iso-surfaces.
TransferFunction thresholdTransferFunction(float threshold);

}  // namespace handson
