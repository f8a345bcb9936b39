#pragma once
// The sliding interfaces' slide nodes in the on-disk cache (sim/scene_cache.h, CoarseModel::save).
#include <cmath>
#include <vector>

#include "sim/base/binary_io.h"
#include "sim/sliding_interface.h"

namespace handson::bin {

inline void writeSlideNodes(Writer& w, const std::vector<SlideNode>& slide) {
  w.pod(std::uint64_t(slide.size()));
  for (const SlideNode& s : slide) {
    w.pod(std::int32_t(s.node));
    w.pod(std::int32_t(s.handle));
    w.pod(s.normal);
    w.pod(s.stiffness);
  }
}

/// Throws handson::Error for a node outside the fine mesh (`handleOf`, `fixed`: its roles), held,
/// a handle's own or listed twice, a handle outside `handleCount`, a normal that is not unit or a
/// stiffness that is not finite and >= 0.
inline std::vector<SlideNode> readSlideNodes(Reader& r, const std::vector<int>& handleOf, const std::vector<char>& fixed, int handleCount) {
  const std::size_t fineNodes = handleOf.size();
  const auto n = r.pod<std::uint64_t>();
  if (n > fineNodes || fixed.size() != fineNodes) throw Error("cache file corrupt (slide nodes)");
  std::vector<char> seen(fineNodes, 0);
  std::vector<SlideNode> out(n);
  for (SlideNode& s : out) {
    s.node = r.pod<std::int32_t>();
    s.handle = r.pod<std::int32_t>();
    s.normal = r.pod<Eigen::Vector3d>();
    s.stiffness = r.pod<double>();
    if (s.node < 0 || std::size_t(s.node) >= fineNodes || s.handle < 0 || s.handle >= handleCount || !(std::abs(s.normal.norm() - 1.0) < 1e-9) ||
        !(s.stiffness >= 0) || !std::isfinite(s.stiffness) || fixed[std::size_t(s.node)] || handleOf[std::size_t(s.node)] >= 0 || seen[std::size_t(s.node)]++)
      throw Error("cache file corrupt (a slide node)");
  }
  return out;
}

}  // namespace handson::bin
