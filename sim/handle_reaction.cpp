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
#include "sim/handle_reaction.h"

#include <Eigen/Geometry>
#include <cstdio>

#include "sim/error.h"
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
  if (coarse) std::snprintf(buf, sizeof buf, "tissue force ~%.2g N (coarse model)", r.forceN.norm());
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
  for (std::size_t k = 0; k < sum.size(); ++k)
    if (n[k] > 0) sum[k] /= n[k];
  return sum;
}

std::vector<HandleReaction> fineHandleReactions(const TetMesh& F, const std::vector<Mat12>& fineK, const FineConstraints& cons,
                                                const std::vector<RigidTransform>& handles, const std::vector<Eigen::Vector3d>& x) {
  if (fineK.size() != F.tets.size() || x.size() != F.nodes.size() || cons.handleOf.size() != F.nodes.size() || cons.fixed.size() != F.nodes.size() ||
      int(handles.size()) < cons.handleCount)
    throw Error("handle reactions: inconsistent sizes");
  std::vector<HandleReaction> r(std::size_t(cons.handleCount));
  for (std::size_t t = 0; t < F.tets.size(); ++t) {
    const auto& tet = F.tets[t];
    bool touches = false;
    for (int v : tet) touches = touches || (cons.handleOf[std::size_t(v)] >= 0 && !cons.fixed[std::size_t(v)]);
    if (!touches) continue;
    const Vec12 f = corotationalForce(fineK[t], tetCorners(tet, F.nodes), tetCorners(tet, x));
    for (int a = 0; a < 4; ++a) {
      const auto v = std::size_t(tet[std::size_t(a)]);
      const int k = cons.handleOf[v];
      if (k < 0 || cons.fixed[v]) continue;
      r[std::size_t(k)].forceN += f.segment<3>(3 * a);
      r[std::size_t(k)].torqueNmm += x[v].cross(f.segment<3>(3 * a));
    }
  }
  return aboutCentroids(std::move(r), handleRestCentroids(F, cons), handles);
}

std::vector<HandleReaction> CoarseModel::handleReactions(const std::vector<RigidTransform>& handles, const std::vector<Eigen::Vector3d>& x) const {
  if (int(handles.size()) < constraints_.handleCount || x.size() != nodes_.size()) throw Error("handle reactions: inconsistent sizes");
  std::vector<HandleReaction> r(std::size_t(constraints_.handleCount));
  const int nc = nc_;
  for (std::size_t e = 0; e < elements_.size(); ++e) {
    const Element& el = elements_[e];
    bool handleCorner = false;
    for (int c = 0; c < nc; ++c) handleCorner = handleCorner || coarseRole_[std::size_t(el.node[std::size_t(c)])] >= 0;
    if (el.handles.empty() && !handleCorner) continue;
    const Eigen::Matrix3d Rc = elementRotation(int(e), x);  // only the elements at a handle: not all
    VecE d(3 * nc);
    for (int c = 0; c < nc; ++c) {
      const auto v = std::size_t(el.node[std::size_t(c)]);
      d.segment<3>(3 * c) = Rc.transpose() * x[v] - nodes_[v];
    }
    const std::size_t h = el.handles.size();
    Eigen::VectorXd p(12 * Eigen::Index(h));
    for (std::size_t a = 0; a < h; ++a) {
      const RigidTransform& T = handles[std::size_t(el.handles[a].handle)];
      const Eigen::Matrix3d M = Rc.transpose() * T.R - Eigen::Matrix3d::Identity();
      p.segment<9>(12 * Eigen::Index(a)) = Eigen::Map<const Eigen::Matrix<double, 9, 1>>(M.data());
      p.segment<3>(12 * Eigen::Index(a) + 9) = Rc.transpose() * T.t;
    }
    // The handles' coarse corners: their rows of the element force.
    if (handleCorner) {
      VecE local = el.Kh * d;
      for (std::size_t a = 0; a < h; ++a)
        local.noalias() += el.handles[a].A * p.segment<9>(12 * Eigen::Index(a)) + el.handles[a].B * p.segment<3>(12 * Eigen::Index(a) + 9);
      for (int c = 0; c < nc; ++c) {
        const auto v = std::size_t(el.node[std::size_t(c)]);
        const int k = coarseRole_[v];
        if (k < 0) continue;
        const Eigen::Vector3d f = -(Rc * local.segment<3>(3 * c));
        r[std::size_t(k)].forceN += f;
        r[std::size_t(k)].torqueNmm += x[v].cross(f);
      }
    }
    // The handles' other nodes, through the condensed blocks.
    for (std::size_t a = 0; a < h; ++a) {
      const HandleBlock& b = el.handles[a];
      Eigen::Matrix<double, 12, 1> g;
      g.head<9>() = b.A.transpose() * d;
      g.tail<3>() = b.B.transpose() * d;
      g.noalias() += el.Q.middleRows(12 * Eigen::Index(a), 12) * p;
      const RigidTransform& T = handles[std::size_t(b.handle)];
      const Eigen::Matrix3d Rp = T.R.transpose() * Rc;
      const Eigen::Vector3d gt = Rc * g.tail<3>();
      Eigen::Vector3d m = Eigen::Vector3d::Zero();
      for (int c = 0; c < 3; ++c) m += Eigen::Vector3d::Unit(c).cross(Rp * g.segment<3>(3 * c));
      r[std::size_t(b.handle)].forceN -= gt;
      r[std::size_t(b.handle)].torqueNmm -= T.R * m + T.t.cross(gt);
    }
  }
  return aboutCentroids(std::move(r), handleRestCentroid_, handles);
}

}  // namespace handson
