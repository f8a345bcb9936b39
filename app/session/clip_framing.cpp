#include "app/session/clip_framing.h"

namespace handson {

std::vector<HalfSpace> clipHalfSpaces(const ClipRegion& clip) {
  std::vector<HalfSpace> h;
  if (clip.box) h = boxHalfSpaces(glm::dvec3(clip.lo), glm::dvec3(clip.hi));
  if (clip.plane) h.push_back({glm::dvec3(clip.normal), double(clip.offset)});
  return h;
}

std::optional<OrbitCamera> frameClip(const OrbitCamera& from, const VolumeGeometry& geometry, const ClipRegion& clip, FramingView view) {
  if (!clip.box && !clip.plane) return std::nullopt;
  const std::vector<glm::dvec3> corners = clippedVolumeCorners(geometry, clipHalfSpaces(clip));
  if (corners.empty()) return std::nullopt;
  // A region thinner than a voxel in every direction (the clip touches the volume at a corner or
  // an edge) shows nothing to frame.
  glm::dvec3 lo = corners.front(), hi = corners.front();
  for (const glm::dvec3& p : corners) {
    lo = glm::min(lo, p);
    hi = glm::max(hi, p);
  }
  if (!(glm::length(hi - lo) >= geometry.spacing.minCoeff())) return std::nullopt;
  view.sceneDiagonalMm = geometry.diagonalMm();
  return framePoints(from, corners, view);
}

}  // namespace handson
