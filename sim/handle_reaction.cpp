// Handle reactions on the fine mesh and from the coarse model's condensed blocks.
//
// Coarse model, per element e (rotation R_e, corner displacements d = R_e^T x_e - X_e, 24-vector;
// for each handle k it touches, p_k = [vec(R_e^T R_k - I); R_e^T t_k], 12-vector): the condensed
// energy is E_e = 1/2 [d; u_D]^T [K_h K_hd; K_dh K_dd] [d; u_D] with u_D = U p (U: the handle nodes'
// unit motions, sim/coarsening.h). Its gradient against handle k's 12 motion parameters is
//   g_k = [A_k B_k]^T d + sum_l Q_kl p_l      (12; [A_k B_k] = K_hd U_k, Q_kl = U_k^T K_dd U_l),
// whose entries are g_k[3c+r] = sum_D X_D,c w_D,r and g_k[9+r] = sum_D w_D,r for w_D = dE/du_D (the
// element-frame force on node D, negated). So the handle's non-corner nodes D receive
//   F = -R_e g_k[9..11],
//   T_O = sum_D x_D x f_D = -R_k sum_c e_c x (R_k^T R_e g_k[3c..3c+2]) - t_k x R_e g_k[9..11]
// (x_D = R_k X_D + t_k; moments about the world origin), and the handle's coarse corners receive
// their rows of -R_e (K_h d + h_e) with moments x_c x f_c. No fine work: a pass over the elements.
// R_e is not the solve's corner-fit rotation but the element's moment-free frame, where E_e is
// stationary (stationaryRotation; docs/simulation-outputs.md, "Reaction force and torque"), except
// in an element that holds a sliding interface, whose normals are fixed in the solve's frame.
#include "sim/handle_reaction.h"

#include <algorithm>

#include <Eigen/Geometry>
#include <cstdio>

#include "sim/base/error.h"
#include "sim/fem.h"

namespace handson {

namespace {

constexpr double kNewtonPerPaMm2 = 1e-6;

// Moments about the world origin moved to each handle's current centroid, and the units applied.
std::vector<HandleReaction> aboutCentroids(std::vector<HandleReaction> r, const std::vector<Eigen::Vector3d>& restCentroid,
                                           const std::vector<RigidTransform>& handles) {
  for (std::size_t k = 0; k < r.size(); ++k) {
    const Eigen::Vector3d c = handles[k].apply(restCentroid[k]);
    r[k].centreMm = c;
    r[k].torqueNmm = (r[k].torqueNmm - c.cross(r[k].forceN)) * kNewtonPerPaMm2;
    r[k].forceN *= kNewtonPerPaMm2;
  }
  return r;
}

}  // namespace

std::string formatReaction(const HandleReaction& r, bool coarse) {
  char buf[96];
  if (coarse) std::snprintf(buf, sizeof buf, "tissue force ~%.2g N, torque ~%.2g N mm (coarse model)", r.forceN.norm(), r.torqueNmm.norm());
  else std::snprintf(buf, sizeof buf, "tissue force %.3g N, torque %.3g N mm", r.forceN.norm(), r.torqueNmm.norm());
  return buf;
}

std::vector<Eigen::Vector3d> handleRestCentroids(const TetMesh& fine, const FineConstraints& cons) {
  std::vector<Eigen::Vector3d> sum(std::size_t(cons.handleCount), Eigen::Vector3d::Zero());
  std::vector<double> n(std::size_t(cons.handleCount), 0.0);
  for (std::size_t i = 0; i < fine.nodes.size(); ++i) {
    const int k = cons.handleOf[i];
    if (k < 0 || cons.fixed[i]) continue;
    sum[std::size_t(k)] += fine.nodes[i];
    n[std::size_t(k)] += 1.0;
  }
  for (const SlideNode& s : cons.slide) {  // a sliding handle's surface nodes are its too
    sum[std::size_t(s.handle)] += fine.nodes[std::size_t(s.node)];
    n[std::size_t(s.handle)] += 1.0;
  }
  for (std::size_t k = 0; k < sum.size(); ++k)
    if (n[k] > 0) sum[k] /= n[k];
  return sum;
}

std::vector<HandleReaction> fineHandleReactions(const TetMesh& F, const std::vector<Mat12>& fineK, const FineConstraints& cons,
                                                const std::vector<RigidTransform>& handles, const std::vector<Eigen::Vector3d>& x,
                                                const std::vector<NeoHookeanTet>* hyperelastic) {
  if (fineK.size() != F.tets.size() || x.size() != F.nodes.size() || cons.handleOf.size() != F.nodes.size() || cons.fixed.size() != F.nodes.size() ||
      int(handles.size()) < cons.handleCount || (hyperelastic && hyperelastic->size() != F.tets.size()))
    throw Error("handle reactions: inconsistent sizes");
  // The tissue's forces on the handles' nodes and on the sliding interfaces' nodes.
  std::vector<char> carries(F.nodes.size(), 0);
  for (std::size_t i = 0; i < F.nodes.size(); ++i) carries[i] = cons.handleOf[i] >= 0 && !cons.fixed[i];
  for (const SlideNode& s : cons.slide) carries[std::size_t(s.node)] = 1;
  std::vector<Eigen::Vector3d> f(F.nodes.size(), Eigen::Vector3d::Zero());
  for (std::size_t t = 0; t < F.tets.size(); ++t) {
    const auto& tet = F.tets[t];
    if (std::none_of(tet.begin(), tet.end(), [&](int v) { return carries[std::size_t(v)] != 0; })) continue;
    const Vec12 ft = hyperelastic ? neoHookeanForce((*hyperelastic)[t], tetCorners(tet, x)) : corotationalForce(fineK[t], tetCorners(tet, F.nodes), tetCorners(tet, x));
    for (int a = 0; a < 4; ++a) f[std::size_t(tet[std::size_t(a)])] += ft.segment<3>(3 * a);
  }
  std::vector<HandleReaction> r(std::size_t(cons.handleCount));
  auto add = [&](int k, std::size_t v, const Eigen::Vector3d& fv) {
    r[std::size_t(k)].forceN += fv;
    r[std::size_t(k)].torqueNmm += x[v].cross(fv);
  };
  for (std::size_t v = 0; v < F.nodes.size(); ++v)
    if (cons.handleOf[v] >= 0 && !cons.fixed[v]) add(cons.handleOf[v], v, f[v]);
  // A sliding interface passes on the normal part of the tissue's force on its nodes (at
  // equilibrium all of it: the springs balance it). Taken from the tissue, not from the springs'
  // k n (n . gap), so that a state short of equilibrium is as accurate here as a glued one: the
  // springs are kSlidePenalty times stiffer than the tissue, and their gaps' errors with them.
  const std::vector<NormalSpring> springs = slideSprings(F, cons.slide, handles);
  for (std::size_t i = 0; i < springs.size(); ++i) {
    const auto v = std::size_t(springs[i].node);
    add(cons.slide[i].handle, v, springs[i].normal.dot(f[v]) * springs[i].normal);
  }
  return aboutCentroids(std::move(r), handleRestCentroids(F, cons), handles);
}

CoarseModel::ElementLoad CoarseModel::elementLoad(const Element& el, const Eigen::Matrix3d& R, const std::vector<Eigen::Vector3d>& x,
                                                  const std::vector<RigidTransform>& handles) const {
  ElementLoad L;
  const int nc = nc_;
  L.d.resize(3 * nc);
  for (int c = 0; c < nc; ++c) {
    const auto v = std::size_t(el.node[std::size_t(c)]);
    L.d.segment<3>(3 * c) = R.transpose() * x[v] - nodes_[v];
  }
  const std::size_t h = el.handles.size();
  L.p.resize(12 * Eigen::Index(h));
  for (std::size_t a = 0; a < h; ++a) {
    const RigidTransform& T = handles[std::size_t(el.handles[a].handle)];
    const Eigen::Matrix3d M = R.transpose() * T.R - Eigen::Matrix3d::Identity();
    L.p.segment<9>(12 * Eigen::Index(a)) = Eigen::Map<const Eigen::Matrix<double, 9, 1>>(M.data());
    L.p.segment<3>(12 * Eigen::Index(a) + 9) = R.transpose() * T.t;
  }
  L.corner = el.Kh * L.d + handleTerm(el, R, handles);
  L.g.resize(h);
  for (std::size_t a = 0; a < h; ++a) {
    const HandleBlock& b = el.handles[a];
    L.g[a].head<9>() = b.A.transpose() * L.d;
    L.g[a].tail<3>() = b.B.transpose() * L.d;
    L.g[a] += el.Q.middleRows(12 * Eigen::Index(a), 12) * L.p;
  }
  return L;
}

Eigen::Vector3d CoarseModel::elementMoment(const Element& el, const Eigen::Matrix3d& R, const ElementLoad& L, const std::vector<RigidTransform>& handles) const {
  // m = sum over the element's nodes of y_n x w_n in its frame (y_n = R^T x_n, w_n = dE/dy_n): the
  // corners' y_c = d_c + X_c; a handle's nodes y_D = M X_D + b (M = R^T R_k, b = R^T t_k) sum to
  // sum_c M e_c x g[3c..3c+2] + b x g[9..11].
  Eigen::Vector3d m = Eigen::Vector3d::Zero();
  for (int c = 0; c < nc_; ++c)
    m += (L.d.segment<3>(3 * c) + nodes_[std::size_t(el.node[std::size_t(c)])]).cross(L.corner.segment<3>(3 * c));
  for (std::size_t a = 0; a < el.handles.size(); ++a) {
    const RigidTransform& T = handles[std::size_t(el.handles[a].handle)];
    const Eigen::Matrix3d M = R.transpose() * T.R;
    for (int c = 0; c < 3; ++c) m += M.col(c).cross(L.g[a].segment<3>(3 * c));
    m += (R.transpose() * T.t).cross(L.g[a].tail<3>());
  }
  return m;
}

Eigen::Matrix3d CoarseModel::momentJacobian(const Element& el, const Eigen::Matrix3d& R, const ElementLoad& L, const std::vector<RigidTransform>& handles) const {
  // Turning the frame by w (R -> R exp([w]x)) turns every element-frame vector v the moment pairs
  // (the corners' y_c, a handle's M e_c and b) by -w: dv = [v]x dw. The energy is quadratic in
  // q = (d, p), E = 1/2 q^T H q with H = [K_h, [A B]; [A B]^T, Q], and its gradient is H q = (the
  // corner forces, g). With G (3n + 12h x 3) stacking the blocks [v]x:
  //   J = dm/dw = -sum_k [grad_k]x [v_k]x - G^T H G.
  const int nc = nc_, h = int(el.handles.size());
  Eigen::Matrix<double, Eigen::Dynamic, 3> G(3 * nc + 12 * h, 3);
  Eigen::Matrix3d J = Eigen::Matrix3d::Zero();
  auto term = [&](int row, const Eigen::Vector3d& v, const Eigen::Vector3d& grad) {
    G.middleRows<3>(row) = crossMatrix(v);
    J -= crossMatrix(grad) * crossMatrix(v);
  };
  for (int c = 0; c < nc; ++c) term(3 * c, L.d.segment<3>(3 * c) + nodes_[std::size_t(el.node[std::size_t(c)])], L.corner.segment<3>(3 * c));
  for (int a = 0; a < h; ++a) {
    const RigidTransform& T = handles[std::size_t(el.handles[std::size_t(a)].handle)];
    const Eigen::Matrix3d M = R.transpose() * T.R;
    for (int c = 0; c < 3; ++c) term(3 * nc + 12 * a + 3 * c, M.col(c), L.g[std::size_t(a)].segment<3>(3 * c));
    term(3 * nc + 12 * a + 9, R.transpose() * T.t, L.g[std::size_t(a)].tail<3>());
  }
  const auto Gd = G.topRows(3 * nc);
  Eigen::Matrix<double, Eigen::Dynamic, 3> HG(3 * nc + 12 * h, 3);
  HG.topRows(3 * nc).noalias() = el.Kh.lazyProduct(Gd);  // small: no GEMM packing
  for (int a = 0; a < h; ++a) {
    const HandleBlock& b = el.handles[std::size_t(a)];
    HG.topRows(3 * nc).noalias() += b.A.lazyProduct(G.middleRows<9>(3 * nc + 12 * a)) + b.B.lazyProduct(G.middleRows<3>(3 * nc + 12 * a + 9));
    HG.middleRows<9>(3 * nc + 12 * a).noalias() = b.A.transpose().lazyProduct(Gd);
    HG.middleRows<3>(3 * nc + 12 * a + 9).noalias() = b.B.transpose().lazyProduct(Gd);
  }
  if (h > 0) HG.bottomRows(12 * h).noalias() += el.Q.lazyProduct(G.bottomRows(12 * h));
  return J - G.transpose().lazyProduct(HG);
}

Eigen::Matrix3d CoarseModel::stationaryRotation(const Element& el, const Eigen::Matrix3d& R0, const std::vector<Eigen::Vector3d>& x,
                                                const std::vector<RigidTransform>& handles, ElementLoad& L) const {
  // E(R exp([w]x)) has gradient -m(R) against w at w = 0: the frame is sought where m = 0, by
  // Levenberg-Marquardt on |m|^2 from R0 with the exact Jacobian (momentJacobian): a step
  // (J^T J + lambda I) w = -J^T m is kept only if it shrinks |m| (lambda eases after a kept step,
  // grows after a refused one), so the search cannot cycle, and steps are at most 0.1 rad, so it
  // stays with the stationary frame nearest R0. Not a minimization of E: a linear-strain energy
  // is not rotation invariant, and a stretched element's energy falls as its frame turns (the
  // rotation's own linear strain is a compression), so its moment-free frame is a saddle of E, as
  // the polar rotation is for a stretched fine tet. Converged when |m| is 1e-7 of the sum of its
  // terms' magnitudes; otherwise, after 20 evaluations, the frame of least |m| found (a few
  // elements at a handle: its |m| 1e-4..1e-3 of that sum, against the fit frame's 1e-1).
  auto turn = [](const Eigen::Matrix3d& R, const Eigen::Vector3d& w) {
    const double a = w.norm();
    return a > 0 ? Eigen::Matrix3d(R * Eigen::AngleAxisd(a, w / a).toRotationMatrix()) : R;
  };
  auto scale = [&](const ElementLoad& load, const Eigen::Matrix3d& R) {
    double s = 0.0;
    for (int c = 0; c < nc_; ++c) s += (load.d.segment<3>(3 * c) + nodes_[std::size_t(el.node[std::size_t(c)])]).norm() * load.corner.segment<3>(3 * c).norm();
    for (std::size_t a = 0; a < el.handles.size(); ++a) {
      for (int c = 0; c < 3; ++c) s += load.g[a].segment<3>(3 * c).norm();
      s += (R.transpose() * handles[std::size_t(el.handles[a].handle)].t).norm() * load.g[a].tail<3>().norm();
    }
    return s;
  };
  Eigen::Matrix3d R = R0;
  L = elementLoad(el, R, x, handles);
  Eigen::Vector3d m = elementMoment(el, R, L, handles);
  Eigen::Matrix3d J = momentJacobian(el, R, L, handles);
  double lambda = 0.0;
  for (int evaluation = 0; evaluation < 20; ++evaluation) {
    if (m.norm() <= 1e-7 * scale(L, R)) return R;
    const Eigen::Matrix3d JtJ = J.transpose() * J;
    Eigen::Vector3d w = -(JtJ + lambda * Eigen::Matrix3d::Identity()).ldlt().solve(J.transpose() * m);
    if (!w.allFinite() || w.norm() == 0.0) break;
    if (w.norm() > 0.1) w *= 0.1 / w.norm();
    const Eigen::Matrix3d Rn = turn(R, w);
    ElementLoad Ln = elementLoad(el, Rn, x, handles);
    const Eigen::Vector3d mn = elementMoment(el, Rn, Ln, handles);
    if (mn.norm() < m.norm()) {
      R = Rn;
      L = std::move(Ln);
      m = mn;
      J = momentJacobian(el, R, L, handles);
      lambda /= 3.0;
    } else {
      lambda = std::max(4.0 * lambda, 1e-6 * JtJ.trace());
    }
  }
  return R;  // the frame of least |m| found (L is its load)
}

void CoarseModel::addElementReaction(const Element& el, const Eigen::Matrix3d& Rc, const ElementLoad& L, const std::vector<Eigen::Vector3d>& x,
                                     const std::vector<RigidTransform>& handles, std::vector<HandleReaction>& r) const {
  // The handles' coarse corners: their rows of the element force.
  for (int c = 0; c < nc_; ++c) {
    const auto v = std::size_t(el.node[std::size_t(c)]);
    const int k = coarseRole_[v];
    if (k < 0) continue;
    const Eigen::Vector3d f = -(Rc * L.corner.segment<3>(3 * c));
    r[std::size_t(k)].forceN += f;
    r[std::size_t(k)].torqueNmm += x[v].cross(f);
  }
  // The handles' other nodes, through the condensed blocks.
  for (std::size_t a = 0; a < el.handles.size(); ++a) {
    const RigidTransform& T = handles[std::size_t(el.handles[a].handle)];
    const Eigen::Matrix3d Rp = T.R.transpose() * Rc;
    const Eigen::Vector3d gt = Rc * L.g[a].tail<3>();
    Eigen::Vector3d m = Eigen::Vector3d::Zero();
    for (int c = 0; c < 3; ++c) m += Eigen::Vector3d::Unit(c).cross(Rp * L.g[a].segment<3>(3 * c));
    r[std::size_t(el.handles[a].handle)].forceN -= gt;
    r[std::size_t(el.handles[a].handle)].torqueNmm -= T.R * m + T.t.cross(gt);
  }
}

std::vector<HandleReaction> CoarseModel::handleReactions(const std::vector<RigidTransform>& given, const std::vector<Eigen::Vector3d>& x) const {
  if (int(given.size()) < constraints_.handleCount || x.size() != nodes_.size()) throw Error("handle reactions: inconsistent sizes");
  const std::vector<RigidTransform> handles = withAnchor(given);
  std::vector<HandleReaction> r(std::size_t(constraints_.handleCount) + 1);  // the anchor's last, dropped
  const int nc = nc_;
  for (std::size_t e = 0; e < elements_.size(); ++e) {
    const Element& el = elements_[e];
    bool handleCorner = false;
    for (int c = 0; c < nc; ++c) handleCorner = handleCorner || coarseRole_[std::size_t(el.node[std::size_t(c)])] >= 0;
    if (el.handles.empty() && !handleCorner) continue;
    // Each element at a handle in the frame where its energy is stationary; one whose corners and
    // other handle nodes all belong to one handle moves rigidly with it (its interior condensed to
    // follow), and its corner fit is that frame already. One that holds a sliding interface in the
    // solve's own frame, the corner fit: the interface's normals are fixed in the element's frame,
    // so another frame turns them against the tissue's slip and changes the gaps the solve
    // balanced, at a hundred times the tissue's stiffness (docs/simulation-outputs.md).
    bool rigid = coarseRole_[std::size_t(el.node[0])] >= 0;
    for (int c = 0; c < nc; ++c) rigid = rigid && coarseRole_[std::size_t(el.node[std::size_t(c)])] == coarseRole_[std::size_t(el.node[0])];
    for (const auto& b : el.handles) rigid = rigid && b.handle == coarseRole_[std::size_t(el.node[0])];
    const Eigen::Matrix3d Rfit = elementRotation(int(e), x);
    if (rigid || el.slides) {
      addElementReaction(el, Rfit, elementLoad(el, Rfit, x, handles), x, handles, r);
      continue;
    }
    ElementLoad L;
    const Eigen::Matrix3d Rc = stationaryRotation(el, Rfit, x, handles, L);
    addElementReaction(el, Rc, L, x, handles, r);
  }
  r.pop_back();
  return aboutCentroids(std::move(r), handleRestCentroid_, given);
}

double CoarseModel::storedEnergy(const std::vector<RigidTransform>& given, const std::vector<Eigen::Vector3d>& x) const {
  if (int(given.size()) < constraints_.handleCount || x.size() != nodes_.size()) throw Error("stored energy: inconsistent sizes");
  const std::vector<RigidTransform> handles = withAnchor(given);
  double E = 0.0;  // q^T H q = d . (K_h d + [A B] p) + sum_a p_a . g_a
  for (std::size_t e = 0; e < elements_.size(); ++e) {
    const ElementLoad L = elementLoad(elements_[e], elementRotation(int(e), x), x, handles);
    E += 0.5 * L.d.dot(L.corner);
    for (std::size_t a = 0; a < L.g.size(); ++a) E += 0.5 * L.p.segment<12>(12 * Eigen::Index(a)).dot(L.g[a]);
  }
  return E * kNewtonPerPaMm2;
}

}  // namespace handson
