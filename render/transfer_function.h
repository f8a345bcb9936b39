#pragma once
// Transfer functions: piecewise-linear colour and opacity over image values, sampled into a lookup
// table (render/tf_table.h: gpu::kTfEntries entries a row) spanning the volume's value window. Presets for CT (abdomen soft
// tissue with contrast-enhanced vessels, soft tissue without contrast, bone, organs told apart) and
// a generic MRI preset defined on percentiles. Any of them can be windowed (level, window, opacity)
// by touch. Opacities are per millimetre of ray (the raymarch corrects them for its step).
//
// Two-dimensional transfer functions (over value and gradient magnitude; Kniss et al. 2002, Levoy
// 1988's gradient-weighted opacity): a function may add a gradient-magnitude axis, a piecewise-linear
// curve g -> (opacity factor, tint), so that
//
//   rgba(v, g) = ( mix(rgb(v), tint(g).rgb, tint(g).a), min(1, a(v) * opacity(g)) ),
//
// which tells materials of one value apart by whether they lie on a boundary (g large) or inside
// (g small). Its table then has gpu::kTfGradientRows rows, row r at g = r / (rows - 1) * the last
// gradient point's magnitude (constant beyond), sampled bilinearly by the raymarch and picking.
#include <glm/glm.hpp>
#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include "sim/volume.h"
#include "tf_table.h"
#include "volume_texture.h"

namespace handson {

struct TfPoint {
  float value;      ///< image value (HU for CT), or a fraction of the [p1, p99] range if relative
  glm::vec4 rgba;   ///< colour 0..1 and opacity per mm 0..1
};

/// One point of the gradient-magnitude axis.
struct TfGradientPoint {
  float magnitude;  ///< gradient magnitude, image units per mm (fractions of the [p1, p99] range per mm if relative)
  float opacity;    ///< factor on the value's opacity (>= 0)
  glm::vec4 tint;   ///< rgb mixed into the value's colour with weight a (0..1)
};

struct TransferFunction {
  std::string name;
  bool relative = false;  ///< values are fractions of the volume's [1st, 99th] percentile range
  std::vector<TfPoint> points;  ///< sorted by value; constant extension outside
  std::vector<TfGradientPoint> gradient;  ///< sorted by magnitude, constant extension; empty: over value alone
  /// The soft tissue the preset was drawn to show: its peak (image units); the automatic window
  /// (render/auto_window.h) moves it onto a region's. NaN: none.
  float tissuePeak = std::nanf("");

  /// Colour and opacity at an image value (linear between points).
  glm::vec4 evaluate(float value) const;
  /// Colour and opacity at an image value and gradient magnitude (image units per mm): as above
  /// when the function has no gradient axis.
  glm::vec4 evaluate(float value, float gradientMagnitude) const;
  /// Lookup table over the quantized volume's value window (and gradient magnitude, when the
  /// function has that axis); relative functions use its percentiles.
  TfTable lookupTable(const QuantizedVolume& volume) const;

  /// Where the function becomes visible: the last zero-opacity point before the first point with
  /// opacity (the first point's value if that one has opacity already). The window's anchor.
  float visibleFrom() const;
  /// The function's width: from visibleFrom() to the first value where opacity reaches half its
  /// largest, at least 1 % of the points' span (and > 0). The level moves by it per viewport height.
  float width() const;
  /// Windowed: each point's value v moves to a + (v - a) * scale + shift (a = visibleFrom()), its
  /// opacity multiplies by `opacity` (clamped to 1), and the gradient axis stretches with the values
  /// (magnitudes times scale). scale > 0, all finite; identity at (1, 0, 1).
  TransferFunction windowed(double scale, double shift, double opacity) const;
};

/// Names: "ct-abdomen", "ct-soft-tissue", "ct-organs", "ct-bone", "mri". Throws handson::Error on an unknown name, listing them.
TransferFunction transferFunctionPreset(const std::string& name);
std::vector<std::string> transferFunctionPresetNames();
/// The preset a volume opens with: "ct-abdomen" when its values look like Hounsfield units (air near
/// -1000 present and a signed range), else "mri".
std::string defaultPresetFor(const Volume& v);
/// Reads a text file: optional "relative" line, lines "value r g b a", and optional gradient lines
/// "gradient magnitude opacity r g b w" ('#' comments); both kinds in increasing order.
TransferFunction loadTransferFunction(const std::string& path);
/// Opaque white above `threshold` (a step), transparent below: for picking tests and iso-surfaces.
TransferFunction thresholdTransferFunction(float threshold);

}  // namespace handson
