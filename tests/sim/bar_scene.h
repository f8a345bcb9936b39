#pragma once
// A 50 x 10 x 10 mm bar along x for exact answers (tests of handle reactions and strain): nodes at
// x = 0 are fixed (or handle 0), nodes at x = 50 a handle.
#include <gtest/gtest.h>

#include "sim/coarsening.h"
#include "sim/static_solver.h"

namespace handson::test {

// clampedStart: x = 0 fixed and x = 50 handle 0; otherwise x = 0 handle 0 and x = 50 handle 1.
struct Bar {
  NestedMeshes meshes = buildNestedMeshes({0, 0, 0}, {50, 10, 10}, 600, 27);
  std::vector<Mat12> K;
  FineConstraints c;
  Bar(double youngs, double poisson, bool clampedStart) {
    const auto& F = meshes.fine;
    K = tetStiffnesses(F, std::vector<double>(F.tets.size(), youngs), std::vector<double>(F.tets.size(), poisson));
    c.handleOf.assign(F.nodes.size(), -1);
    c.fixed.assign(F.nodes.size(), 0);
    for (std::size_t n = 0; n < F.nodes.size(); ++n) {
      if (F.nodes[n].x() < 1e-9) (clampedStart ? c.fixed[n] = 1 : c.handleOf[n] = 0);
      if (F.nodes[n].x() > 50 - 1e-9) c.handleOf[n] = clampedStart ? 0 : 1;
    }
    c.handleCount = clampedStart ? 1 : 2;
  }
  std::vector<Eigen::Vector3d> fineSolve(const std::vector<RigidTransform>& T) const {
    std::vector<char> dir;
    const auto x0 = prescribedPositions(meshes.fine, c, T, &dir);
    StaticSolveOptions o;
    o.tolerance = 1e-9;
    const auto r = solveStatic(meshes.fine, K, dir, x0, o);
    EXPECT_TRUE(r.converged);
    return r.x;
  }
};

}  // namespace handson::test
