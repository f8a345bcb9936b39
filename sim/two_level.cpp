#include "two_level.h"

#include <Eigen/Dense>
#include <cmath>

#include "sim/error.h"
#include "sim/static_solver.h"

namespace handson {

namespace {
using Field = std::vector<Eigen::Vector3d>;

double dot(const Field& a, const Field& b, const std::vector<char>& mask) {
  double s = 0;
  for (std::size_t i = 0; i < a.size(); ++i)
    if (mask[i]) s += a[i].dot(b[i]);
  return s;
}
}  // namespace

FineRefiner::FineRefiner(const CoarseModel& coarse, const std::vector<Mat12>& fineK) : coarse_(coarse), K_(fineK) {
  const auto& c = coarse.constraints();
  free_.resize(c.handleOf.size());
  for (std::size_t i = 0; i < free_.size(); ++i) free_[i] = !c.fixed[i] && c.handleOf[i] < 0;
  if (fineK.size() != coarse.meshes().fine.tets.size()) throw Error("refiner: one stiffness per fine tet expected");
}

double FineRefiner::step(const std::vector<Eigen::Vector3d>& xc, std::vector<Eigen::Vector3d>& x, int iterations) const {
  const TetMesh& F = coarse_.meshes().fine;
  const std::size_t n = F.nodes.size(), nt = F.tets.size();
  if (x.size() != n) throw Error("refiner: wrong node count");
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
  std::vector<Eigen::Matrix3d> dinv(n, Eigen::Matrix3d::Zero());
  for (std::size_t i = 0; i < n; ++i)
    if (free_[i]) {
      const double tr = diag[i].trace();
      dinv[i] = tr > 0 ? Eigen::Matrix3d(diag[i].inverse()) : Eigen::Matrix3d::Zero();
      if (!dinv[i].allFinite()) dinv[i].setZero();
    } else {
      r[i].setZero();
    }
  auto applyK = [&](const Field& p, Field& out) {
    out.assign(n, Eigen::Vector3d::Zero());
    for (std::size_t t = 0; t < nt; ++t) {
      const Vec12 hp = H[t] * stack(cornersAt(t, p));
      for (int i = 0; i < 4; ++i) out[std::size_t(F.tets[t][std::size_t(i)])] += hp.segment<3>(3 * i);
    }
    for (std::size_t i = 0; i < n; ++i)
      if (!free_[i]) out[i].setZero();
  };
  auto precondition = [&](const Field& res, Field& z) {
    z.assign(n, Eigen::Vector3d::Zero());
    for (std::size_t i = 0; i < n; ++i)
      if (free_[i]) z[i] = dinv[i] * res[i];
    const Eigen::VectorXd cc = coarse_.coarseSolve(coarse_.restrictToCoarse(res, xc));
    coarse_.prolongAdd(cc, xc, z);
    for (std::size_t i = 0; i < n; ++i)
      if (!free_[i]) z[i].setZero();
  };
  Field dx(n, Eigen::Vector3d::Zero()), z, p, Ap;
  precondition(r, z);
  p = z;
  double rz = dot(r, z, free_);
  const double r0 = std::sqrt(dot(r, r, free_));
  for (int it = 0; it < iterations && rz > 0; ++it) {
    applyK(p, Ap);
    const double pAp = dot(p, Ap, free_);
    if (!(pAp > 0)) break;
    const double alpha = rz / pAp;
    for (std::size_t i = 0; i < n; ++i) {
      dx[i] += alpha * p[i];
      r[i] -= alpha * Ap[i];
    }
    precondition(r, z);
    const double rzNew = dot(r, z, free_);
    const double beta = rzNew / rz;
    rz = rzNew;
    for (std::size_t i = 0; i < n; ++i) p[i] = z[i] + beta * p[i];
  }
  // Backtracking on the fine elastic energy along dx.
  auto energy = [&](const Field& pos) { return elasticEnergy(F, K_, pos); };
  const double e0 = energy(x);
  Field trial = x;
  for (int ls = 0; ls < 10; ++ls) {
    const double a = std::ldexp(1.0, -ls);
    for (std::size_t i = 0; i < n; ++i)
      if (free_[i]) trial[i] = x[i] + a * dx[i];
    if (energy(trial) <= e0) break;
    if (ls == 9) trial = x;  // no decrease: keep x
  }
  x.swap(trial);
  return r0 > 0 ? std::sqrt(dot(r, r, free_)) / r0 : 0.0;
}

}  // namespace handson
