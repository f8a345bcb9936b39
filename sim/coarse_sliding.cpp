// The coarse model's sliding interfaces (sim/sliding_interface.h): each slide node's normal spring
// to its handle is condensed into the elements that hold the node, as a Dirichlet ghost node of the
// handle, so a frame's cost does not grow with the interface's fine node count.
#include <algorithm>

#include "sim/coarsening.h"

namespace handson {

CoarseModel::SlideShares CoarseModel::slideShares(const std::vector<std::vector<int>>& tetsOf, const std::vector<Mat12>& fineK) const {
  const TetMesh& F = meshes_.fine;
  SlideShares s;
  if (constraints_.slide.empty()) return s;
  s.slideOf.assign(F.nodes.size(), -1);
  for (std::size_t i = 0; i < constraints_.slide.size(); ++i) s.slideOf[std::size_t(constraints_.slide[i].node)] = int(i);
  s.coarseNode.assign(F.nodes.size(), 0);
  for (const int f : nodeFine_)
    if (f >= 0) s.coarseNode[std::size_t(f)] = 1;
  s.rigidTet.assign(F.tets.size(), 0);
  for (std::size_t t = 0; t < F.tets.size(); ++t) s.rigidTet[t] = fineK[t].isZero(0.0);
  s.elementCount.assign(F.nodes.size(), 0);
  std::vector<int> lastSeen(F.nodes.size(), -1);
  for (std::size_t e = 0; e < tetsOf.size(); ++e)
    for (int t : tetsOf[e]) {
      if (s.rigidTet[std::size_t(t)]) continue;
      for (int v : F.tets[std::size_t(t)])
        if (lastSeen[std::size_t(v)] != int(e)) {
          lastSeen[std::size_t(v)] = int(e);
          ++s.elementCount[std::size_t(v)];
        }
    }
  return s;
}

std::vector<int> CoarseModel::SlideShares::of(const std::vector<int>& nodes, const std::vector<int>& tets, const TetMesh& fine,
                                              const std::unordered_map<int, int>& local, std::vector<char>& touches) const {
  std::vector<int> out;
  touches.assign(nodes.size(), 1);
  if (slideOf.empty()) return out;
  std::fill(touches.begin(), touches.end(), 0);
  for (int t : tets)
    if (!rigidTet[std::size_t(t)])
      for (int v : fine.tets[std::size_t(t)]) touches[std::size_t(local.at(v))] = 1;
  for (std::size_t l = 0; l < nodes.size(); ++l)
    if (touches[l] && slideOf[std::size_t(nodes[l])] >= 0) out.push_back(slideOf[std::size_t(nodes[l])]);
  return out;
}

// The spring's energy k/c (n . (u_l - u_g))^2 / 2 in the element's frame: K's blocks (l,l) and
// (g,g) gain k/c n n^T, (l,g) and (g,l) lose it.
void CoarseModel::addGhost(Eigen::MatrixXd& K, int l, int g, const SlideShares& shares, int s, ElementNodes& roles) const {
  const SlideNode& sn = constraints_.slide[std::size_t(s)];
  const double k = sn.stiffness / double(std::max(1, shares.elementCount[std::size_t(sn.node)]));
  const Eigen::Matrix3d kn = k * sn.normal * sn.normal.transpose();
  K.block<3, 3>(3 * l, 3 * l) += kn;
  K.block<3, 3>(3 * g, 3 * g) += kn;
  K.block<3, 3>(3 * l, 3 * g) -= kn;
  K.block<3, 3>(3 * g, 3 * l) -= kn;
  roles.addDirichlet(g, sn.handle, meshes_.fine.nodes[std::size_t(sn.node)]);
}

void CoarseModel::holdSurfaceSlides(const ElementNodes& roles, const std::vector<int>& nodes, const SlideShares& slide, std::size_t firstGhost,
                                    Eigen::MatrixXd& Phic, Eigen::MatrixXd& PhiD) const {
  for (std::size_t j = 0; j < roles.S.size(); ++j) {
    const int l = roles.S[j];
    const Eigen::Vector3d& nrm = constraints_.slide[std::size_t(slide.slideOf[std::size_t(nodes[std::size_t(l)])])].normal;
    const Eigen::Matrix3d Pn = nrm * nrm.transpose();
    for (int c = 0; c < nc_; ++c) Phic.block<3, 3>(3 * l, 3 * c) = roles.Sw[j][c] * (Eigen::Matrix3d::Identity() - Pn);
    PhiD.block<3, 3>(3 * l, 3 * Eigen::Index(firstGhost + j)) = Pn;
  }
}

}  // namespace handson
