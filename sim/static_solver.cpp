#include "static_solver.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <string>

#include "sim/base/error.h"

namespace handson {

namespace {
std::array<Eigen::Vector3d, 4> corners(const TetMesh& m, int t, const std::vector<Eigen::Vector3d>& x) { return tetCorners(m.tets[std::size_t(t)], x); }
}  // namespace

double elasticEnergy(const TetMesh& mesh, const std::vector<Mat12>& K, const std::vector<Eigen::Vector3d>& x) {
  double e = 0.0;
  for (std::size_t t = 0; t < mesh.tets.size(); ++t) {
    double et = 0.0;
    corotationalForce(K[t], corners(mesh, int(t), mesh.nodes), corners(mesh, int(t), x), &et);
    e += et;
  }
  return e;
}

int countInvertedTets(const TetMesh& mesh, const std::vector<Eigen::Vector3d>& x) {
  int n = 0;
  for (std::size_t t = 0; t < mesh.tets.size(); ++t)
    if (deformationGradient(corners(mesh, int(t), mesh.nodes), corners(mesh, int(t), x)).determinant() <= 0) ++n;
  return n;
}

namespace {
std::vector<int> flatten(const std::vector<std::array<int, 4>>& tets) {
  std::vector<int> out;
  out.reserve(tets.size() * 4);
  for (const auto& t : tets) out.insert(out.end(), t.begin(), t.end());
  return out;
}
}  // namespace

BlockAssembler::BlockAssembler(const std::vector<std::array<int, 4>>& tets, const std::vector<int>& dof, int dofCount)
    : BlockAssembler(flatten(tets), 4, dof, dofCount) {}

BlockAssembler::BlockAssembler(std::vector<int> elementNodes, int nodesPerElement, const std::vector<int>& dof, int dofCount)
    : nodes_(std::move(elementNodes)), n_(nodesPerElement), dof_(dof) {
  if (n_ < 1 || nodes_.size() % std::size_t(n_) != 0) throw Error("assembly: element node lists do not match the node count");
  const std::size_t elements = nodes_.size() / std::size_t(n_);
  const int n = n_;
  std::vector<Eigen::Triplet<double, int>> trip;
  trip.reserve(elements * std::size_t(n * (n + 1) / 2) * 6);
  for (std::size_t e = 0; e < elements; ++e)
    for (int a = 0; a < n; ++a)
      for (int b = 0; b < n; ++b) {
        const int ra = dof[std::size_t(nodes_[e * std::size_t(n) + std::size_t(a)])], cb = dof[std::size_t(nodes_[e * std::size_t(n) + std::size_t(b)])];
        if (ra < 0 || cb < 0 || ra < cb) continue;
        for (int c = 0; c < 3; ++c)
          for (int r = 0; r < 3; ++r)
            if (ra + r >= cb + c) trip.emplace_back(ra + r, cb + c, 0.0);
      }
  A_.resize(dofCount, dofCount);
  A_.setFromTriplets(trip.begin(), trip.end());
  A_.makeCompressed();
  // Value index of (row, col), found once per element block column.
  auto find = [&](int row, int col) {
    const int* inner = A_.innerIndexPtr();
    const int* b = inner + A_.outerIndexPtr()[col];
    const int* e = inner + A_.outerIndexPtr()[col + 1];
    const int* p = std::lower_bound(b, e, row);
    return int(p - inner);
  };
  const std::size_t per = std::size_t(3 * n * n);
  slot_.assign(elements * per, -1);
  for (std::size_t e = 0; e < elements; ++e)
    for (int a = 0; a < n; ++a)
      for (int b = 0; b < n; ++b) {
        const int ra = dof[std::size_t(nodes_[e * std::size_t(n) + std::size_t(a)])], cb = dof[std::size_t(nodes_[e * std::size_t(n) + std::size_t(b)])];
        if (ra < 0 || cb < 0 || ra < cb) continue;
        for (int c = 0; c < 3; ++c) slot_[e * per + std::size_t(a * n + b) * 3 + std::size_t(c)] = find(std::max(ra, cb + c), cb + c);
      }
}

void BlockAssembler::zero() { std::fill(A_.valuePtr(), A_.valuePtr() + A_.nonZeros(), 0.0); }

std::vector<Mat12> tetStiffnesses(const TetMesh& mesh, const std::vector<double>& youngs, const std::vector<double>& poisson) {
  if (youngs.size() != mesh.tets.size() || poisson.size() != mesh.tets.size()) throw Error("stiffness: one material per tet expected");
  std::vector<Mat12> K(mesh.tets.size());
  for (std::size_t t = 0; t < K.size(); ++t) K[t] = tetStiffness(corners(mesh, int(t), mesh.nodes), youngs[t], poisson[t]);
  return K;
}

std::vector<Eigen::Vector3d> internalForces(const TetMesh& mesh, const std::vector<Mat12>& K, const std::vector<Eigen::Vector3d>& x) {
  std::vector<Eigen::Vector3d> f(mesh.nodes.size(), Eigen::Vector3d::Zero());
  for (std::size_t t = 0; t < mesh.tets.size(); ++t) {
    const Vec12 fe = corotationalForce(K[t], corners(mesh, int(t), mesh.nodes), corners(mesh, int(t), x));
    for (int i = 0; i < 4; ++i) f[std::size_t(mesh.tets[t][std::size_t(i)])] += fe.segment<3>(3 * i);
  }
  return f;
}

FreeDofs freeDofs(const TetMesh& mesh, const std::vector<char>& fixed, const std::vector<Eigen::Vector3d>& x0, const std::vector<NormalSpring>& springs,
                  const char* solve) {
  const std::size_t n = mesh.nodes.size();
  FreeDofs f;
  f.dof.assign(n, -1);
  for (std::size_t i = 0; i < n; ++i) {
    if (!x0[i].allFinite()) throw Error(std::string(solve) + ": a prescribed or initial position is not finite");
    if (fixed[i]) f.motion = std::max(f.motion, (x0[i] - mesh.nodes[i]).norm());
    else f.dof[i] = (f.count += 3) - 3;
  }
  for (const NormalSpring& s : springs) {
    if (s.node < 0 || std::size_t(s.node) >= n || fixed[std::size_t(s.node)]) throw Error(std::string(solve) + ": a spring on a fixed node or outside the mesh");
    f.motion = std::max(f.motion, (s.anchor - mesh.nodes[std::size_t(s.node)]).norm());
  }
  return f;
}

BlockAssembler tetAndSpringAssembler(const TetMesh& mesh, const std::vector<NormalSpring>& springs, const FreeDofs& free) {
  std::vector<int> elementNodes;
  elementNodes.reserve(4 * (mesh.tets.size() + springs.size()));
  for (const auto& t : mesh.tets) elementNodes.insert(elementNodes.end(), t.begin(), t.end());
  for (const NormalSpring& s : springs) elementNodes.insert(elementNodes.end(), 4, s.node);
  return BlockAssembler(std::move(elementNodes), 4, free.dof, free.count);
}

void addSpringBlocks(BlockAssembler& assembler, const TetMesh& mesh, const std::vector<NormalSpring>& springs) {
  const int first = int(mesh.tets.size());
  for (std::size_t k = 0; k < springs.size(); ++k) {
    Mat12 blk = Mat12::Zero();
    blk.topLeftCorner<3, 3>() = springs[k].stiffness * springs[k].normal * springs[k].normal.transpose();
    assembler.add(first + int(k), blk);
  }
}

namespace {

// The fixed inputs of one static solve, shared by its iterations' parts.
struct StaticProblem {
  const TetMesh& mesh;
  const std::vector<Mat12>& K;  ///< rest stiffness per tet
  const StaticSolveOptions& opt;
  const FreeDofs& free;
  double energy(const std::vector<Eigen::Vector3d>& x) const { return elasticEnergy(mesh, K, x) + springEnergy(opt.springs, x); }
};

// The corotational forces at x into rhs (3 per free dof: -grad E) and, with `stiffness`, each tet's
// warped stiffness (or its Newton Hessian, projected when `project`) into it.
void addTetForces(const StaticProblem& p, const std::vector<Eigen::Vector3d>& x, Eigen::VectorXd& rhs, BlockAssembler* stiffness, bool project) {
  const TetMesh& mesh = p.mesh;
  for (std::size_t t = 0; t < mesh.tets.size(); ++t) {
    const auto X = corners(mesh, int(t), mesh.nodes), xt = corners(mesh, int(t), x);
    const Eigen::Matrix3d Rt = polarRotation(deformationGradient(X, xt));
    Vec12 local;
    for (int i = 0; i < 4; ++i) local.segment<3>(3 * i) = Rt.transpose() * xt[std::size_t(i)] - X[std::size_t(i)];
    const Vec12 kl = p.K[t] * local;
    for (int i = 0; i < 4; ++i) {
      const int d = p.free.dof[std::size_t(mesh.tets[t][std::size_t(i)])];
      if (d >= 0) rhs.segment<3>(d) -= Rt * kl.segment<3>(3 * i);
    }
    if (!stiffness) continue;
    if (p.opt.newton) {
      stiffness->add(int(t), corotationalHessian(p.K[t], X, xt, project));
    } else {
      const Mat12 B = blockRotation(Rt);
      stiffness->add(int(t), B * p.K[t] * B.transpose());
    }
  }
}

// The springs' forces at x into rhs; `scratch` (one vector per node, zero on return) sums a node's
// springs so a node with two is added once.
void addSpringForcesTo(const StaticProblem& p, const std::vector<Eigen::Vector3d>& x, Eigen::VectorXd& rhs, std::vector<Eigen::Vector3d>& scratch) {
  if (p.opt.springs.empty()) return;
  std::fill(scratch.begin(), scratch.end(), Eigen::Vector3d::Zero());
  addSpringForces(p.opt.springs, x, scratch);
  for (const NormalSpring& s : p.opt.springs) {
    rhs.segment<3>(p.free.dof[std::size_t(s.node)]) += scratch[std::size_t(s.node)];
    scratch[std::size_t(s.node)].setZero();
  }
}

// Factorizes the assembled stiffness (springs added); a Newton Hessian that is not positive definite
// is reassembled with every tet's Hessian projected and factorized again. Throws when that fails too.
void factorize(const StaticProblem& p, const std::vector<Eigen::Vector3d>& x, BlockAssembler& asmb, DirectSolver& solver, bool& analyzed) {
  addSpringBlocks(asmb, p.mesh, p.opt.springs);
  if (!analyzed) {
    solver.analyzePattern(asmb.matrix());
    analyzed = true;
  }
  solver.factorize(asmb.matrix());
  if (solver.info() != Eigen::Success && p.opt.newton) {
    asmb.zero();
    for (std::size_t t = 0; t < p.mesh.tets.size(); ++t) asmb.add(int(t), corotationalHessian(p.K[t], corners(p.mesh, int(t), p.mesh.nodes), corners(p.mesh, int(t), x), true));
    addSpringBlocks(asmb, p.mesh, p.opt.springs);
    solver.factorize(asmb.matrix());
  }
  if (solver.info() != Eigen::Success) throw Error("static solve: the stiffness matrix is not positive definite (a free part of the mesh with no Dirichlet node, or degenerate elements)");
}

// Backtracking on the energy along dx from x (a descent direction: dx = K(R)^-1 f with K(R)
// positive definite and f = rhs = -grad E), so elements flipping in and out of inversion cannot make
// the iteration cycle. Returns the accepted positions.
std::vector<Eigen::Vector3d> lineSearch(const StaticProblem& p, const std::vector<Eigen::Vector3d>& x, const Eigen::VectorXd& dx, const Eigen::VectorXd& rhs) {
  const double e0 = p.energy(x);
  const double slope = -rhs.dot(dx);  // directional derivative of E along dx
  double alpha = 1.0;
  std::vector<Eigen::Vector3d> trial = x;
  for (int ls = 0; ls < 12; ++ls, alpha *= 0.5) {
    for (std::size_t i = 0; i < x.size(); ++i)
      if (const int d = p.free.dof[i]; d >= 0) trial[i] = x[i] + alpha * dx.segment<3>(d);
    if (p.energy(trial) <= e0 + 1e-4 * alpha * slope) break;
  }
  return trial;
}

}  // namespace

StaticSolveResult solveStatic(const TetMesh& mesh, const std::vector<Mat12>& K, const std::vector<char>& fixed,
                              const std::vector<Eigen::Vector3d>& x0, const StaticSolveOptions& opt) {
  const std::size_t n = mesh.nodes.size();
  if (K.size() != mesh.tets.size() || fixed.size() != n || x0.size() != n) throw Error("static solve: inconsistent sizes");
  if (std::none_of(fixed.begin(), fixed.end(), [](char c) { return c != 0; })) throw Error("static solve: no Dirichlet nodes, the system is singular");
  const FreeDofs free = freeDofs(mesh, fixed, x0, opt.springs, "static solve");
  StaticSolveResult res;
  res.x = x0;
  if (free.count == 0) {
    res.converged = true;
    return res;
  }
  const StaticProblem problem{mesh, K, opt, free};
  const double tol = opt.tolerance * std::max(free.motion, 1e-9);
  BlockAssembler asmb = tetAndSpringAssembler(mesh, opt.springs, free);
  DirectSolver solver;
  solver.cholmod().print = 0;  // an indefinite Hessian is expected (then projected), not an error to print
  bool analyzed = false, refactor = true;
  double prevUpdate = std::numeric_limits<double>::infinity();
  Eigen::VectorXd rhs(free.count);
  std::vector<Eigen::Vector3d> springForce(n);
  for (int it = 0; it < opt.maxIterations; ++it) {
    // Forces (and, when refactorizing, the warped stiffness: the exact Hessian first) at x.
    rhs.setZero();
    if (refactor) asmb.zero();
    addTetForces(problem, res.x, rhs, refactor ? &asmb : nullptr, false);
    addSpringForcesTo(problem, res.x, rhs, springForce);
    if (refactor) {
      factorize(problem, res.x, asmb, solver, analyzed);
      ++res.factorizations;
    }
    std::vector<Eigen::Vector3d> next = lineSearch(problem, res.x, solver.solve(rhs), rhs);
    const double update = free.largestUpdate(next, res.x);
    res.x.swap(next);
    if (!std::isfinite(update)) throw Error("static solve: diverged (non-finite update)");
    res.iterations = it + 1;
    res.lastUpdate = update;
    reportProgress(opt.progress, std::min(1.0, double(it + 1) / 20.0), "fine static solve");
    if (update <= tol) {
      res.converged = true;
      break;
    }
    // Keep the factorization while the updates shrink by more than 4x per iteration.
    refactor = opt.newton || it < 2 || update > 0.25 * prevUpdate;
    prevUpdate = update;
  }
  res.invertedTets = countInvertedTets(mesh, res.x);
  return res;
}

}  // namespace handson
