#pragma once
// A transfer function sampled for one volume (render/transfer_function.h makes it): what the
// renderer uploads to kBindTf and the CPU reference (render/raymarch_reference.h) reads.
#include <glm/glm.hpp>
#include <algorithm>
#include <cstdint>
#include <limits>
#include <vector>

#include "shaders/shared.h"

namespace handson {

struct TfTable {
  /// Row-major rows of gpu::kTfEntries RGBA (0..1): column i at the volume's normalized value
  /// i / (kTfEntries - 1); row r < rows at the gradient magnitude r / (rows - 1) * gradientTop.
  /// With a gradient axis one more row follows, the envelope: at each value the largest of the
  /// rows' entries, channel by channel, which lets a pass skip a sample without computing its
  /// gradient (all rows are transparent where the envelope is, bilinear weights being >= 0).
  std::vector<glm::vec4> entries;
  std::uint32_t rows = 1;    ///< 1 (over value alone) or gpu::kTfGradientRows (value x gradient magnitude)
  float gradientTop = 0.0f;  ///< the last row's gradient magnitude, normalized value per mm (0 with one row)

  /// Rows stored: rows, and the envelope with a gradient axis.
  std::uint32_t storedRows() const { return rows > 1 ? rows + 1 : rows; }
  /// Whether the shape is one the passes read: rows 1 with gradientTop 0, or kTfGradientRows with
  /// gradientTop a normal positive float below 1e30, and storedRows() * kTfEntries entries.
  bool valid() const {
    // A normal float (not a denormal a GPU may flush to 0, which would read as "one row").
    const bool shape = (rows == 1 && gradientTop == 0.0f) ||
                       (rows == gpu::kTfGradientRows && gradientTop >= std::numeric_limits<float>::min() && gradientTop < 1e30f);
    return shape && entries.size() == std::size_t(storedRows()) * gpu::kTfEntries;
  }
  /// The largest opacity at each value over the rows (gpu::kTfEntries): what empty-space skipping
  /// needs; the envelope's with a gradient axis, the one row's without.
  std::vector<float> maxAlpha() const {
    std::vector<float> a(gpu::kTfEntries, 0.0f);
    const std::size_t base = std::size_t(storedRows() - 1) * gpu::kTfEntries;
    for (std::size_t i = 0; i < a.size() && base + i < entries.size(); ++i) a[i] = entries[base + i].a;
    return a;
  }
};

}  // namespace handson
