#include "two_level.h"

#include <Eigen/Dense>
#include <cmath>

#include "sim/blas_threads.h"
#include "sim/base/error.h"
#include "sim/refine_pcg.h"
#include "sim/static_solver.h"

namespace handson {

using refine::Field;

const char* refineMethodName(RefineMethod m) {
  return m == RefineMethod::Analytic ? "analytic" : m == RefineMethod::Warped ? "warped" : "projected";
}

std::vector<Eigen::Vector3d> positionsOnCut(const RefineCut& cut, const std::vector<RigidTransform>& handles, const std::vector<Eigen::Vector3d>& x) {
  if (!cut.mesh || !cut.constraints || !cut.sourceNode || cut.sourceNode->size() != cut.mesh->nodes.size())
    throw Error("refiner: a cut mesh needs its roles and each node's source");
  std::vector<char> dirichlet;
  std::vector<Eigen::Vector3d> out = prescribedPositions(*cut.mesh, *cut.constraints, handles, &dirichlet);
  for (std::size_t i = 0; i < out.size(); ++i) {
    const auto s = std::size_t((*cut.sourceNode)[i]);
    if (s >= x.size()) throw Error("refiner: a cut mesh's node copies no node of the positions given");
    if (!dirichlet[i]) out[i] = x[s];
  }
  return out;
}

double FineRefiner::step(const std::vector<RigidTransform>& handles, const std::vector<Eigen::Vector3d>& xc, std::vector<Eigen::Vector3d>& x, int iterations) const {
  if (x.size() != fine_->nodes.size()) throw Error("refiner: wrong node count");
  const Springs springs = slideSprings(*fine_, constraints_->slide, handles);
  const SingleThreadedBlas blas;  // the coarse correction's small solves (sim/blas_threads.h)
  return options_.method == RefineMethod::Projected ? stepProjected(springs, xc, x, iterations) : stepWarped(springs, xc, x, iterations);
}

double FineRefiner::stepProjected(const Springs& springs, const std::vector<Eigen::Vector3d>& xc, std::vector<Eigen::Vector3d>& x, int iterations) const {
  const TetMesh& F = *fine_;
  projectOntoSpringPlanes(springs, x);
  const std::size_t n = F.nodes.size(), nt = F.tets.size();
  // Residual f(x) and the element Hessians (projected to positive semi-definite) at x.
  std::vector<Mat12> H(nt);
  Field r(n, Eigen::Vector3d::Zero());
  std::vector<Eigen::Matrix3d> diag(n, Eigen::Matrix3d::Zero());
  auto cornersAt = [&](std::size_t t, const Field& pos) { return tetCorners(F.tets[t], pos); };
  for (std::size_t t = 0; t < nt; ++t) {
    const auto& v = F.tets[t];
    const auto X = cornersAt(t, F.nodes), xs = cornersAt(t, x);
    const Vec12 f = corotationalForce(K_[t], X, xs);
    H[t] = corotationalHessian(K_[t], X, xs, true);
    for (int i = 0; i < 4; ++i) {
      r[std::size_t(v[std::size_t(i)])] += f.segment<3>(3 * i);
      diag[std::size_t(v[std::size_t(i)])] += H[t].block<3, 3>(3 * i, 3 * i);
    }
  }
  const std::vector<Eigen::Matrix3d> dinv = refine::jacobiInverse(diag, free_);
  for (std::size_t i = 0; i < n; ++i)
    if (!free_[i]) r[i].setZero();
  removeNormalParts(springs, r);
  auto applyK = [&](const Field& p, Field& out) {
    out.assign(n, Eigen::Vector3d::Zero());
    for (std::size_t t = 0; t < nt; ++t) {
      const Vec12 hp = H[t] * stack(cornersAt(t, p));
      for (int i = 0; i < 4; ++i) out[std::size_t(F.tets[t][std::size_t(i)])] += hp.segment<3>(3 * i);
    }
    removeNormalParts(springs, out);
    for (std::size_t i = 0; i < n; ++i)
      if (!free_[i]) out[i].setZero();
  };
  const std::vector<Eigen::Matrix3d> Rc = coarse_.elementRotations(xc);
  auto precondition = [&](const Field& res, Field& z) {
    refine::twoLevelPrecondition({coarse_, Rc, source_}, dinv, free_, res, z);
    removeNormalParts(springs, z);
  };

  Field dx;
  const double reduction = refine::pcg(r, free_, iterations, applyK, precondition, dx);
  auto energy = [&](const Field& pos) { return elasticEnergy(F, K_, pos); };
  refine::backtrack(x, dx, free_, energy(x), energy);
  return reduction;
}

}  // namespace handson
