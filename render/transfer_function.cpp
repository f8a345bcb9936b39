#include "transfer_function.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <sstream>

#include "shaders/shared.h"
#include "sim/base/error.h"

namespace handson {

glm::vec4 TransferFunction::evaluate(float value) const {
  if (points.empty()) return glm::vec4(0.0f);
  if (value <= points.front().value) return points.front().rgba;
  if (value >= points.back().value) return points.back().rgba;
  for (std::size_t i = 1; i < points.size(); ++i) {
    const TfPoint& a = points[i - 1];
    const TfPoint& b = points[i];
    if (value <= b.value) {
      const float span = b.value - a.value;
      const float t = span > 0.0f ? (value - a.value) / span : 1.0f;
      return glm::mix(a.rgba, b.rgba, t);
    }
  }
  return points.back().rgba;
}

namespace {

// The gradient axis at a magnitude: opacity factor (x) and tint (y..: rgb, weight), linear between
// points, constant beyond.
struct GradientSample {
  float opacity = 1.0f;
  glm::vec4 tint{0.0f};
};

GradientSample gradientAt(const std::vector<TfGradientPoint>& g, float magnitude) {
  if (g.empty()) return {};
  if (!(magnitude > g.front().magnitude)) return {g.front().opacity, g.front().tint};
  if (magnitude >= g.back().magnitude) return {g.back().opacity, g.back().tint};
  for (std::size_t i = 1; i < g.size(); ++i) {
    if (magnitude > g[i].magnitude) continue;
    const float span = g[i].magnitude - g[i - 1].magnitude;
    const float t = span > 0.0f ? (magnitude - g[i - 1].magnitude) / span : 1.0f;
    return {g[i - 1].opacity + t * (g[i].opacity - g[i - 1].opacity), glm::mix(g[i - 1].tint, g[i].tint, t)};
  }
  return {g.back().opacity, g.back().tint};
}

// The value's colour c modulated by the gradient axis' sample s (the header's formula).
glm::vec4 withGradient(const glm::vec4& c, const GradientSample& s) {
  const glm::vec3 rgb = glm::mix(glm::vec3(c), glm::vec3(s.tint), std::clamp(s.tint.a, 0.0f, 1.0f));
  return {rgb, std::min(1.0f, c.a * std::max(s.opacity, 0.0f))};
}

}  // namespace

glm::vec4 TransferFunction::evaluate(float value, float gradientMagnitude) const {
  const glm::vec4 c = evaluate(value);
  return gradient.empty() ? c : withGradient(c, gradientAt(gradient, gradientMagnitude));
}

// Table entry (row r, column i) = evaluate(value of column i, magnitude of row r), both in the
// function's own units (a relative function's values and magnitudes are fractions of the volume's
// [p1, p99] range). The row axis in the shader's units: normalized value (0..1 over the volume's
// window) per mm, so gradientTop = the last point's magnitude in image units / (hi - lo).
TfTable TransferFunction::lookupTable(const QuantizedVolume& volume) const {
  float base = 0.0f, scale = 1.0f;
  if (relative) {
    base = volume.percentile(0.01);
    scale = std::max(volume.percentile(0.99) - base, 1e-6f);
  }
  TfTable t;
  const float top = gradient.empty() ? 0.0f : gradient.back().magnitude;
  t.rows = top > 0.0f ? gpu::kTfGradientRows : 1u;
  t.gradientTop = t.rows > 1 ? top * scale / std::max(volume.hi - volume.lo, 1e-6f) : 0.0f;
  t.entries.assign(std::size_t(t.storedRows()) * gpu::kTfEntries, glm::vec4(0.0f));
  // The value curve once per column, the gradient curve once per row.
  std::vector<glm::vec4> byValue(gpu::kTfEntries);
  for (std::uint32_t i = 0; i < gpu::kTfEntries; ++i) {
    const float v = volume.toValue(float(i) / float(gpu::kTfEntries - 1));
    byValue[i] = evaluate(relative ? (v - base) / scale : v);
  }
  for (std::uint32_t r = 0; r < t.rows; ++r) {
    const float g = t.rows > 1 ? top * float(r) / float(t.rows - 1) : 0.0f;
    const GradientSample s = gradientAt(gradient, g);
    for (std::uint32_t i = 0; i < gpu::kTfEntries; ++i) {
      glm::vec4& e = t.entries[std::size_t(r) * gpu::kTfEntries + i];
      e = glm::clamp(gradient.empty() ? byValue[i] : withGradient(byValue[i], s), glm::vec4(0.0f), glm::vec4(1.0f));
      if (t.rows > 1) {
        glm::vec4& envelope = t.entries[std::size_t(t.rows) * gpu::kTfEntries + i];
        envelope = glm::max(envelope, e);
      }
    }
  }
  return t;
}

float TransferFunction::visibleFrom() const {
  for (std::size_t i = 0; i < points.size(); ++i)
    if (points[i].rgba.a > 0.0f) return points[i == 0 ? 0 : i - 1].value;
  return points.empty() ? 0.0f : points.front().value;
}

float TransferFunction::width() const {
  if (points.empty()) return 1.0f;
  const float span = points.back().value - points.front().value;
  const float floor = std::max(0.01f * span, 1e-6f);
  float maxAlpha = 0.0f;
  for (const auto& p : points) maxAlpha = std::max(maxAlpha, p.rgba.a);
  const float from = visibleFrom();
  for (std::size_t i = 0; i < points.size(); ++i) {
    if (points[i].rgba.a < 0.5f * maxAlpha || maxAlpha <= 0.0f) continue;
    // Between points i-1 and i the opacity crosses half its largest value.
    float at = points[i].value;
    if (i > 0 && points[i].rgba.a > points[i - 1].rgba.a) {
      const float t = (0.5f * maxAlpha - points[i - 1].rgba.a) / (points[i].rgba.a - points[i - 1].rgba.a);
      at = points[i - 1].value + std::clamp(t, 0.0f, 1.0f) * (points[i].value - points[i - 1].value);
    }
    return std::max(at - from, floor);
  }
  return std::max(span, floor);
}

TransferFunction TransferFunction::windowed(double scale, double shift, double opacity) const {
  TransferFunction tf = *this;
  if (!(scale > 0.0) || !std::isfinite(scale) || !std::isfinite(shift) || !(opacity >= 0.0) || !std::isfinite(opacity)) return tf;
  const double a = visibleFrom();
  for (auto& p : tf.points) {
    p.value = float(a + (double(p.value) - a) * scale + shift);
    p.rgba.a = float(std::min(1.0, double(p.rgba.a) * opacity));
  }
  for (auto& g : tf.gradient) g.magnitude = float(double(g.magnitude) * scale);
  return tf;
}

namespace {

// Organs told apart: soft tissues a few tens of HU apart (unenhanced kidney ~30, spleen ~45, muscle
// ~50, liver ~60) get hues around the colour circle - a step of 15 HU is a step of hue (CIELAB
// differences of 30-60 between neighbours) - fat clear, bone a thin white. The gradient axis makes
// boundaries (organ against fat: 50-100 HU/mm; the CT's noise alone gives 10-20 HU/mm) more opaque
// and darkens them a little, and interiors more transparent, so each organ's surface reads as one
// outline. Drawn for an unenhanced abdomen (peak 45 HU); the automatic window moves it onto a
// region's own soft-tissue peak, contrast or not.
void ctOrgans(TransferFunction& tf) {
  tf.points = {{-1024, {0, 0, 0, 0}},
               {-30, {0, 0, 0, 0}},
               {0, {0.55f, 0.65f, 0.90f, 0.0f}},
               {15, {0.20f, 0.50f, 0.90f, 0.05f}},
               {30, {0.20f, 0.80f, 0.55f, 0.07f}},
               {45, {0.95f, 0.85f, 0.20f, 0.08f}},
               {60, {0.95f, 0.45f, 0.10f, 0.09f}},
               {75, {0.85f, 0.15f, 0.30f, 0.08f}},
               {100, {0.60f, 0.25f, 0.75f, 0.04f}},
               {200, {0.95f, 0.90f, 0.85f, 0.02f}},
               {400, {1.0f, 0.97f, 0.92f, 0.12f}},
               {3071, {1, 1, 1, 0.25f}}};
  tf.gradient = {{0.0f, 0.6f, {0, 0, 0, 0}}, {20.0f, 0.8f, {0, 0, 0, 0}}, {60.0f, 1.8f, {0.12f, 0.08f, 0.08f, 0.35f}}};
  tf.tissuePeak = 45.0f;
}

}  // namespace

TransferFunction transferFunctionPreset(const std::string& name) {
  TransferFunction tf;
  tf.name = name;
  if (name == "ct-abdomen") {
    // Fat faint yellow, soft tissue and organs translucent red-brown, contrast-enhanced vessels and
    // kidney cortex bright, bone white and opaque.
    tf.points = {{-1024, {0, 0, 0, 0}},
                 {-200, {0, 0, 0, 0}},
                 {-120, {0.85f, 0.75f, 0.45f, 0.0f}},
                 {-80, {0.85f, 0.75f, 0.45f, 0.002f}},
                 {-40, {0.80f, 0.55f, 0.40f, 0.0f}},
                 {0, {0.75f, 0.35f, 0.28f, 0.0f}},
                 {40, {0.75f, 0.35f, 0.28f, 0.002f}},
                 {90, {0.85f, 0.45f, 0.35f, 0.006f}},
                 {140, {0.95f, 0.30f, 0.25f, 0.15f}},
                 {300, {1.0f, 0.55f, 0.45f, 0.4f}},
                 {500, {1.0f, 0.95f, 0.88f, 0.8f}},
                 {3071, {1.0f, 1.0f, 1.0f, 0.95f}}};
    // Drawn for the portal-venous phase: enhanced liver and spleen at 100-120 HU.
    tf.tissuePeak = 110.0f;
  } else if (name == "ct-soft-tissue") {
    // Without contrast, kidneys (~30 HU), spleen (~45), muscle (~50) and liver (~60) lie within a
    // few tens of HU: fat (-100) is clear, soft tissue from 0 to 90 HU is a visible translucent
    // solid coloured from pale (water-like) to deep red (liver), blood clots and calcium faint,
    // bone a thin white so that it does not hide the organs. Clip away the body wall to see inside.
    tf.points = {{-1024, {0, 0, 0, 0}},
                 {-30, {0, 0, 0, 0}},
                 {0, {0.95f, 0.80f, 0.70f, 0.0f}},
                 {20, {0.92f, 0.62f, 0.52f, 0.04f}},
                 {40, {0.85f, 0.42f, 0.35f, 0.08f}},
                 {65, {0.70f, 0.25f, 0.22f, 0.10f}},
                 {95, {0.80f, 0.50f, 0.40f, 0.03f}},
                 {200, {0.95f, 0.90f, 0.80f, 0.02f}},
                 {400, {1.0f, 0.97f, 0.92f, 0.12f}},
                 {3071, {1, 1, 1, 0.25f}}};
    // Drawn for an unenhanced abdomen: kidney, spleen, muscle and liver at 30-60 HU.
    tf.tissuePeak = 45.0f;
  } else if (name == "ct-organs") {
    ctOrgans(tf);
  } else if (name == "ct-bone") {
    tf.points = {{-1024, {0, 0, 0, 0}}, {150, {0, 0, 0, 0}}, {250, {0.9f, 0.8f, 0.65f, 0.3f}}, {700, {1, 0.97f, 0.9f, 0.9f}},
                 {3071, {1, 1, 1, 1}}};
  } else if (name == "mri") {
    // Generic: percentiles of the image's own range, dark background transparent.
    tf.relative = true;
    tf.points = {{0.0f, {0, 0, 0, 0}}, {0.12f, {0, 0, 0, 0}}, {0.3f, {0.6f, 0.5f, 0.45f, 0.03f}}, {0.6f, {0.9f, 0.8f, 0.7f, 0.15f}},
                 {1.0f, {1, 1, 1, 0.5f}}};
  } else {
    std::ostringstream msg;
    msg << "unknown transfer-function preset '" << name << "' (available:";
    for (const auto& n : transferFunctionPresetNames()) msg << ' ' << n;
    msg << ")";
    throw Error(msg.str());
  }
  return tf;
}

std::vector<std::string> transferFunctionPresetNames() { return {"ct-abdomen", "ct-soft-tissue", "ct-organs", "ct-bone", "mri"}; }

std::string defaultPresetFor(const Volume& v) {
  const auto [lo, hi] = v.valueRange();
  return (lo <= -900.0f && hi >= 0.0f) ? "ct-abdomen" : "mri";
}

TransferFunction thresholdTransferFunction(float threshold) {
  TransferFunction tf;
  tf.name = "threshold";
  tf.points = {{threshold - 1e-3f, {0, 0, 0, 0}}, {threshold, {1, 1, 1, 1}}};
  return tf;
}

namespace {

// One "gradient magnitude opacity r g b w" line (after the word "gradient").
TfGradientPoint parseGradientLine(std::istringstream& ls, const std::string& where) {
  TfGradientPoint g{};
  // Bounds: a gradient past 1e6 value units per mm is no image's (CT's steepest, air against bone,
  // is a few thousand HU/mm), and the table's top must stay a normal float in the shaders' units.
  if (!(ls >> g.magnitude >> g.opacity >> g.tint.r >> g.tint.g >> g.tint.b >> g.tint.a) || !(g.magnitude >= 0.0f) ||
      !(g.magnitude <= 1e6f) || !(g.opacity >= 0.0f) || !std::isfinite(g.opacity))
    throw Error(where + ": expected 'gradient magnitude opacity r g b w' (magnitude 0..1e6 and opacity >= 0)");
  return g;
}

}  // namespace

TransferFunction loadTransferFunction(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw Error("cannot open transfer function file '" + path + "'");
  TransferFunction tf;
  tf.name = path;
  std::string line;
  int lineNo = 0;
  while (std::getline(in, line)) {
    ++lineNo;
    if (auto c = line.find('#'); c != std::string::npos) line.resize(c);
    std::istringstream ls(line);
    std::string first;
    if (!(ls >> first)) continue;
    const std::string where = path + ":" + std::to_string(lineNo);
    if (first == "relative") {
      tf.relative = true;
      continue;
    }
    if (first == "gradient") {
      const TfGradientPoint g = parseGradientLine(ls, where);
      if (!tf.gradient.empty() && g.magnitude < tf.gradient.back().magnitude) throw Error(where + ": gradient magnitudes must not decrease");
      tf.gradient.push_back(g);
      continue;
    }
    TfPoint p{};
    try {
      p.value = std::stof(first);
    } catch (...) {
      throw Error(where + ": expected 'value r g b a'");
    }
    if (!(ls >> p.rgba.r >> p.rgba.g >> p.rgba.b >> p.rgba.a) || !std::isfinite(p.value)) throw Error(where + ": expected 'value r g b a'");
    if (!tf.points.empty() && p.value < tf.points.back().value) throw Error(where + ": values must be increasing");
    tf.points.push_back(p);
  }
  if (tf.points.empty()) throw Error("transfer function file '" + path + "' has no points");
  return tf;
}

}  // namespace handson
