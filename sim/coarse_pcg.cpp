// The coarse model's matrix-free solve (CoarseSolver::Pcg; docs/simulation.md, "The coarse solve").
//
// The coarse equilibrium is f(x) = 0 over the free coarse dofs, with per element e (n corners, its
// 3n-vector of corner positions x_e, its rotation R_e = polar of the corners' least-squares affine
// fit, K_h its condensed 3n x 3n stiffness, h_e its handles' term, X_e its rest corners):
//   f_e(x) = -R_e [K_h (R_e^T x_e - X_e) + h_e(R_e)]      (R_e acting on each corner's 3-block).
// Both solvers iterate x += d with A(R) d ~ f(x), A(R) = sum_e R_e K_h R_e^T (the warped stiffness,
// symmetric positive definite once Dirichlet nodes are removed), so they share the fixed point.
// Here, per iteration:
//  1. R_e by polarRotationWarm (Newton on the rotation, warm-started from the last iteration's);
//  2. r = f(x), element by element with fixed-size K_h blocks (no assembly);
//  3. m conjugate-gradient iterations on A(R) d = r from d = 0 (PcgOptions::cgIterations, default
//     2; m = 1 carries its direction across iterations instead), with products A(R) p element by
//     element, preconditioned by M^-1 = Rn A(Q)^-1 Rn^T: A(Q) = sum_e Q_e K_h Q_e^T over the free
//     dofs at reference rotations Q_e (first the rest, Q = I: A_0), factorized by sparse Cholesky;
//     Rn = diag of per-node rotations relative to Q (the normalized sum of the node's elements'
//     R_e Q_e^T as quaternions). If every R_e Q_e^T were one rotation, M = A(R)^-1 exactly; with
//     rotations varying smoothly over the mesh M stays close to A(R).
//  4. In a call's later iterations (from PcgOptions::refreshFromIteration on), once an element has
//     turned more than the refresh angle from its Q_e, Q takes this iteration's rotations and A(Q)
//     is refactorized (the pattern is the rest's; ~27 ms at the default 2,199 dofs). A sliding
//     interface needs it most: its normal springs, 100x the tissue's stiffness, are condensed into
//     elements that turn with the organ while the tissue beside them does not, so the per-node
//     rotations cannot map A_0 onto A(R) there (the phantom's sliding kidney moved 10 mm and turned
//     30 degrees from rest: 143 iterations with A_0 throughout, 81 refreshed). A frame's three
//     iterations never refactorize: a refresh costs as much as ~9 of them.
//  5. Uniform cells and tets: the step taken is Anderson's mix of the update with the last
//     PcgOptions::andersonDepth secant pairs (sim/anderson.h), kept across a drag's calls; a stall
//     (no smaller plain update in 8 iterations) goes back to the best iterate and on plain, damped.
// Graded cells: a hanging corner (x_h = sum_m w_m x_m) gathers its masters' free dofs and scatters
// its force to them with the same weights (P^T f with P the constraint's prolongation), and x is
// re-expanded after every update.
// Shapes: x, positions of all coarse nodes (3-vectors); r, d, p, z, q: free dofs (3 a free node);
// K_h: 3n x 3n (n = 4 tet, 8 cell), column-major: the element's own (double) for residuals, a packed
// single-precision copy for the products.
#include <Eigen/Dense>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>

#include "sim/coarse_pcg_workspace.h"
#include "sim/coarsening.h"
#include "sim/base/error.h"

namespace handson {

CoarseModel::~CoarseModel() = default;

bool CoarseModel::pcgReady() const { return pcg_ && pcg_->ready; }

void CoarseModel::prepareSolve() {
  if (solverKind_ != CoarseSolver::Pcg || dofCount_ == 0) return;
  CoarseSolveStats st;
  preparePcg(st);
}

void CoarseModel::preparePcg(CoarseSolveStats& st) {
  if (pcgReady()) return;
  auto w = std::make_unique<PcgWorkspace>();
  const int m = 3 * nc_;
  w->khf.resize(elements_.size() * std::size_t(m * m));
  for (std::size_t e = 0; e < elements_.size(); ++e)
    Eigen::Map<Eigen::MatrixXf>(&w->khf[e * std::size_t(m * m)], m, m) = elements_[e].Kh.cast<float>();
  w->elementR.assign(elements_.size(), Eigen::Matrix3d::Identity());
  w->elementQ.assign(elements_.size(), Eigen::Quaterniond::Identity());
  w->refQ = w->elementQ;
  // An element whose corners are all held (a shaped region's outside, sim/region_shape.h) adds
  // nothing to a free dof's residual or product.
  // Graded: an element with a hanging corner takes the slower gather and scatter through masters.
  w->hangs.assign(elements_.size(), 0);
  for (std::size_t e = 0; e < elements_.size(); ++e)
    for (int c = 0; c < nc_; ++c)
      if (coarseRole_[std::size_t(elements_[e].node[std::size_t(c)])] == -3) w->hangs[e] = 1;
  for (std::size_t e = 0; e < elements_.size(); ++e)
    for (int c = 0; c < nc_; ++c)
      if (dof_[std::size_t(elements_[e].node[std::size_t(c)])] >= 0 || w->hangs[e]) {
        w->active.push_back(int(e));
        break;
      }
  // Free nodes in dof order, and the elements around each.
  const std::size_t nn = nodes_.size();
  w->freeNode.assign(std::size_t(dofCount_ / 3), -1);
  for (std::size_t v = 0; v < nn; ++v)
    if (dof_[v] >= 0) w->freeNode[std::size_t(dof_[v] / 3)] = int(v);
  std::vector<int> count(w->freeNode.size() + 1, 0);
  for (const auto& el : elements_)
    for (int c = 0; c < nc_; ++c)
      if (const int d = dof_[std::size_t(el.node[std::size_t(c)])]; d >= 0) ++count[std::size_t(d / 3) + 1];
  for (std::size_t i = 1; i < count.size(); ++i) count[i] += count[i - 1];
  w->adjStart = count;
  w->adjElement.resize(std::size_t(count.back()));
  for (std::size_t e = 0; e < elements_.size(); ++e)
    for (int c = 0; c < nc_; ++c)
      if (const int d = dof_[std::size_t(elements_[e].node[std::size_t(c)])]; d >= 0) w->adjElement[std::size_t(count[std::size_t(d / 3)]++)] = int(e);
  w->nodeR.assign(w->freeNode.size(), Eigen::Matrix3d::Identity());
  pcg_ = std::move(w);
  pcgFactorize(nullptr, st);  // A_0 = sum_e K_h over the free dofs; its pattern serves every refresh
  pcg_->ready = true;
}

// The preconditioner's factor of sum_e Q_e K_h Q_e^T over the free dofs (Q null: the rest, A_0,
// whose pattern is analysed then; a refresh only refactorizes). The uniform grid assembles into its
// fixed pattern; graded cells gather hanging corners through their masters.
void CoarseModel::pcgFactorize(const std::vector<Eigen::Matrix3d>* Q, CoarseSolveStats& st) {
  PcgWorkspace& w = *pcg_;
  const auto t0 = std::chrono::steady_clock::now();
  const SparseMatrix graded = graded_ ? warpedStiffness(Q) : SparseMatrix();
  if (!graded_) {
    assembler_->zero();
    MatE Ae(3 * nc_, 3 * nc_);
    for (std::size_t e = 0; e < elements_.size(); ++e) {
      if (!Q) {
        assembler_->add(int(e), elements_[e].Kh);
        continue;
      }
      const Eigen::Matrix3d& R = (*Q)[e];
      for (int a = 0; a < nc_; ++a)
        for (int b = 0; b < nc_; ++b) Ae.block<3, 3>(3 * a, 3 * b).noalias() = R * elements_[e].Kh.block<3, 3>(3 * a, 3 * b) * R.transpose();
      assembler_->add(int(e), Ae);
    }
  }
  const SparseMatrix& A = graded_ ? graded : assembler_->matrix();
  if (Q) w.rest.factorize(A);
  else w.rest.compute(A);
  // A turned sum of positive semidefinite blocks with the rest's Dirichlet nodes is positive definite
  // whenever A_0 is (a null vector would be a rigid motion of every element); rounding aside.
  if (w.rest.info() != Eigen::Success) throw Error(Q ? "coarse solve: the turned stiffness is not positive definite" : "coarse solve: the rest stiffness is not positive definite");
  st.factorMs += std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  ++st.factorizations;
}

template <int N>
void CoarseModel::pcgRotations(const std::vector<Eigen::Vector3d>& x, bool nodes) {
  PcgWorkspace& w = *pcg_;
  double nearest = 1.0;  // the smallest |q_e . refQ_e|: cos of half the largest turn from the reference
  for (const int ei : w.active) {
    const auto e = std::size_t(ei);
    const Element& el = elements_[e];
    // sum_c (x_c - centroid) dX_c^T = sum_c x_c dX_c^T, as the dX_c sum to zero.
    Eigen::Matrix3d S = Eigen::Matrix3d::Zero();
    for (int c = 0; c < N; ++c) S.noalias() += x[std::size_t(el.node[std::size_t(c)])] * el.dX[std::size_t(c)].transpose();
    // One Newton step a call when the rotation moved less than 1e-3 rad: it keeps converging with
    // x (quadratically), and is exact at the fixed point.
    w.elementR[e] = polarRotationWarm(S * el.fitInv, w.elementQ[e], 1e-3);
    nearest = std::min(nearest, std::abs(w.elementQ[e].coeffs().dot(w.refQ[e].coeffs())));
  }
  w.drift = 2.0 * std::acos(std::clamp(nearest, 0.0, 1.0));
  if (nodes) pcgNodeRotations();
}

void CoarseModel::pcgNodeRotations() {
  PcgWorkspace& w = *pcg_;
  // Rn: the normalized sum of the node's elements' rotations since the reference, R_e Q_e^T as
  // quaternions (signs aligned with the first): the rotation "between" them, all the
  // preconditioner needs.
  auto turned = [&w](int e) -> Eigen::Vector4d { return (w.elementQ[std::size_t(e)] * w.refQ[std::size_t(e)].conjugate()).coeffs(); };
  for (std::size_t i = 0; i < w.freeNode.size(); ++i) {
    const Eigen::Vector4d first = turned(w.adjElement[std::size_t(w.adjStart[i])]);
    Eigen::Vector4d sum = Eigen::Vector4d::Zero();
    for (int k = w.adjStart[i]; k < w.adjStart[i + 1]; ++k) {
      const Eigen::Vector4d q = turned(w.adjElement[std::size_t(k)]);
      sum += q.dot(first) < 0 ? Eigen::Vector4d(-q) : q;
    }
    const double n = sum.norm();
    w.nodeR[i] = n > 0 ? Eigen::Quaterniond(sum / n).toRotationMatrix() : Eigen::Matrix3d::Identity();
  }
}

template <int N>
void CoarseModel::pcgResidual(const std::vector<RigidTransform>& handles, const std::vector<Eigen::Vector3d>& x, Eigen::VectorXd& r, double& boundaryMs) const {
  using VecN = Eigen::Matrix<double, 3 * N, 1>;
  using MatN = Eigen::Matrix<double, 3 * N, 3 * N>;
  const PcgWorkspace& w = *pcg_;
  r.setZero(dofCount_);
  for (const int ei : w.active) {
    const auto e = std::size_t(ei);
    const Element& el = elements_[e];
    const Eigen::Matrix3d& R = w.elementR[e];
    VecN u;
    for (int c = 0; c < N; ++c) u.template segment<3>(3 * c).noalias() = R.transpose() * x[std::size_t(el.node[std::size_t(c)])];
    VecN y = Eigen::Map<const MatN>(el.Kh.data()) * u - Eigen::Map<const VecN>(el.KhX.data());
    if (!el.handles.empty()) {
      const auto b0 = std::chrono::steady_clock::now();
      y += handleTerm(el, R, handles);
      boundaryMs += std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - b0).count();
    }
    for (int c = 0; c < N; ++c) {
      const auto v = std::size_t(el.node[std::size_t(c)]);
      if (const int d = dof_[v]; d >= 0) r.template segment<3>(d).noalias() -= R * y.template segment<3>(3 * c);
      else if (w.hangs[e])
        for (const auto& [m, wt] : hang_[v])
          if (const int dm = dof_[std::size_t(m)]; dm >= 0) r.template segment<3>(dm).noalias() -= wt * (R * y.template segment<3>(3 * c));
    }
  }
}

template <int N>
void CoarseModel::pcgProduct(const Eigen::VectorXd& p, Eigen::VectorXd& out) const {
  // In single precision: a product only sets a step length and a direction (the residual, which sets
  // the fixed point, stays double), and a float K_h block is half the memory and twice the SIMD width.
  using VecN = Eigen::Matrix<float, 3 * N, 1>;
  using MatN = Eigen::Matrix<float, 3 * N, 3 * N>;
  const PcgWorkspace& w = *pcg_;
  out.setZero(dofCount_);
  for (const int ei : w.active) {
    const auto e = std::size_t(ei);
    const Element& el = elements_[e];
    const Eigen::Matrix3d& R = w.elementR[e];
    int dofs[N];
    VecN u;
    const bool hangs = w.hangs[e] != 0;
    for (int c = 0; c < N; ++c) {
      dofs[c] = dof_[std::size_t(el.node[std::size_t(c)])];
      if (dofs[c] >= 0) {
        u.template segment<3>(3 * c) = (R.transpose() * p.segment<3>(dofs[c])).template cast<float>();
      } else if (hangs) {
        Eigen::Vector3d pv = Eigen::Vector3d::Zero();
        for (const auto& [m, wt] : hang_[std::size_t(el.node[std::size_t(c)])])
          if (const int dm = dof_[std::size_t(m)]; dm >= 0) pv += wt * p.segment<3>(dm);
        u.template segment<3>(3 * c) = (R.transpose() * pv).template cast<float>();
      } else {
        u.template segment<3>(3 * c).setZero();
      }
    }
    const VecN y = Eigen::Map<const MatN>(&w.khf[e * std::size_t(9 * N * N)]) * u;
    for (int c = 0; c < N; ++c) {
      if (dofs[c] >= 0) {
        out.template segment<3>(dofs[c]).noalias() += R * y.template segment<3>(3 * c).template cast<double>();
      } else if (hangs) {
        const Eigen::Vector3d f = R * y.template segment<3>(3 * c).template cast<double>();
        for (const auto& [m, wt] : hang_[std::size_t(el.node[std::size_t(c)])])
          if (const int dm = dof_[std::size_t(m)]; dm >= 0) out.template segment<3>(dm).noalias() += wt * f;
      }
    }
  }
}

void CoarseModel::pcgPrecondition(const Eigen::VectorXd& r, Eigen::VectorXd& z) const {
  PcgWorkspace& w = *pcg_;
  w.tmp.resize(dofCount_);
  for (std::size_t i = 0; i < w.nodeR.size(); ++i) w.tmp.segment<3>(3 * Eigen::Index(i)).noalias() = w.nodeR[i].transpose() * r.segment<3>(3 * Eigen::Index(i));
  w.tmp = w.rest.solve(w.tmp);
  z.resize(dofCount_);
  for (std::size_t i = 0; i < w.nodeR.size(); ++i) z.segment<3>(3 * Eigen::Index(i)).noalias() = w.nodeR[i] * w.tmp.segment<3>(3 * Eigen::Index(i));
}

// The preconditioner's reference becomes the current rotations: A(Q) refactorized with the rest's
// pattern.
void CoarseModel::pcgRefresh(CoarseSolveStats& st) {
  PcgWorkspace& w = *pcg_;
  pcgFactorize(&w.elementR, st);
  w.refQ = w.elementQ;
  w.drift = 0.0;
  w.rzLast = 0.0;  // the carried direction was conjugate under the old preconditioner: restart
  w.anderson.reset();  // the update's map changed with the preconditioner
  pcgNodeRotations();
}

// Replaces the plain update w.d by Anderson's mix with the recent secant pairs (sim/anderson.h; from
// this call and the drag's earlier ones) and returns the plain update's largest node step. A mix
// more than 10x the plain step's length (secants that no longer describe the map: a handle let go,
// a preconditioner refreshed) is dropped for the plain step, and the pairs with it (guardedStep).
double CoarseModel::andersonStep(const std::vector<Eigen::Vector3d>& x) {
  PcgWorkspace& w = *pcg_;
  w.xFree.resize(dofCount_);
  double plain = 0.0;
  for (std::size_t i = 0; i < w.freeNode.size(); ++i) {
    w.xFree.segment<3>(3 * Eigen::Index(i)) = x[std::size_t(w.freeNode[i])];
    plain = std::max(plain, w.d.segment<3>(3 * Eigen::Index(i)).norm());
  }
  w.d = w.anderson.guardedStep(w.xFree, w.d, 10.0);
  return plain;
}

namespace {

double msSince(std::chrono::steady_clock::time_point t0) { return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count(); }

// Anderson acceleration's stall watch over one call: no new smallest plain update in kStall
// iterations is a stall. Anderson's mix cannot mend a map that barely
// contracts (as graded cells' with sliding, where it wandered at 1e-2 of the motion), so the call
// then goes back to the iterate with the smallest plain update and on from there plain, damped.
struct StallWatch {
  static constexpr int kStall = 8;
  double best = std::numeric_limits<double>::infinity();
  int since = 0;
  /// After a preconditioner refresh: the updates before it were another map's.
  void restart() { *this = StallWatch{}; }
  enum class Verdict { Improved, Same, Stalled };
  Verdict watch(double update) {
    if (update < best) {
      best = update;
      since = 0;
      return Verdict::Improved;
    }
    return ++since >= kStall ? Verdict::Stalled : Verdict::Same;
  }
};

}  // namespace

// Conjugate gradients on A(R) d = r from d = 0 into w.d, o.cgIterations of them. With one an
// iteration the directions are carried over the call's iterations instead (nonlinear conjugate
// gradients, Polak-Ribiere+: beta = max(0, z_k . (r_k - r_k-1) / z_k-1 . r_k-1)): within a frame the
// problem is nearly linear, so three such iterations do about what three linear CG iterations would.
// `carry`: a later iteration of the call, whose direction may be carried.
void CoarseModel::pcgStep(bool carry, CoarseSolveStats& st) {
  PcgWorkspace& w = *pcg_;
  const PcgOptions& o = pcgOptions_;
  const bool cell = nc_ == 8;
  w.d.setZero(dofCount_);
  w.res = w.r;
  auto t0 = std::chrono::steady_clock::now();
  pcgPrecondition(w.res, w.z);
  st.backSolveMs += msSince(t0);
  double rz = w.res.dot(w.z);
  const double rzOuter = rz;
  if (o.cgIterations == 1 && carry && w.rzLast > 0) {
    const double beta = std::max(0.0, (rz - w.z.dot(w.rLast)) / w.rzLast);
    w.p = w.z + beta * w.pLast;
  } else {
    w.p = w.z;
  }
  for (int j = 0; j < o.cgIterations && rz > 0; ++j) {
    t0 = std::chrono::steady_clock::now();
    if (cell) pcgProduct<8>(w.p, w.q);
    else pcgProduct<4>(w.p, w.q);
    st.productMs += msSince(t0);
    const double pq = w.p.dot(w.q);
    if (!(pq > 0)) break;
    const double alpha = w.res.dot(w.p) / pq;  // = rz / pq for the linear iterations
    w.d.noalias() += alpha * w.p;
    ++st.pcgIterations;
    if (j + 1 == o.cgIterations) break;
    w.res.noalias() -= alpha * w.q;
    t0 = std::chrono::steady_clock::now();
    pcgPrecondition(w.res, w.z);
    st.backSolveMs += msSince(t0);
    const double rzNew = w.res.dot(w.z);
    w.p = w.z + (rzNew / rz) * w.p;
    rz = rzNew;
  }
  w.rLast = w.r;
  w.pLast = w.p;
  w.rzLast = rzOuter;
  if (!w.d.allFinite()) throw Error("coarse solve: diverged (non-finite update)");
}

CoarseSolveStats CoarseModel::solvePcg(const std::vector<RigidTransform>& handles, std::vector<Eigen::Vector3d>& x, int maxIterations, double tol) {
  CoarseSolveStats st;
  preparePcg(st);
  PcgWorkspace& w = *pcg_;
  const bool cell = nc_ == 8;
  const PcgOptions& o = pcgOptions_;
  double update0 = 0.0, relax = 1.0;
  // Other options make another map: its pairs go.
  if (w.options.andersonDepth != o.andersonDepth) w.anderson = AndersonAcceleration(o.andersonDepth);
  else if (!(w.options == o)) w.anderson.reset();
  w.options = o;
  w.anderson.begin();
  // Graded cells keep the plain iteration: with a sliding interface it barely contracts there
  // (rate ~0.99), and the mix stalled, then left the plain iteration thousands of iterations from
  // its fixed point (results.md, 2026-12-07, sixth entry).
  bool accelerate = o.andersonDepth > 0 && !graded_;
  StallWatch stall;
  for (int it = 0; it < maxIterations; ++it) {
    auto t0 = std::chrono::steady_clock::now();
    // The preconditioner's node rotations once a call: it need only stay close to A(R).
    if (cell) pcgRotations<8>(x, it == 0);
    else pcgRotations<4>(x, it == 0);
    st.rotationMs += msSince(t0);
    if (it >= o.refreshFromIteration && o.refreshDeg > 0.0 && w.drift > o.refreshDeg * M_PI / 180.0) {
      pcgRefresh(st);
      stall.restart();
    }
    t0 = std::chrono::steady_clock::now();
    double boundary = 0.0;
    if (cell) pcgResidual<8>(handles, x, w.r, boundary);
    else pcgResidual<4>(handles, x, w.r, boundary);
    st.boundaryMs += boundary;
    st.productMs += msSince(t0) - boundary;
    pcgStep(it > 0, st);
    // With Anderson acceleration the plain update stays a convergence measure beside the step.
    double update = 0.0;
    if (accelerate) {
      update = andersonStep(x);
      relax = 1.0;
      const StallWatch::Verdict v = stall.watch(update);
      if (v == StallWatch::Verdict::Improved) {
        w.bestX = x;
      } else if (v == StallWatch::Verdict::Stalled) {
        accelerate = false;
        w.anderson.reset();
        ++st.andersonStalls;
        x = w.bestX;
        w.d.setZero();
        update0 = std::numeric_limits<double>::infinity();  // full steps again
      }
    }
    for (std::size_t i = 0; i < w.freeNode.size(); ++i) {
      const Eigen::Vector3d step = relax * w.d.segment<3>(3 * Eigen::Index(i));
      x[std::size_t(w.freeNode[i])] += step;
      update = std::max(update, step.norm());
    }
    if (!std::isfinite(update)) throw Error("coarse solve: diverged (non-finite positions)");
    expandHanging(x);
    st.iterations = it + 1;
    st.lastUpdate = update;
    // Damping: an update that does not shrink halves the next steps (as in the assembled solve), and
    // one that halves doubles them again (to full steps). Without the recovery the damping only
    // ever tightened: the nonlinear CG's updates alternate (a long step, then one about as long), so
    // within 15 iterations every step was 1/64 of the update and a sliding interface's solve crawled
    // (the phantom's kidney moved 10 mm: 526 iterations; with the recovery 24, the same answer).
    if (it > 0 && update > 0.9 * update0) relax = std::max(relax * 0.5, 1.0 / 64.0);
    else if (it > 0 && update < 0.5 * update0) relax = std::min(1.0, relax * 2.0);
    update0 = update;
    if (update <= tol) {
      st.converged = true;
      break;
    }
  }
  return st;
}

}  // namespace handson
