#include "interaction/cut_stroke.h"

#include <charconv>
#include <cmath>
#include <string>

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

std::string formatCutQuads(const std::vector<CutQuad>& quads) {
  std::string out;
  char num[32];
  for (std::size_t q = 0; q < quads.size(); ++q)
    for (int c = 0; c < 4; ++c)
      for (int a = 0; a < 3; ++a) {
        const auto r = std::to_chars(num, num + sizeof num, quads[q].corners[std::size_t(c)][a]);  // shortest round-trip form
        out += (q == 0 && c == 0 && a == 0) ? "" : (c == 0 && a == 0) ? ";" : ",";
        out.append(num, r.ptr);
      }
  return out;
}

std::vector<CutQuad> parseCutQuads(std::string_view text) {
  std::vector<CutQuad> quads;
  while (true) {
    const std::size_t end = std::min(text.find(';'), text.size());
    const std::string_view quad = text.substr(0, end);
    std::vector<double> v;
    for (std::size_t at = 0; at <= quad.size();) {
      const std::size_t comma = std::min(quad.find(',', at), quad.size());
      double x = 0.0;
      const char* first = quad.data() + at;
      const char* last = quad.data() + comma;
      const auto r = std::from_chars(first, last, x);
      if (r.ec != std::errc() || r.ptr != last) throw Error("a cut: \"" + std::string(quad.substr(at, comma - at)) + "\" is not a number");
      v.push_back(x);
      at = comma + 1;
    }
    if (v.size() != 12) throw Error("a cut: a quad takes twelve numbers, its four corners X,Y,Z in order (" + std::to_string(v.size()) + " given)");
    CutQuad q;
    for (int c = 0; c < 4; ++c) q.corners[std::size_t(c)] = Eigen::Vector3d(v[std::size_t(3 * c)], v[std::size_t(3 * c + 1)], v[std::size_t(3 * c + 2)]);
    checkCutQuad(q);
    quads.push_back(q);
    if (end == text.size()) return quads;
    text.remove_prefix(end + 1);
  }
}

}  // namespace handson
