// The two-level refinement with the warped stiffness, matrix-free (RefineMethod::Warped;
// docs/simulation.md, "Refinement").
//
// Per fine tet t: rest edge matrix D_m = [X1-X0, X2-X0, X3-X0] (3x3), G = D_m^-1 (its rows g_1..g_3
// are the shape-function gradients, g_0 = -(g_1+g_2+g_3)), volume V, Lame parameters
// lambda = E nu / ((1+nu)(1-2nu)), mu = E / (2(1+nu)). The linear stiffness acts as stress times
// gradient: for corner vectors u_a, the gradient U = sum_a u_a g_a^T = [u1-u0, u2-u0, u3-u0] G,
// eps = sym(U), sigma = lambda tr(eps) I + 2 mu eps, and (K u)_a = V sigma g_a - the same numbers as
// tetStiffness's V B^T C B u (tested). Corotational, with F = D_s G and R = polar(F):
//   force        f_a = -V R sigma(eps) g_a,     eps = sym(R^T F) - I
//   energy       V (lambda/2 tr(eps)^2 + mu eps:eps)
//   product      (H p)_a = V R sigma(sym(R^T P)) g_a,  P = [p1-p0, p2-p0, p3-p0] G   (H = R K R^T)
//   diagonal     H_aa = V ((lambda+mu) h h^T + mu |h|^2 I), h = R g_a
// In matrix form the three non-zero corners' vectors are V (R sigma) G^T's columns, corner 0 minus
// their sum. Each pass runs over the tets in `threads` chunks, each accumulating into its own node
// buffers, summed after.
#include <Eigen/Dense>
#include <cmath>

#include "sim/base/error.h"
#include "sim/base/parallel.h"
#include "sim/refine_pcg.h"
#include "sim/two_level.h"

namespace handson {

using refine::Field;

struct FineRefiner::Warped {
  int threads = 1;
  bool twist = false;                      ///< Analytic: the clamped twist terms too
  mutable std::vector<Eigen::Matrix3d> L;  ///< Analytic, per tet: Lambda = sum_k max(lambda_k, 0) v_k v_k^T
  std::vector<Eigen::Matrix3d> G;          ///< per tet, D_m^-1 (zero for a degenerate tet)
  std::vector<double> V, lambda, mu;       ///< per tet
  mutable std::vector<Eigen::Matrix3d> R;  ///< per tet, the rotation at the step's positions
  mutable std::vector<Eigen::Quaterniond> q;  ///< per tet, the polar iteration's warm start
  mutable std::vector<Field> vec;          ///< per thread, a node buffer
  mutable std::vector<std::vector<Eigen::Matrix3d>> diag;  ///< per thread, diagonal blocks
};

FineRefiner::FineRefiner(const CoarseModel& coarse, const std::vector<Mat12>& fineK) : coarse_(coarse), K_(fineK) {
  options_.method = RefineMethod::Projected;
  solveOn(coarse.meshes().fine, coarse.constraints());
}

void FineRefiner::solveOn(const TetMesh& fine, const FineConstraints& c) {
  fine_ = &fine;
  constraints_ = &c;
  if (K_.size() != fine.tets.size()) throw Error("refiner: one stiffness per fine tet expected");
  if (c.handleOf.size() != fine.nodes.size() || c.fixed.size() != fine.nodes.size()) throw Error("refiner: the roles do not match the fine mesh");
  free_.resize(c.handleOf.size());
  for (std::size_t i = 0; i < free_.size(); ++i) free_[i] = !c.fixed[i] && c.handleOf[i] < 0;
}

FineRefiner::FineRefiner(const CoarseModel& coarse, const std::vector<Mat12>& fineK, const std::vector<double>& youngs, const std::vector<double>& poisson,
                         const RefineOptions& options)
    : FineRefiner(coarse, fineK) {
  options_ = options;
  if (const RefineCut& cut = options.cut; cut.mesh) {
    if (!cut.constraints || !cut.sourceNode || cut.sourceNode->size() != cut.mesh->nodes.size() || cut.mesh->tets.size() != coarse.meshes().fine.tets.size())
      throw Error("refiner: a cut mesh needs its roles and each node's source, and the coarse model's tets");
    for (int s : *cut.sourceNode)
      if (s < 0 || std::size_t(s) >= coarse.meshes().fine.nodes.size()) throw Error("refiner: a cut mesh's node copies no node of the coarse model's");
    solveOn(*cut.mesh, *cut.constraints);
    source_ = *cut.sourceNode;
  }
  if (options_.method == RefineMethod::Projected) return;
  const TetMesh& F = *fine_;
  const std::size_t nt = F.tets.size();
  if (youngs.size() != nt || poisson.size() != nt) throw Error("refiner: one material per fine tet expected");
  auto w = std::make_unique<Warped>();
  w->threads = simulationThreads(options.threads);
  w->twist = options_.method == RefineMethod::Analytic;
  if (w->twist) w->L.assign(nt, Eigen::Matrix3d::Zero());
  w->G.assign(nt, Eigen::Matrix3d::Zero());
  w->V.assign(nt, 0.0);
  w->lambda.assign(nt, 0.0);
  w->mu.assign(nt, 0.0);
  for (std::size_t t = 0; t < nt; ++t) {
    const auto X = tetCorners(F.tets[t], F.nodes);
    Eigen::Matrix3d Dm;
    Dm << X[1] - X[0], X[2] - X[0], X[3] - X[0];
    const double V = std::abs(Dm.determinant()) / 6.0;
    const double scale = (X[1] - X[0]).norm() + (X[2] - X[0]).norm() + (X[3] - X[0]).norm();
    const double E = youngs[t], nu = poisson[t];
    // The same degenerate cases as tetStiffness (a zero matrix there, no contribution here).
    // A sliding handle's own tets (E = 0) add nothing either.
    if (!(V > 1e-12 * scale * scale * scale) || !std::isfinite(E) || !std::isfinite(nu) || !(E > 0)) continue;
    w->G[t] = Dm.inverse();
    w->V[t] = V;
    w->lambda[t] = E * nu / ((1 + nu) * (1 - 2 * nu));
    w->mu[t] = E / (2 * (1 + nu));
  }
  w->R.assign(nt, Eigen::Matrix3d::Identity());
  w->q.assign(nt, Eigen::Quaterniond::Identity());
  w->vec.resize(std::size_t(w->threads));
  w->diag.resize(std::size_t(w->threads));
  warped_ = std::move(w);
}

FineRefiner::~FineRefiner() = default;

namespace {

// sigma(eps) = lambda tr(eps) I + 2 mu eps for a symmetric eps.
Eigen::Matrix3d stress(const Eigen::Matrix3d& eps, double lambda, double mu) {
  Eigen::Matrix3d s = 2.0 * mu * eps;
  s.diagonal().array() += lambda * eps.trace();
  return s;
}

// Adds the corner vectors of V * M * G^T (columns 1..3, corner 0 minus their sum) to out.
void scatter(const std::array<int, 4>& tet, const Eigen::Matrix3d& VMGt, Field& out) {
  const Eigen::Vector3d c1 = VMGt.col(0), c2 = VMGt.col(1), c3 = VMGt.col(2);
  out[std::size_t(tet[1])] += c1;
  out[std::size_t(tet[2])] += c2;
  out[std::size_t(tet[3])] += c3;
  out[std::size_t(tet[0])] -= c1 + c2 + c3;
}

// Lambda = sum_k max(lambda_k, 0) v_k v_k^T for S = R^T F (symmetric at the polar rotation) with
// eigenpairs (s_k, v_k): the twist about v_k has lambda_k = (tau_i + tau_j) / (s_i + s_j), i, j the
// other two, tau = dpsi/ds = 2 mu (s - 1) + lambda (sum s - 3). Where s_i + s_j is near zero (an
// element folding through itself) the twist is dropped.
Eigen::Matrix3d twistOperator(const Eigen::Matrix3d& S, double lambda, double mu) {
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es;
  es.computeDirect(0.5 * (S + S.transpose()));
  const Eigen::Vector3d s = es.eigenvalues();
  const Eigen::Vector3d tau = (2.0 * mu * (s.array() - 1.0) + lambda * (s.sum() - 3.0)).matrix();
  const double scale = s.cwiseAbs().maxCoeff() + 1e-300;
  Eigen::Vector3d l;
  for (int k = 0; k < 3; ++k) {
    const int i = (k + 1) % 3, j = (k + 2) % 3;
    const double den = s[i] + s[j];
    l[k] = den > 1e-6 * scale ? std::max(0.0, (tau[i] + tau[j]) / den) : 0.0;
  }
  return es.eigenvectors() * l.asDiagonal() * es.eigenvectors().transpose();
}

Eigen::Matrix3d edges(const std::array<int, 4>& tet, const Field& p) {
  Eigen::Matrix3d D;
  const Eigen::Vector3d& p0 = p[std::size_t(tet[0])];
  D << p[std::size_t(tet[1])] - p0, p[std::size_t(tet[2])] - p0, p[std::size_t(tet[3])] - p0;
  return D;
}

}  // namespace

// Sums the per-thread node buffers into out (zero at Dirichlet nodes), split over nodes.
void FineRefiner::sumThreadBuffers(Field& out) const {
  const Warped& w = *warped_;
  const std::size_t n = free_.size();
  const int T = w.threads;
  out.resize(n);
  parallelChunks(n, T, [&](std::size_t b, std::size_t e, int) {
    for (std::size_t i = b; i < e; ++i) {
      Eigen::Vector3d s = Eigen::Vector3d::Zero();
      for (int t = 0; t < T; ++t) s += w.vec[std::size_t(t)][i];
      out[i] = free_[i] ? s : Eigen::Vector3d::Zero();
    }
  });
}

// The linearization at x: each tet's rotation (warm-started, kept in w.R and w.q), the residual r
// (free nodes) and the Jacobi blocks' diagonal (3x3 per node, summed over the threads); returns
// the energy at x.
double FineRefiner::linearizeWarped(const Field& x, Field& r, std::vector<Eigen::Matrix3d>& diag) const {
  const Warped& w = *warped_;
  const TetMesh& F = *fine_;
  const std::size_t n = F.nodes.size(), nt = F.tets.size();
  const int T = w.threads;
  std::vector<double> energyOf(std::size_t(T), 0.0);
  parallelChunks(nt, T, [&](std::size_t b, std::size_t e, int c) {
    Field& rc = w.vec[std::size_t(c)];
    auto& d = w.diag[std::size_t(c)];
    rc.assign(n, Eigen::Vector3d::Zero());
    d.assign(n, Eigen::Matrix3d::Zero());
    double energy = 0;
    for (std::size_t t = b; t < e; ++t) {
      if (w.V[t] == 0) continue;
      const auto& tet = F.tets[t];
      const Eigen::Matrix3d Ft = edges(tet, x) * w.G[t];
      // One Newton step a step when the rotation moved less than 1e-3 rad (it keeps converging from
      // step to step with x).
      const Eigen::Matrix3d R = polarRotationWarm(Ft, w.q[t], 1e-5);
      w.R[t] = R;
      const Eigen::Matrix3d S = R.transpose() * Ft;
      Eigen::Matrix3d eps = 0.5 * (S + S.transpose());
      eps.diagonal().array() -= 1.0;
      const double tr = eps.trace();
      energy += w.V[t] * (0.5 * w.lambda[t] * tr * tr + w.mu[t] * eps.squaredNorm());
      scatter(tet, -w.V[t] * (R * stress(eps, w.lambda[t], w.mu[t])) * w.G[t].transpose(), rc);
      if (w.twist) w.L[t] = twistOperator(S, w.lambda[t], w.mu[t]);
      for (int a = 0; a < 4; ++a) {
        const Eigen::Vector3d g = a == 0 ? Eigen::Vector3d(-w.G[t].colwise().sum().transpose()) : Eigen::Vector3d(w.G[t].row(a - 1).transpose());
        const Eigen::Vector3d h = R * g;
        Eigen::Matrix3d blk = (w.V[t] * (w.lambda[t] + w.mu[t])) * (h * h.transpose());
        blk.diagonal().array() += w.V[t] * w.mu[t] * h.squaredNorm();
        // The twist part on this corner: (1/2) V R [g]x^T Lambda [g]x R^T (positive semi-definite).
        if (w.twist) blk += (0.5 * w.V[t]) * (R * crossMatrix(g).transpose() * w.L[t] * crossMatrix(g) * R.transpose());
        d[std::size_t(tet[std::size_t(a)])] += blk;
      }
    }
    energyOf[std::size_t(c)] = energy;
  });
  double e0 = 0;
  for (double v : energyOf) e0 += v;
  sumThreadBuffers(r);
  diag.assign(n, Eigen::Matrix3d::Zero());
  for (std::size_t i = 0; i < n; ++i)
    for (int t = 0; t < T; ++t) diag[i] += w.diag[std::size_t(t)][i];
  return e0;
}

// The warped stiffness (with the twist term) at the rotations linearizeWarped kept, applied to p.
void FineRefiner::applyWarped(const Field& p, Field& out) const {
  const Warped& w = *warped_;
  const TetMesh& F = *fine_;
  const std::size_t n = F.nodes.size();
  parallelChunks(F.tets.size(), w.threads, [&](std::size_t b, std::size_t e, int c) {
    Field& y = w.vec[std::size_t(c)];
    y.assign(n, Eigen::Vector3d::Zero());
    for (std::size_t t = b; t < e; ++t) {
      if (w.V[t] == 0) continue;
      const Eigen::Matrix3d S = w.R[t].transpose() * (edges(F.tets[t], p) * w.G[t]);
      Eigen::Matrix3d M = stress(0.5 * (S + S.transpose()), w.lambda[t], w.mu[t]);
      if (w.twist) M += crossMatrix(w.L[t] * axialOfSkew(S));
      scatter(F.tets[t], w.V[t] * (w.R[t] * M) * w.G[t].transpose(), y);
    }
  });
  sumThreadBuffers(out);
}

// The corotational energy at trial positions (rotations warm-started from x's, not kept).
double FineRefiner::warpedEnergy(const Field& pos) const {
  const Warped& w = *warped_;
  const TetMesh& F = *fine_;
  std::vector<double> part(std::size_t(w.threads), 0.0);
  parallelChunks(F.tets.size(), w.threads, [&](std::size_t b, std::size_t e, int c) {
    double s = 0;
    for (std::size_t t = b; t < e; ++t) {
      if (w.V[t] == 0) continue;
      const Eigen::Matrix3d Ft = edges(F.tets[t], pos) * w.G[t];
      Eigen::Quaterniond q = w.q[t];  // a trial: the warm start stays with x
      const Eigen::Matrix3d S = polarRotationWarm(Ft, q, 1e-5).transpose() * Ft;
      Eigen::Matrix3d eps = 0.5 * (S + S.transpose());
      eps.diagonal().array() -= 1.0;
      const double tr = eps.trace();
      s += w.V[t] * (0.5 * w.lambda[t] * tr * tr + w.mu[t] * eps.squaredNorm());
    }
    part[std::size_t(c)] = s;
  });
  double s = 0;
  for (double v : part) s += v;
  return s;
}

double FineRefiner::stepWarped(const Springs& springs, const std::vector<Eigen::Vector3d>& xc, std::vector<Eigen::Vector3d>& x, int iterations) const {
  if (!warped_) throw Error("refiner: the matrix-free methods need the fine materials");
  projectOntoSpringPlanes(springs, x);
  Field r;
  std::vector<Eigen::Matrix3d> diag;
  const double e0 = linearizeWarped(x, r, diag);
  removeNormalParts(springs, r);
  const std::vector<Eigen::Matrix3d> dinv = refine::jacobiInverse(diag, free_);
  auto applyK = [&](const Field& p, Field& out) {
    applyWarped(p, out);
    removeNormalParts(springs, out);
  };
  const std::vector<Eigen::Matrix3d> Rc = coarse_.elementRotations(xc);
  auto precondition = [&](const Field& res, Field& z) {
    refine::twoLevelPrecondition({coarse_, Rc, source_}, dinv, free_, res, z);
    removeNormalParts(springs, z);
  };
  Field dx;
  const double reduction = refine::pcg(r, free_, iterations, applyK, precondition, dx);
  refine::backtrack(x, dx, free_, e0, [&](const Field& pos) { return warpedEnergy(pos); });
  return reduction;
}

std::vector<Eigen::Vector3d> FineRefiner::product(const std::vector<Eigen::Vector3d>& x, const std::vector<Eigen::Vector3d>& p) const {
  if (!warped_) throw Error("refiner: the matrix-free methods need the fine materials");
  const Warped& w = *warped_;
  const TetMesh& F = *fine_;
  Field out(F.nodes.size(), Eigen::Vector3d::Zero());
  for (std::size_t t = 0; t < F.tets.size(); ++t) {
    if (w.V[t] == 0) continue;
    Eigen::Quaterniond q = Eigen::Quaterniond::Identity();
    const Eigen::Matrix3d Ft = edges(F.tets[t], x) * w.G[t];
    const Eigen::Matrix3d R = polarRotationWarm(Ft, q);
    const Eigen::Matrix3d S = R.transpose() * (edges(F.tets[t], p) * w.G[t]);
    Eigen::Matrix3d M = stress(0.5 * (S + S.transpose()), w.lambda[t], w.mu[t]);
    if (w.twist) M += crossMatrix(twistOperator(R.transpose() * Ft, w.lambda[t], w.mu[t]) * axialOfSkew(S));
    scatter(F.tets[t], w.V[t] * (R * M) * w.G[t].transpose(), out);
  }
  return out;
}

}  // namespace handson
