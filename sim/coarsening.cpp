#include "coarsening.h"

#include <Eigen/Dense>
#include <Eigen/Geometry>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <unordered_map>

#include "sim/base/binary_io.h"
#include "sim/slide_io.h"
#include "sim/blas_threads.h"
#include "sim/handle_reaction.h"
#include "sim/coarse_pcg_workspace.h"
#include "sim/base/error.h"

namespace handson {

namespace {

using Mat = Eigen::MatrixXd;

}  // namespace

Eigen::Matrix<double, 3, 12> unitMotions(const Eigen::Vector3d& X) {
  Eigen::Matrix<double, 3, 12> U = Eigen::Matrix<double, 3, 12>::Zero();
  for (int c = 0; c < 3; ++c)
    for (int r = 0; r < 3; ++r) U(r, 3 * c + r) = X[c];
  U.rightCols<3>().setIdentity();
  return U;
}

namespace {

// vec (column-major) of M = R_c^T R - I as the 9 numbers A multiplies.
Eigen::Matrix<double, 9, 1> unroll(const Eigen::Matrix3d& M) {
  Eigen::Matrix<double, 9, 1> v;
  for (int c = 0; c < 3; ++c)
    for (int r = 0; r < 3; ++r) v[3 * c + r] = M(r, c);
  return v;
}

std::array<Eigen::Vector3d, 4> cornersOf(const TetMesh& m, int t, const std::vector<Eigen::Vector3d>& x) { return tetCorners(m.tets[std::size_t(t)], x); }

Eigen::Vector4d barycentric(const std::array<Eigen::Vector3d, 4>& X, const Eigen::Vector3d& p) {
  Eigen::Matrix3d D;
  D << X[1] - X[0], X[2] - X[0], X[3] - X[0];
  const Eigen::Vector3d l = D.inverse() * (p - X[0]);
  return {1.0 - l.sum(), l.x(), l.y(), l.z()};
}

}  // namespace

const char* coarseElementName(CoarseElement e) {
  switch (e) {
    case CoarseElement::Tet: return "tet";
    case CoarseElement::Cell: return "cell";
  }
  return "?";
}
const char* coarseSolverName(CoarseSolver s) { return s == CoarseSolver::Assembled ? "assembled" : "pcg"; }

void CoarseModel::setPcgOptions(const PcgOptions& o) {
  if (o.cgIterations < 1 || o.cgIterations > 16) throw Error("coarse solve: 1 to 16 conjugate-gradient iterations an iteration");
  if (!(o.refreshDeg >= 0.0 && o.refreshDeg <= 180.0)) throw Error("coarse solve: the preconditioner's refresh angle must be 0 (never) to 180 degrees");
  if (o.refreshFromIteration < 0) throw Error("coarse solve: the preconditioner's refresh cannot start before a call's first iteration");
  if (o.andersonDepth < 0 || o.andersonDepth > 16) throw Error("coarse solve: Anderson acceleration keeps 0 to 16 secant pairs");
  pcgOptions_ = o;
}

int CoarseModel::elementOfFineTet(std::size_t t) const {
  if (graded_) return leafOfFineTet_[t];
  if (cut_) return cut_->elementOfTet[t];
  const int p = meshes_.fineParent[t];
  return kind_ == CoarseElement::Tet ? p : p / 6;
}

CoarseModel::CoarseModel(const NestedMeshes& meshes, const std::vector<Mat12>& fineK, const FineConstraints& cons, const ProgressFn& progress,
                         CoarseElement kind, const CoarseGrading& grading)
    : meshes_(meshes), constraints_(cons), nodes_(meshes.coarse.nodes), nodeFine_(meshes.coarseNodeInFine), kind_(kind),
      nc_(kind == CoarseElement::Tet ? 4 : 8) {
  const TetMesh& C = meshes.coarse;
  const TetMesh& F = meshes.fine;
  if (fineK.size() != F.tets.size() || cons.handleOf.size() != F.nodes.size() || cons.fixed.size() != F.nodes.size() ||
      meshes.fineParent.size() != F.tets.size())
    throw Error("coarsening: inconsistent sizes");
  if (kind_ != CoarseElement::Tet && C.tets.size() != meshes.coarseGrid.cellCount() * 6)
    throw Error("coarsening: cell elements need the coarse mesh of the coarse grid");
  if (kind_ == CoarseElement::Tet && !meshes.regularFine)
    throw Error("coarsening: tet elements need the regular fine mesh (an image-adapted one is nested in cells, not tets)");
  // The outer boundary wins over a handle on it: those nodes stay fixed.
  for (std::size_t i = 0; i < F.nodes.size(); ++i)
    if (constraints_.fixed[i]) constraints_.handleOf[i] = -1;

  std::vector<std::vector<int>> tetsOf;
  const bool cutMesh = !meshes.cutSource.empty();
  if (cutMesh && (grading.graded() || kind_ != CoarseElement::Cell))
    throw Error("coarsening: on a cut mesh only the uniform cell elements (the default) split where the cut passes; graded cells and tet elements do not see cuts");
  if (grading.graded()) {
    buildGradedLeaves(grading, tetsOf);
  } else {
    tetsOf = ungradedTets();
    if (cutMesh) separateCutCells(tetsOf);
  }
  buildConforming(fineK, tetsOf, progress);
  stiffenVirtualCorners();
  finishBuild(progress);
}

std::vector<std::vector<int>> CoarseModel::ungradedTets() const {
  const TetMesh& F = meshes_.fine;
  std::vector<std::vector<int>> tetsOf(kind_ == CoarseElement::Tet ? meshes_.coarse.tets.size() : meshes_.coarseGrid.cellCount());
  for (std::size_t t = 0; t < F.tets.size(); ++t) {
    if (meshes_.fineParent[t] < 0 || std::size_t(meshes_.fineParent[t]) >= meshes_.coarse.tets.size())
      throw Error("coarsening: a fine tet lies outside the coarse mesh");
    tetsOf[std::size_t(kind_ == CoarseElement::Tet ? meshes_.fineParent[t] : meshes_.fineParent[t] / 6)].push_back(int(t));
  }
  return tetsOf;
}

// Coarse Dirichlet roles and the free dofs' system.
void CoarseModel::finishBuild(const ProgressFn& progress) {
  const auto& handleOf = constraints_.handleOf;
  coarseRole_.assign(nodes_.size(), -1);
  dof_.assign(nodes_.size(), -1);
  for (std::size_t v = 0; v < nodes_.size(); ++v) {
    const int f = nodeFine_[v];
    if (f < 0) dof_[v] = (dofCount_ += 3) - 3;  // a cut's virtual node: free
    else if (constraints_.fixed[std::size_t(f)]) coarseRole_[v] = -2;
    else if (handleOf[std::size_t(f)] >= 0) coarseRole_[v] = handleOf[std::size_t(f)];
    else if (graded_ && !hang_[v].empty()) coarseRole_[v] = -3;
    else dof_[v] = (dofCount_ += 3) - 3;
  }
  buildAssembler();
  handleRestCentroid_ = handleRestCentroids(meshes_.fine, constraints_);
  reportProgress(progress, 1.0, "coarsening");
}

// What the elements' condensation shares: the fine stiffness, each element's fine tets, the sliding
// interfaces' shares, and scratch (fine -> local node, per local node whether it touches tissue,
// per fine node whether its reconstruction record is written).
struct CoarseModel::ConformingBuild {
  const std::vector<Mat12>& fineK;
  const std::vector<std::vector<int>>& tetsOf;
  SlideShares slide;
  std::unordered_map<int, int> local;
  std::vector<char> touches, recorded;
};

// One element's fine problem: its fine nodes (local order, corners first), their roles, the
// stiffness K (3n' x 3n', n' = n + the sliding ghosts) and the shape functions Phi_c (3n' x 3nc)
// and Phi_D (3n' x 3nD); after condenseInterior, H (3nI x 3nc) and G (3nI x 3nD) are the interior
// nodes' rows of them.
struct CoarseModel::ElementSystem {
  std::vector<int> nodes;
  ElementNodes roles;
  Mat K, Phic, PhiD, H, G;
  bool slides = false;  ///< it holds springs or slide nodes on its faces
};

void CoarseModel::buildConforming(const std::vector<Mat12>& fineK, const std::vector<std::vector<int>>& tetsOf, const ProgressFn& progress,
                                  const std::vector<char>* only) {
  const std::size_t elementCount = tetsOf.size();
  ConformingBuild b{fineK, tetsOf, slideShares(tetsOf, fineK), {}, {}, {}};
  // A fine node takes its position from one record; coarse nodes are their own (graded: a hanging
  // node also lies on a whole cell's face, and is condensed there as a face node, not recorded).
  b.recorded.assign(meshes_.fine.nodes.size(), 0);
  for (const int f : nodeFine_)
    if (f >= 0) b.recorded[std::size_t(f)] = 1;
  for (const auto& in : interior_) b.recorded[std::size_t(in.fine)] = 1;  // kept from an uncut model (sim/coarse_cut.cpp)
  for (const auto& bn : boundary_) b.recorded[std::size_t(bn.fine)] = 1;
  elements_.resize(elementCount);
  for (std::size_t e = 0; e < elementCount; ++e) {
    if (only && !(*only)[e]) continue;
    if (e % 256 == 0) reportProgress(progress, double(e) / double(elementCount), "coarsening");
    Element& el = elements_[e];
    if (kind_ == CoarseElement::Tet)
      for (int c = 0; c < 4; ++c) el.node[std::size_t(c)] = meshes_.coarse.tets[e][std::size_t(c)];
    else if (graded_)
      el.node = leaves_[e].node;
    else if (cut_)
      el.node = cut_->node[e];
    else
      el.node = meshes_.coarseGrid.cellNodes(int(e));
    const std::vector<int> nodes = localNodes(int(e), el, b);
    if (std::all_of(nodes.begin(), nodes.end(), [&](int f) { return f < 0 || constraints_.fixed[std::size_t(f)] != 0; })) {
      // Held whole (outside a shaped region): no energy, its fine nodes at rest.
      el.Kh = Mat::Zero(3 * nc_, 3 * nc_);
      finishElement(el);
      continue;
    }
    ElementSystem sys = elementSystem(int(e), el, nodes, b);
    condenseInterior(int(e), sys);
    condenseBlocks(sys, el);
    finishElement(el);
    el.slides = sys.slides;
    recordReconstruction(int(e), sys, b);
  }
}

// Element e's fine nodes, corners first, and b.local mapping them to their local indices. A cut's
// virtual corner has no fine node: a placeholder -1 - c, without stiffness, in its place.
std::vector<int> CoarseModel::localNodes(int e, const Element& el, ConformingBuild& b) const {
  b.local.clear();
  std::vector<int> nodes;
  for (int c = 0; c < nc_; ++c) {
    int f = cut_ ? cut_->fine[std::size_t(e)][std::size_t(c)] : nodeFine_[std::size_t(el.node[std::size_t(c)])];
    if (f < 0) f = -1 - c;
    b.local.emplace(f, int(nodes.size()));
    nodes.push_back(f);
  }
  for (int t : b.tetsOf[std::size_t(e)])
    for (int v : meshes_.fine.tets[std::size_t(t)])
      if (b.local.emplace(v, int(nodes.size())).second) nodes.push_back(v);
  return nodes;
}

// The element's roles, stiffness and shape functions before condensation. Sliding interfaces: the
// slide nodes touching tissue here; those on the element's faces are held to the surface exactly
// (roles.S), the others by their springs, each through a Dirichlet ghost node of the handle after
// the fine nodes.
CoarseModel::ElementSystem CoarseModel::elementSystem(int e, const Element& el, const std::vector<int>& nodes, ConformingBuild& b) const {
  const TetMesh& F = meshes_.fine;
  const int nc = nc_, n = int(nodes.size());
  std::array<Eigen::Vector3d, 4> Xt;
  if (kind_ == CoarseElement::Tet) Xt = cornersOf(meshes_.coarse, e, meshes_.coarse.nodes);
  ElementSystem sys;
  sys.nodes = nodes;
  const std::vector<int>& tets = b.tetsOf[std::size_t(e)];
  const std::vector<int> candidates = b.slide.of(nodes, tets, F, b.local, b.touches);
  sys.roles = classifyNodes(e, el, nodes, Xt, b.slide, b.touches);
  ElementNodes& roles = sys.roles;
  std::vector<int> springs;
  for (int s : candidates)
    if (std::find(roles.S.begin(), roles.S.end(), b.local[constraints_.slide[std::size_t(s)].node]) == roles.S.end()) springs.push_back(s);
  const int ng = n + int(springs.size() + roles.S.size());
  sys.K = Mat::Zero(3 * ng, 3 * ng);
  for (int t : tets)
    for (int i = 0; i < 4; ++i)
      for (int j = 0; j < 4; ++j) {
        const int li = b.local[F.tets[std::size_t(t)][std::size_t(i)]], lj = b.local[F.tets[std::size_t(t)][std::size_t(j)]];
        sys.K.block<3, 3>(3 * li, 3 * lj) += b.fineK[std::size_t(t)].block<3, 3>(3 * i, 3 * j);
      }
  for (std::size_t g = 0; g < springs.size(); ++g) addGhost(sys.K, b.local[constraints_.slide[std::size_t(springs[g])].node], n + int(g), b.slide, springs[g], roles);
  sys.slides = !springs.empty() || !roles.S.empty();
  const std::size_t firstSurfaceGhost = roles.D.size();
  for (std::size_t j = 0; j < roles.S.size(); ++j) {
    const SlideNode& sn = constraints_.slide[std::size_t(b.slide.slideOf[std::size_t(nodes[std::size_t(roles.S[j])])])];
    roles.addDirichlet(n + int(springs.size() + j), sn.handle, F.nodes[std::size_t(sn.node)]);
  }
  const int nB = int(roles.B.size()), nD = int(roles.D.size());
  sys.Phic = Mat::Zero(3 * ng, 3 * nc);
  sys.PhiD = Mat::Zero(3 * ng, 3 * nD);
  for (int c = 0; c < nc; ++c) sys.Phic.block<3, 3>(3 * c, 3 * c).setIdentity();
  for (int i = 0; i < nB; ++i)
    for (int c = 0; c < nc; ++c) sys.Phic.block<3, 3>(3 * roles.B[std::size_t(i)], 3 * c) = roles.Bw[std::size_t(i)][c] * Eigen::Matrix3d::Identity();
  for (int i = 0; i < nD; ++i) sys.PhiD.block<3, 3>(3 * roles.D[std::size_t(i)], 3 * i).setIdentity();
  holdSurfaceSlides(roles, nodes, b.slide, firstSurfaceGhost, sys.Phic, sys.PhiD);
  return sys;
}

// The interior nodes condensed: their rows of Phi_c and Phi_D become H = -K_II^{-1} K_I* Phi_c and
// G = -K_II^{-1} K_I* Phi_D (K_I*: the interior rows of K, 3nI x 3n').
void CoarseModel::condenseInterior(int e, ElementSystem& sys) const {
  const std::vector<int>& In = sys.roles.I;
  const int nI = int(In.size()), nD = int(sys.roles.D.size());
  if (nI == 0) return;
  Mat KI(3 * nI, sys.K.cols());
  for (int i = 0; i < nI; ++i) KI.middleRows(3 * Eigen::Index(i), 3) = sys.K.middleRows(3 * In[std::size_t(i)], 3);
  Mat KII(3 * nI, 3 * nI);
  for (int j = 0; j < nI; ++j) KII.middleCols(3 * j, 3) = KI.middleCols(3 * In[std::size_t(j)], 3);
  const Eigen::LDLT<Mat> ldlt(KII);
  if (ldlt.info() != Eigen::Success) throw Error("coarsening: singular interior stiffness in coarse element " + std::to_string(e));
  // (No Dirichlet nodes: PhiD has no columns, and Eigen would offset a null pointer solving for an
  // empty right-hand side.)
  sys.H = -ldlt.solve(KI * sys.Phic);
  sys.G = nD > 0 ? Mat(-ldlt.solve(KI * sys.PhiD)) : Mat(3 * nI, 0);
  for (int i = 0; i < nI; ++i) {
    sys.Phic.middleRows(3 * In[std::size_t(i)], 3) = sys.H.middleRows(3 * i, 3);
    if (nD > 0) sys.PhiD.middleRows(3 * In[std::size_t(i)], 3) = sys.G.middleRows(3 * i, 3);
  }
}

// Kh = Phi_c^T K Phi_c (3nc x 3nc); per handle among the D nodes its blocks of
// K_hd = Phi_c^T K Phi_D (3nc x 3nD); and the handles' own condensed stiffness for their reactions,
// Q = (Phi_D U)^T K (Phi_D U), U (3nD x 12h) each D node's 12 unit motions in its handle's columns
// (el.handles order).
void CoarseModel::condenseBlocks(const ElementSystem& sys, Element& el) const {
  const Mat KPhic = sys.K * sys.Phic;
  el.Kh = sys.Phic.transpose() * KPhic;
  const ElementNodes& roles = sys.roles;
  const int nD = int(roles.D.size());
  if (nD == 0) return;
  const Mat Khd = KPhic.transpose() * sys.PhiD;  // 3nc x 3nD
  for (int i = 0; i < nD; ++i) addHandleBlock(el, roles.Dhandle[std::size_t(i)], roles.DX[std::size_t(i)], Khd.middleCols(3 * i, 3));
  const int h = int(el.handles.size());
  Mat U = Mat::Zero(3 * nD, 12 * h);
  for (int i = 0; i < nD; ++i) {
    const int hd = roles.Dhandle[std::size_t(i)];
    const auto it = std::find_if(el.handles.begin(), el.handles.end(), [&](const HandleBlock& hb) { return hb.handle == hd; });
    U.block<3, 12>(3 * i, 12 * int(it - el.handles.begin())) = unitMotions(roles.DX[std::size_t(i)]);
  }
  const Mat PU = sys.PhiD * U;
  el.Q = PU.transpose() * (sys.K * PU);
  el.Q = 0.5 * (el.Q + el.Q.transpose()).eval();
}

// The fine nodes' reconstruction records: slide nodes on faces (the first element's record) and
// interior nodes from their shape-function rows, face nodes from the corners' weights.
void CoarseModel::recordReconstruction(int e, const ElementSystem& sys, ConformingBuild& b) {
  const ElementNodes& roles = sys.roles;
  const int nD = int(roles.D.size());
  auto record = [&](int f, const Mat& rowsC, const Mat& rowsD, int row) {
    InteriorNode in;
    in.fine = f;
    in.element = e;
    in.H = rowsC.middleRows(3 * row, 3);
    for (int d = 0; d < nD; ++d) addInteriorHandleBlock(in, roles.Dhandle[std::size_t(d)], roles.DX[std::size_t(d)], rowsD.block<3, 3>(3 * row, 3 * d));
    interior_.push_back(std::move(in));
  };
  for (const int l : roles.S) {
    const int f = sys.nodes[std::size_t(l)];
    if (b.recorded[std::size_t(f)]) continue;
    b.recorded[std::size_t(f)] = 1;
    record(f, sys.Phic, sys.PhiD, l);
  }
  for (std::size_t i = 0; i < roles.I.size(); ++i) record(sys.nodes[std::size_t(roles.I[i])], sys.H, sys.G, int(i));
  for (std::size_t i = 0; i < roles.B.size(); ++i) {
    const int f = sys.nodes[std::size_t(roles.B[i])];
    if (b.recorded[std::size_t(f)]) continue;
    b.recorded[std::size_t(f)] = 1;
    boundary_.push_back({f, e, roles.Bw[i]});
  }
}

CoarseModel::ElementNodes CoarseModel::classifyNodes(int e, const Element& el, const std::vector<int>& nodes, const std::array<Eigen::Vector3d, 4>& Xt,
                                                     const SlideShares& slide, const std::vector<char>& touches) const {
  const TetMesh& F = meshes_.fine;
  const auto& handleOf = constraints_.handleOf;
  const int nc = nc_, n = int(nodes.size());
  ElementNodes r;
  const double scale = (nodes_[std::size_t(el.node[1])] - nodes_[std::size_t(el.node[0])]).norm();
  for (int l = nc; l < n; ++l) {
    const int f = nodes[std::size_t(l)];
    const bool held = constraints_.fixed[std::size_t(f)] != 0;
    if (!held && handleOf[std::size_t(f)] >= 0) {
      r.addDirichlet(l, handleOf[std::size_t(f)], F.nodes[std::size_t(f)]);
      continue;
    }
    if (slide.slides(f) && !touches[std::size_t(l)]) {  // only the handle's own tets here: it moves with the handle
      r.addDirichlet(l, constraints_.slide[std::size_t(slide.slideOf[std::size_t(f)])].handle, F.nodes[std::size_t(f)]);
      continue;
    }
    Eigen::Matrix<double, 8, 1> w = Eigen::Matrix<double, 8, 1>::Zero();
    bool onBoundary = false;
    if (kind_ == CoarseElement::Tet) {
      const Eigen::Vector4d lam = barycentric(Xt, F.nodes[std::size_t(f)]);
      onBoundary = lam.minCoeff() < 1e-9 * std::max(1.0, scale);
      w.head<4>() = lam.cwiseMax(0.0) / lam.cwiseMax(0.0).sum();
    } else {
      w = elementWeights(int(e), F.nodes[std::size_t(f)], &onBoundary);
    }
    // A held node (the anchored skeleton) is Dirichlet at rest - the anchor handle's node, x = X -
    // unless it lies on a face whose weighted corners are all held (the region's fixed faces:
    // N_b x_c is its rest position already).
    if (held && !(onBoundary && onHeldCorners(el, w))) {
      r.addDirichlet(l, anchorHandle(), F.nodes[std::size_t(f)]);
      continue;
    }
    if (onBoundary && slide.heldExactly(f)) {
      r.S.push_back(l);
      r.Sw.push_back(w);
    } else if (onBoundary) {
      r.B.push_back(l);
      r.Bw.push_back(w);
    } else {
      r.I.push_back(l);
    }
  }
  return r;
}

bool CoarseModel::onHeldCorners(const Element& el, const Eigen::Matrix<double, 8, 1>& w) const {
  for (int c = 0; c < nc_; ++c)
    if (const int f = nodeFine_[std::size_t(el.node[std::size_t(c)])]; w[c] > 1e-12 && (f < 0 || !constraints_.fixed[std::size_t(f)])) return false;
  return true;
}


std::vector<RigidTransform> CoarseModel::withAnchor(const std::vector<RigidTransform>& handles) const {
  std::vector<RigidTransform> out(handles.begin(), handles.begin() + std::min<std::ptrdiff_t>(std::ptrdiff_t(handles.size()), anchorHandle()));
  out.resize(std::size_t(anchorHandle()) + 1);  // the anchor: the identity
  return out;
}

void CoarseModel::finishElement(Element& el) const {
  const auto& C = nodes_;
  const int nc = nc_;
  el.Kh = 0.5 * (el.Kh + el.Kh.transpose()).eval();
  VecE Xc(3 * nc);
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  for (int c = 0; c < nc; ++c) {
    Xc.segment<3>(3 * c) = C[std::size_t(el.node[std::size_t(c)])];
    centroid += C[std::size_t(el.node[std::size_t(c)])] / double(nc);
  }
  el.KhX = el.Kh * Xc;
  Eigen::Matrix3d M = Eigen::Matrix3d::Zero();
  for (int c = 0; c < nc; ++c) {
    el.dX[std::size_t(c)] = C[std::size_t(el.node[std::size_t(c)])] - centroid;
    M += el.dX[std::size_t(c)] * el.dX[std::size_t(c)].transpose();
  }
  el.fitInv = M.inverse();
}

void CoarseModel::addHandleBlock(Element& el, int handle, const Eigen::Vector3d& X, const Eigen::Ref<const Eigen::MatrixXd>& blk) const {
  auto it = std::find_if(el.handles.begin(), el.handles.end(), [&](const HandleBlock& b) { return b.handle == handle; });
  if (it == el.handles.end()) {
    HandleBlock hb{handle, {}, {}};
    hb.A.setZero(3 * nc_, 9);
    hb.B.setZero(3 * nc_, 3);
    el.handles.push_back(std::move(hb));
    it = el.handles.end() - 1;
  }
  for (int c = 0; c < 3; ++c) it->A.middleCols(3 * c, 3) += X[c] * blk;
  it->B += blk;
}

void CoarseModel::addInteriorHandleBlock(InteriorNode& in, int handle, const Eigen::Vector3d& X, const Eigen::Matrix3d& blk) {
  auto it = std::find_if(in.g.begin(), in.g.end(), [&](const InteriorNode::G& g) { return g.handle == handle; });
  if (it == in.g.end()) {
    in.g.push_back({handle, Eigen::Matrix<double, 3, 9>::Zero(), Eigen::Matrix3d::Zero()});
    it = in.g.end() - 1;
  }
  for (int c = 0; c < 3; ++c) it->A.middleCols(3 * c, 3) += X[c] * blk;
  it->B += blk;
}

void CoarseModel::buildAssembler() {
  if (dofCount_ <= 0) return;
  std::vector<int> flat;
  flat.reserve(elements_.size() * std::size_t(nc_));
  for (const auto& el : elements_) flat.insert(flat.end(), el.node.begin(), el.node.begin() + nc_);
  assembler_ = std::make_unique<BlockAssembler>(std::move(flat), nc_, dof_, dofCount_);
}

void CoarseModel::save(std::ostream& os) const {
  if (graded_) throw Error("coarsening: graded cells are not cached");
  if (cut_) throw Error("coarsening: a model of a cut mesh is not cached (its cells split where the cut passes)");
  bin::Writer w{os};
  w.pod(std::uint32_t(kind_));
  w.podVector(constraints_.handleOf);
  w.podVector(constraints_.fixed);
  w.pod(std::int32_t(constraints_.handleCount));
  bin::writeSlideNodes(w, constraints_.slide);
  w.pod(std::uint64_t(elements_.size()));
  for (const auto& el : elements_) {
    w.pod(el.node);
    w.matrix(el.Kh);
    w.matrix(el.KhX);
    w.matrix(el.fitInv);
    for (int c = 0; c < nc_; ++c) w.pod(el.dX[std::size_t(c)]);
    w.pod(std::uint32_t(el.handles.size()));
    for (const auto& h : el.handles) {
      w.pod(std::int32_t(h.handle));
      w.matrix(h.A);
      w.matrix(h.B);
    }
    if (!el.handles.empty()) w.matrix(el.Q);
    w.pod(std::uint8_t(el.slides));
  }
  w.pod(std::uint64_t(interior_.size()));
  for (const auto& in : interior_) {
    w.pod(std::int32_t(in.fine));
    w.pod(std::int32_t(in.element));
    w.matrix(in.H);
    w.pod(std::uint32_t(in.g.size()));
    for (const auto& g : in.g) {
      w.pod(std::int32_t(g.handle));
      w.pod(g.A);
      w.pod(g.B);
    }
  }
  w.pod(std::uint64_t(boundary_.size()));
  for (const auto& b : boundary_) {
    w.pod(std::int32_t(b.fine));
    w.pod(std::int32_t(b.element));
    w.pod(b.N);
  }
  w.podVector(coarseRole_);
  w.podVector(dof_);
  w.pod(std::int32_t(dofCount_));
}

std::unique_ptr<CoarseModel> CoarseModel::load(std::istream& is, std::uint64_t bytes, const NestedMeshes& meshes) {
  bin::Reader r{is, bytes};
  const auto kind = r.pod<std::uint32_t>();
  if (kind > std::uint32_t(CoarseElement::Cell)) throw Error("cache file corrupt (element kind)");
  std::unique_ptr<CoarseModel> m(new CoarseModel(meshes, CoarseElement(kind)));
  const int nc = m->nc_;
  const std::size_t nf = meshes.fine.nodes.size(), ncn = meshes.coarse.nodes.size();
  m->constraints_.handleOf = r.podVector<int>();
  m->constraints_.fixed = r.podVector<char>();
  m->constraints_.handleCount = r.pod<std::int32_t>();
  const int hc = m->constraints_.handleCount;
  if (m->constraints_.handleOf.size() != nf || m->constraints_.fixed.size() != nf || hc < 0) throw Error("cache file does not fit the mesh");
  m->constraints_.slide = bin::readSlideNodes(r, m->constraints_.handleOf, m->constraints_.fixed, hc);
  auto checkIndex = [](std::int64_t v, std::size_t n) {
    if (v < 0 || std::uint64_t(v) >= n) throw Error("cache file corrupt (an index out of range)");
  };
  const auto ne = r.pod<std::uint64_t>();
  if (ne != (m->kind_ == CoarseElement::Tet ? meshes.coarse.tets.size() : meshes.coarseGrid.cellCount())) throw Error("cache file does not fit the mesh");
  m->elements_.resize(ne);
  for (auto& el : m->elements_) {
    el.node = r.pod<std::array<int, 8>>();
    for (int c = 0; c < nc; ++c) checkIndex(el.node[std::size_t(c)], ncn);
    r.matrix(el.Kh, 3 * nc, 3 * nc);
    r.matrix(el.KhX, 3 * nc, 1);
    r.matrix(el.fitInv, 3, 3);
    for (int c = 0; c < nc; ++c) el.dX[std::size_t(c)] = r.pod<Eigen::Vector3d>();
    const auto nh = r.pod<std::uint32_t>();
    if (nh > std::uint32_t(hc) + 1) throw Error("cache file corrupt (handle blocks)");
    el.handles.resize(nh);
    for (auto& h : el.handles) {
      h.handle = r.pod<std::int32_t>();
      checkIndex(h.handle, std::size_t(hc) + 1);  // the anchor is handle hc
      r.matrix(h.A, 3 * nc, 9);
      r.matrix(h.B, 3 * nc, 3);
    }
    if (nh > 0) r.matrix(el.Q, 12 * Eigen::Index(nh), 12 * Eigen::Index(nh));
    const auto slides = r.pod<std::uint8_t>();
    if (slides > 1) throw Error("cache file corrupt (sliding flag)");
    el.slides = slides != 0;
  }
  const auto ni = r.pod<std::uint64_t>();
  if (ni > nf) throw Error("cache file corrupt (interior nodes)");
  m->interior_.resize(ni);
  for (auto& in : m->interior_) {
    in.fine = r.pod<std::int32_t>();
    in.element = r.pod<std::int32_t>();
    checkIndex(in.fine, nf);
    checkIndex(in.element, ne);
    r.matrix(in.H, 3, 3 * nc);
    const auto ng = r.pod<std::uint32_t>();
    if (ng > std::uint32_t(hc) + 1) throw Error("cache file corrupt (handle blocks)");
    in.g.resize(ng);
    for (auto& g : in.g) {
      g.handle = r.pod<std::int32_t>();
      checkIndex(g.handle, std::size_t(hc) + 1);  // the anchor is handle hc
      g.A = r.pod<Eigen::Matrix<double, 3, 9>>();
      g.B = r.pod<Eigen::Matrix3d>();
    }
  }
  const auto nb = r.pod<std::uint64_t>();
  if (nb > nf) throw Error("cache file corrupt (boundary nodes)");
  m->boundary_.resize(nb);
  for (auto& b : m->boundary_) {
    b.fine = r.pod<std::int32_t>();
    b.element = r.pod<std::int32_t>();
    checkIndex(b.fine, nf);
    checkIndex(b.element, ne);
    b.N = r.pod<Eigen::Matrix<double, 8, 1>>();
  }
  m->coarseRole_ = r.podVector<int>();
  m->dof_ = r.podVector<int>();
  m->dofCount_ = r.pod<std::int32_t>();
  if (m->coarseRole_.size() != ncn || m->dof_.size() != ncn || m->dofCount_ < 0 || m->dofCount_ > 3 * int(ncn)) throw Error("cache file does not fit the mesh");
  if (m->dofCount_ % 3 != 0) throw Error("cache file corrupt (dofs)");
  for (std::size_t v = 0; v < ncn; ++v) {
    const int d = m->dof_[v], role = m->coarseRole_[v];
    if (role < -2 || role >= hc || (role == -1) != (d >= 0) || (d >= 0 && (d % 3 != 0 || d + 2 >= m->dofCount_))) throw Error("cache file corrupt (dofs)");
  }
  for (int h : m->constraints_.handleOf)
    if (h < -1 || h >= hc) throw Error("cache file corrupt (handle roles)");
  m->buildAssembler();
  m->handleRestCentroid_ = handleRestCentroids(meshes.fine, m->constraints_);
  return m;
}

std::vector<Eigen::Matrix3d> CoarseModel::elementRotations(const std::vector<Eigen::Vector3d>& x) const {
  std::vector<Eigen::Matrix3d> R(elements_.size());
  for (std::size_t e = 0; e < R.size(); ++e) R[e] = elementRotation(int(e), x);
  return R;
}

FineInterpolationData CoarseModel::interpolationData() const {
  const TetMesh& F = meshes_.fine;
  FineInterpolationData d;
  d.handleCount = std::uint32_t(constraints_.handleCount);
  d.node.assign(F.nodes.size(), {FineInterpolationData::Rest, 0, 0, 0});
  d.rest.reserve(F.nodes.size());
  for (const auto& X : F.nodes) d.rest.emplace_back(float(X.x()), float(X.y()), float(X.z()), 1.0f);
  for (const auto& X : nodes_) d.coarseRest.emplace_back(float(X.x()), float(X.y()), float(X.z()), 1.0f);
  d.cornersPerElement = std::uint32_t(nc_);
  for (const auto& el : elements_)
    for (int h = 0; h < 2; ++h) {
      std::array<std::uint32_t, 4> q{};
      for (int c = 0; c < 4; ++c) q[std::size_t(c)] = 4 * h + c < nc_ ? std::uint32_t(el.node[std::size_t(4 * h + c)]) : 0u;
      d.elementCorners.push_back(q);
    }
  // Same precedence as reconstruct(): handle, then corner, boundary, interior records overwrite.
  for (std::size_t f = 0; f < F.nodes.size(); ++f)
    if (constraints_.handleOf[f] >= 0) d.node[f] = {FineInterpolationData::Handle, std::uint32_t(constraints_.handleOf[f]), 0, 0};
  for (std::size_t v = 0; v < nodes_.size(); ++v)
    if (nodeFine_[v] >= 0) d.node[std::size_t(nodeFine_[v])] = {FineInterpolationData::Corner, std::uint32_t(v), 0, 0};
  auto push3 = [&](const Eigen::Matrix3d& m) {
    for (int c = 0; c < 3; ++c) d.blocks.emplace_back(float(m(0, c)), float(m(1, c)), float(m(2, c)), 0.0f);
  };
  for (const auto& b : boundary_) {
    d.node[std::size_t(b.fine)] = {FineInterpolationData::Boundary, std::uint32_t(b.element), std::uint32_t(d.blocks.size()), 0};
    d.blocks.push_back(b.N.head<4>().cast<float>());
    if (nc_ == 8) d.blocks.push_back(b.N.tail<4>().cast<float>());
  }
  for (const auto& in : interior_) {
    d.node[std::size_t(in.fine)] = {FineInterpolationData::Interior, std::uint32_t(in.element), std::uint32_t(d.blocks.size()),
                                    std::uint32_t(in.g.size())};
    for (int c = 0; c < nc_; ++c) push3(in.H.block<3, 3>(0, 3 * c));
    for (const auto& g : in.g) {
      d.blocks.emplace_back(g.handle == anchorHandle() ? -1.0f : float(g.handle), 0.0f, 0.0f, 0.0f);  // -1: the anchor (identity)
      for (int j = 0; j < 3; ++j) push3(g.A.block<3, 3>(0, 3 * j));
      push3(g.B);
    }
  }
  if (d.blocks.size() > std::size_t(UINT32_MAX)) throw Error("deformation: the reconstruction data is too large");
  return d;
}

Eigen::Matrix3d CoarseModel::elementRotation(int e, const std::vector<Eigen::Vector3d>& x) const {
  const Element& el = elements_[std::size_t(e)];
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  for (int c = 0; c < nc_; ++c) centroid += x[std::size_t(el.node[std::size_t(c)])];
  centroid /= double(nc_);
  // The least-squares affine fit of the corners: F = (sum dx dX^T) (sum dX dX^T)^-1.
  Eigen::Matrix3d S = Eigen::Matrix3d::Zero();
  for (int c = 0; c < nc_; ++c) S.noalias() += (x[std::size_t(el.node[std::size_t(c)])] - centroid) * el.dX[std::size_t(c)].transpose();
  return polarRotation(S * el.fitInv);
}

CoarseModel::VecE CoarseModel::handleTerm(const Element& el, const Eigen::Matrix3d& Rc, const std::vector<RigidTransform>& handles) const {
  VecE h = VecE::Zero(3 * nc_);
  for (const auto& b : el.handles) {
    const RigidTransform& T = handles[std::size_t(b.handle)];
    h.noalias() += b.A * unroll(Rc.transpose() * T.R - Eigen::Matrix3d::Identity());
    h.noalias() += b.B * (Rc.transpose() * T.t);
  }
  return h;
}

double CoarseModel::pinDirichlet(const std::vector<RigidTransform>& handles, std::vector<Eigen::Vector3d>& x, double tolerance) const {
  const auto& C = nodes_;
  if (int(handles.size()) < constraints_.handleCount) throw Error("coarse solve: a transform per handle expected");
  if (x.size() != C.size()) x = C;
  for (const auto& T : handles)
    if (!T.R.allFinite() || !T.t.allFinite()) throw Error("coarse solve: a handle transform is not finite");
  // Dirichlet coarse nodes take their positions; the motion scale sets the tolerance.
  double motion = 0.0;
  for (std::size_t v = 0; v < C.size(); ++v) {
    if (coarseRole_[v] == -2) x[v] = C[v];
    else if (coarseRole_[v] >= 0) x[v] = handles[std::size_t(coarseRole_[v])].apply(C[v]);
  }
  expandHanging(x);
  // The motion scale: the handles' coarse nodes' displacements and their translations.
  for (std::size_t v = 0; v < C.size(); ++v)
    if (coarseRole_[v] >= 0) motion = std::max(motion, (x[v] - C[v]).norm());
  for (const auto& T : handles) motion = std::max(motion, T.t.norm());
  return tolerance * std::max(motion, 1e-3);  // a micron at least: zero motion converges too
}

CoarseSolveStats CoarseModel::solve(const std::vector<RigidTransform>& given, std::vector<Eigen::Vector3d>& x, int maxIterations, double tolerance) {
  const auto start = std::chrono::steady_clock::now();
  const SingleThreadedBlas blas;  // small triangular solves (sim/blas_threads.h)
  const double tol = pinDirichlet(given, x, tolerance);
  const std::vector<RigidTransform> handles = withAnchor(given);
  CoarseSolveStats st;
  if (dofCount_ == 0) st.converged = true;
  else if (solverKind_ == CoarseSolver::Pcg) st = solvePcg(handles, x, maxIterations, tol);
  else st = solveAssembled(handles, x, maxIterations, tol);
  st.solveMs = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  return st;
}

CoarseSolveStats CoarseModel::solveAssembled(const std::vector<RigidTransform>& handles, std::vector<Eigen::Vector3d>& x, int maxIterations, double tol) {
  if (graded_) throw Error("coarse solve: the assembled solver takes the uniform grid only (use pcg with graded cells)");
  using Clock = std::chrono::steady_clock;
  auto ms = [](Clock::time_point t0) { return std::chrono::duration<double, std::milli>(Clock::now() - t0).count(); };
  CoarseSolveStats st;
  ++callsSinceFactorization_;
  Eigen::VectorXd rhs(dofCount_);
  double update0 = 0.0, prevUpdate = std::numeric_limits<double>::infinity();  // the last two updates
  double relax = 1.0;
  std::vector<Eigen::Matrix3d> rotations(elements_.size());
  for (int it = 0; it < maxIterations; ++it) {
    auto t0 = Clock::now();
    for (std::size_t e = 0; e < elements_.size(); ++e) rotations[e] = elementRotation(int(e), x);
    st.rotationMs += ms(t0);
    t0 = Clock::now();
    const double boundaryBefore = st.boundaryMs;
    assembler_->zero();
    rhs.setZero();
    const int nc = nc_;
    MatE Ae(3 * nc, 3 * nc);
    VecE be(3 * nc);
    for (std::size_t e = 0; e < elements_.size(); ++e) {
      const Element& el = elements_[e];
      const Eigen::Matrix3d& Rc = rotations[e];
      // R K_h R^T block by block (3x3 products instead of two full ones).
      for (int a = 0; a < nc; ++a)
        for (int b = 0; b < nc; ++b) Ae.block<3, 3>(3 * a, 3 * b).noalias() = Rc * el.Kh.block<3, 3>(3 * a, 3 * b) * Rc.transpose();
      VecE local = el.KhX;
      if (!el.handles.empty()) {
        const auto b0 = Clock::now();
        local -= handleTerm(el, Rc, handles);
        st.boundaryMs += std::chrono::duration<double, std::milli>(Clock::now() - b0).count();
      }
      for (int a = 0; a < nc; ++a) be.segment<3>(3 * a).noalias() = Rc * local.segment<3>(3 * a);
      assembler_->add(int(e), Ae);
      // Dirichlet corners move to the right-hand side.
      for (int a = 0; a < nc; ++a) {
        const int da = dof_[std::size_t(el.node[std::size_t(a)])];
        if (da < 0) continue;
        Eigen::Vector3d r = be.segment<3>(3 * a);
        for (int b = 0; b < nc; ++b) {
          const int v = el.node[std::size_t(b)];
          if (dof_[std::size_t(v)] < 0) r -= Ae.block<3, 3>(3 * a, 3 * b) * x[std::size_t(v)];
        }
        rhs.segment<3>(da) += r;
      }
    }
    st.productMs += ms(t0) - (st.boundaryMs - boundaryBefore);
    // x += A_f^-1 (b - A(R) x) with A_f the last factorized matrix: refactorized every third call
    // (frame) and whenever the updates stop halving; otherwise only back-solves (the factorization
    // is the frame's main cost on larger coarse meshes). The fixed point is the same.
    if (!factorized_ || (it == 0 && callsSinceFactorization_ >= 3) || (it > 0 && update0 > 0.5 * prevUpdate)) {
      callsSinceFactorization_ = 0;
      t0 = Clock::now();
      if (!factorize(assembler_->matrix())) throw Error("coarse solve: the coarse stiffness is not positive definite");
      st.factorMs += ms(t0);
      factorized_ = true;
      ++st.factorizations;
    }
    t0 = Clock::now();
    Eigen::VectorXd xf(dofCount_);
    for (std::size_t v = 0; v < nodes_.size(); ++v)  // a cut's copies after the mesh's nodes
      if (dof_[v] >= 0) xf.segment<3>(dof_[v]) = x[v];
    const Eigen::VectorXd r = rhs - assembler_->matrix().selfadjointView<Eigen::Lower>() * xf;
    st.productMs += ms(t0);
    t0 = Clock::now();
    const Eigen::VectorXd dx = backSolve(r);
    st.backSolveMs += ms(t0);
    if (!dx.allFinite()) throw Error("coarse solve: diverged (non-finite update)");  // std::max would hide a NaN
    double update = 0.0;
    for (std::size_t v = 0; v < nodes_.size(); ++v)
      if (dof_[v] >= 0) {
        x[v] += relax * dx.segment<3>(dof_[v]);
        update = std::max(update, relax * dx.segment<3>(dof_[v]).norm());
      }
    if (!std::isfinite(update)) throw Error("coarse solve: diverged (non-finite positions)");
    st.iterations = it + 1;
    st.lastUpdate = update;
    // Damping: an update that does not shrink (elements flipping between two states) halves the
    // step of the following iterations.
    if (it > 0 && update > 0.9 * update0) relax = std::max(relax * 0.5, 1.0 / 64.0);
    prevUpdate = update0;
    update0 = update;
    if (update <= tol) {
      st.converged = true;
      break;
    }
  }
  return st;
}

CoarseModel::CoarseModel(const NestedMeshes& meshes, CoarseElement kind)
    : meshes_(meshes), nodes_(meshes.coarse.nodes), nodeFine_(meshes.coarseNodeInFine), kind_(kind), nc_(kind == CoarseElement::Tet ? 4 : 8) {}

std::vector<Eigen::Vector3d> CoarseModel::reconstruct(const std::vector<RigidTransform>& given, const std::vector<Eigen::Vector3d>& x) const {
  const auto& C = nodes_;
  const TetMesh& F = meshes_.fine;
  if (x.size() != C.size()) throw Error("coarse reconstruction: one position per coarse node expected");
  if (int(given.size()) < constraints_.handleCount) throw Error("coarse reconstruction: a transform per handle expected");
  const std::vector<RigidTransform> handles = withAnchor(given);
  std::vector<Eigen::Vector3d> out = F.nodes;
  for (std::size_t f = 0; f < F.nodes.size(); ++f) {
    const int h = constraints_.handleOf[f];
    if (h >= 0) out[f] = handles[std::size_t(h)].apply(F.nodes[f]);
  }
  for (std::size_t v = 0; v < C.size(); ++v)
    if (nodeFine_[v] >= 0) out[std::size_t(nodeFine_[v])] = x[v];
  for (const auto& b : boundary_) {
    const Element& el = elements_[std::size_t(b.element)];
    Eigen::Vector3d p = Eigen::Vector3d::Zero();
    for (int c = 0; c < nc_; ++c) p += b.N[c] * x[std::size_t(el.node[std::size_t(c)])];
    out[std::size_t(b.fine)] = p;
  }
  const std::vector<Eigen::Matrix3d> R = elementRotations(x);
  VecE local(3 * nc_);
  for (const auto& in : interior_) {
    const Eigen::Matrix3d& Rc = R[std::size_t(in.element)];
    const Element& el = elements_[std::size_t(in.element)];
    for (int c = 0; c < nc_; ++c) {
      const auto v = std::size_t(el.node[std::size_t(c)]);
      local.segment<3>(3 * c) = Rc.transpose() * x[v] - C[v];
    }
    Eigen::Vector3d p = F.nodes[std::size_t(in.fine)] + in.H * local;
    for (const auto& g : in.g) {
      const RigidTransform& T = handles[std::size_t(g.handle)];
      p += g.A * unroll(Rc.transpose() * T.R - Eigen::Matrix3d::Identity()) + g.B * (Rc.transpose() * T.t);
    }
    out[std::size_t(in.fine)] = Rc * p;
  }
  return out;
}

Eigen::VectorXd CoarseModel::restrictToCoarse(const std::vector<Eigen::Vector3d>& r, const std::vector<Eigen::Matrix3d>& R) const {
  Eigen::VectorXd out = Eigen::VectorXd::Zero(dofCount_);
  // A hanging node's share goes to its masters.
  auto add = [&](int coarseNode, const Eigen::Vector3d& v) {
    if (const int d = dof_[std::size_t(coarseNode)]; d >= 0) out.segment<3>(d) += v;
    else if (graded_)
      for (const auto& [m, w] : hang_[std::size_t(coarseNode)])
        if (const int dm = dof_[std::size_t(m)]; dm >= 0) out.segment<3>(dm) += w * v;
  };
  for (std::size_t v = 0; v < nodes_.size(); ++v)
    if (nodeFine_[v] >= 0) add(int(v), r[std::size_t(nodeFine_[v])]);
  for (const auto& b : boundary_) {
    if (constraints_.fixed[std::size_t(b.fine)]) continue;
    for (int c = 0; c < nc_; ++c) add(elementCorner(b.element, c), b.N[c] * r[std::size_t(b.fine)]);
  }
  for (const auto& in : interior_) {
    const Eigen::Matrix3d& Rc = R[std::size_t(in.element)];
    const Eigen::Vector3d rl = Rc.transpose() * r[std::size_t(in.fine)];
    for (int c = 0; c < nc_; ++c) add(elementCorner(in.element, c), Rc * (in.H.middleCols<3>(3 * c).transpose() * rl));
  }
  return out;
}

void CoarseModel::prolongAdd(const Eigen::VectorXd& cv, const std::vector<Eigen::Matrix3d>& R, std::vector<Eigen::Vector3d>& out) const {
  auto val = [&](int coarseNode) -> Eigen::Vector3d {
    if (const int d = dof_[std::size_t(coarseNode)]; d >= 0) return cv.segment<3>(d);
    Eigen::Vector3d v = Eigen::Vector3d::Zero();
    if (graded_)
      for (const auto& [m, w] : hang_[std::size_t(coarseNode)])
        if (const int dm = dof_[std::size_t(m)]; dm >= 0) v += w * cv.segment<3>(dm);
    return v;
  };
  for (std::size_t v = 0; v < nodes_.size(); ++v)
    if (nodeFine_[v] >= 0) out[std::size_t(nodeFine_[v])] += val(int(v));
  for (const auto& b : boundary_) {
    if (constraints_.fixed[std::size_t(b.fine)]) continue;
    for (int c = 0; c < nc_; ++c) out[std::size_t(b.fine)] += b.N[c] * val(elementCorner(b.element, c));
  }
  for (const auto& in : interior_) {
    const Eigen::Matrix3d& Rc = R[std::size_t(in.element)];
    Eigen::Vector3d acc = Eigen::Vector3d::Zero();
    for (int c = 0; c < nc_; ++c) acc += in.H.middleCols<3>(3 * c) * (Rc.transpose() * val(elementCorner(in.element, c)));
    out[std::size_t(in.fine)] += Rc * acc;
  }
}

Eigen::VectorXd CoarseModel::coarseSolve(const Eigen::VectorXd& b) const {
  if (dofCount_ == 0) return Eigen::VectorXd::Zero(dofCount_);
  if (solverKind_ == CoarseSolver::Pcg && pcgReady()) {
    Eigen::VectorXd z;
    pcgPrecondition(b, z);
    return z;
  }
  if (!analyzed_) return Eigen::VectorXd::Zero(dofCount_);
  return backSolve(b);
}

bool CoarseModel::factorize(const SparseMatrix& A) {
  if (!analyzed_) {
    solver_.analyzePattern(A);
    analyzed_ = true;
  }
  solver_.factorize(A);
  return solver_.info() == Eigen::Success;
}

Eigen::VectorXd CoarseModel::backSolve(const Eigen::VectorXd& b) const { return solver_.solve(b); }

std::vector<Eigen::Vector3d> prescribedPositions(const TetMesh& fine, const FineConstraints& c, const std::vector<RigidTransform>& handles, std::vector<char>* dirichlet) {
  std::vector<Eigen::Vector3d> x = fine.nodes;
  if (dirichlet) dirichlet->assign(fine.nodes.size(), 0);
  for (std::size_t i = 0; i < fine.nodes.size(); ++i) {
    if (c.fixed[i]) {
      if (dirichlet) (*dirichlet)[i] = 1;
    } else if (c.handleOf[i] >= 0) {
      x[i] = handles[std::size_t(c.handleOf[i])].apply(fine.nodes[i]);
      if (dirichlet) (*dirichlet)[i] = 1;
    }
  }
  return x;
}

std::vector<Eigen::Vector3d> plainCoarseSolve(const NestedMeshes& meshes, const std::vector<double>& fineYoungs, const std::vector<double>& finePoisson,
                                              const FineConstraints& cons, const std::vector<RigidTransform>& handles) {
  const TetMesh& C = meshes.coarse;
  const TetMesh& F = meshes.fine;
  std::vector<double> E(C.tets.size(), 0.0), nu(C.tets.size(), 0.0), vol(C.tets.size(), 0.0);
  for (std::size_t t = 0; t < F.tets.size(); ++t) {
    const double v = std::abs(F.signedVolume(int(t)));
    const auto p = std::size_t(meshes.fineParent[t]);
    E[p] += v * fineYoungs[t];
    nu[p] += v * finePoisson[t];
    vol[p] += v;
  }
  for (std::size_t e = 0; e < E.size(); ++e) {
    E[e] /= vol[e];
    nu[e] /= vol[e];
  }
  FineConstraints cc;
  cc.handleOf.assign(C.nodes.size(), -1);
  cc.fixed.assign(C.nodes.size(), 0);
  cc.handleCount = cons.handleCount;
  for (std::size_t v = 0; v < C.nodes.size(); ++v) {
    const auto f = std::size_t(meshes.coarseNodeInFine[v]);
    cc.fixed[v] = cons.fixed[f];
    cc.handleOf[v] = cons.fixed[f] ? -1 : cons.handleOf[f];
  }
  std::vector<char> dir;
  const auto x0 = prescribedPositions(C, cc, handles, &dir);
  const auto res = solveStatic(C, tetStiffnesses(C, E, nu), dir, x0);
  std::vector<Eigen::Vector3d> out(F.nodes.size());
  for (std::size_t f = 0; f < F.nodes.size(); ++f) {
    Eigen::Vector4d lam;
    const int t = meshes.coarseGrid.locate(F.nodes[f], &lam);
    Eigen::Vector3d p = Eigen::Vector3d::Zero();
    for (int c = 0; c < 4; ++c) p += lam[c] * res.x[std::size_t(C.tets[std::size_t(t)][std::size_t(c)])];
    out[f] = p;
  }
  return out;
}

}  // namespace handson
