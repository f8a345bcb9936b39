#include "box_scene.h"

#include <algorithm>

namespace handson {

BoxScene::BoxScene(double contrast) : meshes(buildNestedMeshes({0, 0, 0}, {60, 40, 40}, 480, 27)) {
  const auto& F = meshes.fine;
  E.assign(F.tets.size(), 3e3);
  nu.assign(F.tets.size(), 0.45);
  for (std::size_t t = 0; t < F.tets.size(); ++t) {
    Eigen::Vector3d ctr = Eigen::Vector3d::Zero();
    for (int v : F.tets[t]) ctr += F.nodes[std::size_t(v)] / 4.0;
    if (ctr.y() > 24 && ctr.y() < 30) E[t] *= contrast;  // a stiff slab beside the handle
  }
  K = tetStiffnesses(F, E, nu);
  c.handleOf.assign(F.nodes.size(), -1);
  c.fixed.assign(F.nodes.size(), 0);
  for (std::size_t n = 0; n < F.nodes.size(); ++n) {
    const auto& p = F.nodes[n];
    if (p.minCoeff() < 1e-9 || p.x() > 60 - 1e-9 || p.y() > 40 - 1e-9 || p.z() > 40 - 1e-9) c.fixed[n] = 1;
  }
}

void BoxScene::ball(const Eigen::Vector3d& ctr, double r, int handle) {
  for (std::size_t n = 0; n < meshes.fine.nodes.size(); ++n)
    if ((meshes.fine.nodes[n] - ctr).norm() < r) c.handleOf[n] = handle;
  c.handleCount = std::max(c.handleCount, handle + 1);
}

namespace {
bool finite(const std::vector<Eigen::Vector3d>& x) {
  return std::all_of(x.begin(), x.end(), [](const Eigen::Vector3d& p) { return p.allFinite(); });
}
}  // namespace

StabilityOutcome solveBoxMotion(const BoxScene& s, const std::function<std::vector<RigidTransform>(double)>& at, int increments, CoarseElement element) {
  StabilityOutcome o;
  CoarseModel model(s.meshes, s.K, s.c, {}, element);
  auto xc = model.restState();
  try {
    o.coarseConverged = true;  // every increment must converge
    for (int k = 1; k <= increments; ++k) {
      const auto st = model.solve(at(double(k) / increments), xc, 30);
      o.coarseIterations += st.iterations;
      o.coarseConverged = o.coarseConverged && st.converged;
      o.coarse = model.reconstruct(at(double(k) / increments), xc);  // the last one: at(1.0)
      if (!finite(o.coarse)) break;
      o.coarseInvertedAt.push_back(countInvertedTets(s.meshes.fine, o.coarse));
    }
    o.coarseFinite = finite(xc) && finite(o.coarse) && !o.coarseInvertedAt.empty();
  } catch (const std::exception&) {
    o.coarseFinite = false;  // the solve refused a non-finite update
  }
  if (o.coarseFinite) o.coarseInverted = o.coarseInvertedAt.back();
  std::vector<char> dir;
  auto x = s.meshes.fine.nodes;
  try {
    o.fineConverged = true;
    for (int k = 1; k <= increments; ++k) {
      auto x0 = prescribedPositions(s.meshes.fine, s.c, at(double(k) / increments), &dir);
      for (std::size_t i = 0; i < x0.size(); ++i)
        if (!dir[i]) x0[i] = x[i];
      const auto r = solveStatic(s.meshes.fine, s.K, dir, x0);
      x = r.x;
      o.fineConverged = o.fineConverged && r.converged;
      o.fineIterations += r.iterations;
      if (!finite(x)) break;
      o.fineInvertedAt.push_back(countInvertedTets(s.meshes.fine, x));
    }
    o.fine = x;
    o.fineFinite = finite(x);
  } catch (const std::exception&) {
    o.fineConverged = false;
    o.fineFinite = false;  // the solve refused a non-finite step
  }
  if (o.fineFinite && !o.fineInvertedAt.empty()) o.fineInverted = o.fineInvertedAt.back();
  return o;
}

}  // namespace handson
