#pragma once
// The one TetGen wrapper (TetGen 1.5, Debian's libtet1.5-dev): tetrahedralizes a closed triangulated
// surface with given interior points, keeping the surface triangles as they are, so meshes of
// neighbouring pieces that share a surface triangulation conform.
#include <Eigen/Core>
#include <array>
#include <string>
#include <vector>

namespace handson {

struct TetgenResult {
  bool ok = false;
  std::string message;                    ///< why not, when !ok
  std::vector<std::array<int, 4>> tets;   ///< indices into the input points, positive orientation
};

/// Every point becomes a vertex (surface points on `triangles`, the others inside); TetGen's
/// switches "pYQJ": a PLC, its boundary not split, quiet, no point dropped (indices stay). TetGen may
/// not add points: if it must (the surface cannot be recovered without Steiner points) the result
/// is !ok with the reason, as for any TetGen error; tets of zero volume are refused too. TetGen runs
/// in a forked child process (its error path frees memory twice and would crash this one); safe
/// to call from several threads. Never throws for bad geometry.
TetgenResult tetrahedralizeSurface(const std::vector<Eigen::Vector3d>& points, const std::vector<std::array<int, 3>>& triangles);

}  // namespace handson
