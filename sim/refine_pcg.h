#pragma once
// The two-level refinement's shared pieces (sim/two_level.cpp, sim/refine_warped.cpp): the
// preconditioned conjugate gradients on H dx = r over the free fine nodes, the block-Jacobi
// inverse, and the backtracking on the elastic energy. Fields are per fine node (3-vectors);
// `mask` marks the free nodes (Dirichlet nodes stay zero in every direction).
#include <Eigen/Dense>
#include <cmath>
#include <vector>

#include "sim/coarsening.h"

namespace handson::refine {

using Field = std::vector<Eigen::Vector3d>;

inline double dot(const Field& a, const Field& b, const std::vector<char>& mask) {
  double s = 0;
  for (std::size_t i = 0; i < a.size(); ++i)
    if (mask[i]) s += a[i].dot(b[i]);
  return s;
}

/// The inverse of each free node's 3x3 diagonal block (zero where it is not invertible or the node
/// is not free).
inline std::vector<Eigen::Matrix3d> jacobiInverse(const std::vector<Eigen::Matrix3d>& diag, const std::vector<char>& mask) {
  std::vector<Eigen::Matrix3d> dinv(diag.size(), Eigen::Matrix3d::Zero());
  for (std::size_t i = 0; i < diag.size(); ++i)
    if (mask[i] && diag[i].trace() > 0) {
      dinv[i] = diag[i].inverse();
      if (!dinv[i].allFinite()) dinv[i].setZero();
    }
  return dinv;
}

/// `iterations` PCG iterations on H dx = r from dx = 0: applyK(p, out) writes H p (zero at
/// Dirichlet nodes), precondition(res, z) writes M^-1 res. r is consumed (left as the last
/// residual). Returns |r_k| / |r_0|.
template <class ApplyK, class Precondition>
double pcg(Field& r, const std::vector<char>& mask, int iterations, ApplyK&& applyK, Precondition&& precondition, Field& dx) {
  const std::size_t n = r.size();
  dx.assign(n, Eigen::Vector3d::Zero());
  Field z, p, Ap;
  precondition(r, z);
  p = z;
  double rz = dot(r, z, mask);
  const double r0 = std::sqrt(dot(r, r, mask));
  for (int it = 0; it < iterations && rz > 0; ++it) {
    applyK(p, Ap);
    const double pAp = dot(p, Ap, mask);
    if (!(pAp > 0)) break;
    const double alpha = rz / pAp;
    for (std::size_t i = 0; i < n; ++i) {
      dx[i] += alpha * p[i];
      r[i] -= alpha * Ap[i];
    }
    precondition(r, z);
    const double rzNew = dot(r, z, mask);
    const double beta = rzNew / rz;
    rz = rzNew;
    for (std::size_t i = 0; i < n; ++i) p[i] = z[i] + beta * p[i];
  }
  return r0 > 0 ? std::sqrt(dot(r, r, mask)) / r0 : 0.0;
}

/// The coarse correction's inputs: the coarse model, its element rotations at the coarse state and,
/// for a cut fine mesh, each node's source among the model's fine nodes (empty: the same nodes).
struct CoarseCorrection {
  const CoarseModel& coarse;
  const std::vector<Eigen::Matrix3d>& Rc;
  const std::vector<int>& source;
};

/// The two-level preconditioner: z = D^-1 res + P A_c^-1 P^T res (block Jacobi plus the coarse
/// correction through the coarse model's shape functions at the coarse state whose element
/// rotations are Rc), zero at Dirichlet nodes. On a cut mesh P = S P_0, S (copies x the model's
/// fine nodes) taking each copy its source's row: P^T res sums the copies' residuals into their
/// source, and each copy takes its source's correction.
inline void twoLevelPrecondition(const CoarseCorrection& c, const std::vector<Eigen::Matrix3d>& dinv, const std::vector<char>& mask, const Field& res,
                                 Field& z) {
  const std::size_t n = res.size();
  z.assign(n, Eigen::Vector3d::Zero());
  for (std::size_t i = 0; i < n; ++i)
    if (mask[i]) z[i] = dinv[i] * res[i];
  if (c.source.empty()) {
    c.coarse.prolongAdd(c.coarse.coarseSolve(c.coarse.restrictToCoarse(res, c.Rc)), c.Rc, z);
  } else {
    Field onModel(c.coarse.meshes().fine.nodes.size(), Eigen::Vector3d::Zero());
    for (std::size_t i = 0; i < n; ++i) onModel[std::size_t(c.source[i])] += res[i];
    const Eigen::VectorXd cc = c.coarse.coarseSolve(c.coarse.restrictToCoarse(onModel, c.Rc));
    onModel.assign(onModel.size(), Eigen::Vector3d::Zero());
    c.coarse.prolongAdd(cc, c.Rc, onModel);
    for (std::size_t i = 0; i < n; ++i) z[i] += onModel[std::size_t(c.source[i])];
  }
  for (std::size_t i = 0; i < n; ++i)
    if (!mask[i]) z[i].setZero();
}

/// x += 2^-k dx for the first k < 10 whose energy(trial) <= e0 (the energy at x); none: x stays.
template <class Energy>
void backtrack(Field& x, const Field& dx, const std::vector<char>& mask, double e0, Energy&& energy) {
  Field trial = x;
  for (int ls = 0; ls < 10; ++ls) {
    const double a = std::ldexp(1.0, -ls);
    for (std::size_t i = 0; i < x.size(); ++i)
      if (mask[i]) trial[i] = x[i] + a * dx[i];
    if (energy(trial) <= e0) {
      x.swap(trial);
      return;
    }
  }
}

}  // namespace handson::refine
