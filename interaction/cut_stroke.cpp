#include "interaction/cut_stroke.h"

#include <cmath>

#include "sim/base/error.h"

namespace handson {

namespace {

void checkSamples(const std::vector<StrokeSample>& samples, const CutStrokeOptions& o) {
  if (samples.size() < 2) throw Error("cut: a stroke needs at least two samples");
  if (!(o.depthMm > 0.0) || !std::isfinite(o.depthMm) || !(o.minSegmentMm > 0.0) || !std::isfinite(o.minSegmentMm))
    throw Error("cut: the depth and the segment length must be positive");
  for (const StrokeSample& s : samples)
    if (!s.origin.allFinite() || !s.direction.allFinite() || std::abs(s.direction.norm() - 1.0) > 1e-6 || std::isinf(s.surfaceMm) || s.surfaceMm < 0.0)
      throw Error("cut: a stroke sample is not a finite ray with a unit direction");
  if (!std::isfinite(samples.front().surfaceMm)) throw Error("cut: the stroke must start on the tissue (its first pick missed)");
}

// Whether the sample has tissue above the cut's bottom under it.
bool cuts(const StrokeSample& s, double bottom) { return std::isfinite(s.surfaceMm) && s.surfaceMm < bottom; }

}  // namespace

CutStroke cutAlongStroke(const std::vector<StrokeSample>& samples, const CutStrokeOptions& o) {
  checkSamples(samples, o);
  const double bottom = samples.front().surfaceMm + o.depthMm;
  auto surface = [&](const StrokeSample& s) { return Eigen::Vector3d(s.origin + s.surfaceMm * s.direction); };
  CutStroke out;
  std::size_t last = 0;  // the last sample kept (with tissue under it)
  for (std::size_t i = 1; i < samples.size(); ++i) {
    const StrokeSample &a = samples[last], &b = samples[i];
    if (!cuts(b, bottom)) {  // no cut beneath it: the stroke's cut resumes at the next sample that has one
      ++out.skipped;
      for (++i; i < samples.size() && !cuts(samples[i], bottom); ++i) ++out.skipped;
      if (i < samples.size()) last = i;
      continue;
    }
    if ((surface(b) - surface(a)).norm() < o.minSegmentMm) continue;
    const CutQuad q{{surface(a), surface(b), Eigen::Vector3d(b.origin + bottom * b.direction), Eigen::Vector3d(a.origin + bottom * a.direction)}};
    try {
      checkCutQuad(q);
      out.quads.push_back(q);
      last = i;
    } catch (const Error&) {  // the two rays span no plane (no common eye, not parallel): the next sample may, with the same start
      ++out.skipped;
    }
  }
  if (out.quads.empty()) throw Error("cut: the stroke leaves nothing to cut (it did not move, or no tissue under it lies above the cut's bottom)");
  return out;
}

}  // namespace handson
