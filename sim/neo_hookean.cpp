#include "sim/neo_hookean.h"

#include <Eigen/Dense>
#include <cmath>

#include "sim/base/error.h"

namespace handson {

namespace {

Eigen::Matrix3d edges(const std::array<Eigen::Vector3d, 4>& x) {
  Eigen::Matrix3d D;
  D << x[1] - x[0], x[2] - x[0], x[3] - x[0];
  return D;
}

// The shape-function gradient of corner a (3-vector).
Eigen::Vector3d gradient(const Eigen::Matrix3d& G, int a) { return a == 0 ? Eigen::Vector3d(-G.colwise().sum().transpose()) : Eigen::Vector3d(G.row(a - 1).transpose()); }

}  // namespace

NeoHookeanTet neoHookeanTet(const std::array<Eigen::Vector3d, 4>& X, double E, double nu) {
  NeoHookeanTet t;
  const Eigen::Matrix3d Dm = edges(X);
  const double V = std::abs(Dm.determinant()) / 6.0;
  const double scale = (X[1] - X[0]).norm() + (X[2] - X[0]).norm() + (X[3] - X[0]).norm();
  // The same degenerate cases as tetStiffness (no energy).
  if (!(V > 1e-12 * scale * scale * scale) || !std::isfinite(E) || !std::isfinite(nu) || !(E > 0)) return t;
  t.G = Dm.inverse();
  t.V = V;
  t.lambda = E * nu / ((1 + nu) * (1 - 2 * nu));
  t.mu = E / (2 * (1 + nu));
  return t;
}

std::vector<NeoHookeanTet> neoHookeanTets(const TetMesh& mesh, const std::vector<double>& youngs, const std::vector<double>& poisson) {
  if (youngs.size() != mesh.tets.size() || poisson.size() != mesh.tets.size()) throw Error("neo-Hookean: one material per tet expected");
  std::vector<NeoHookeanTet> out(mesh.tets.size());
  for (std::size_t t = 0; t < out.size(); ++t) out[t] = neoHookeanTet(tetCorners(mesh.tets[t], mesh.nodes), youngs[t], poisson[t]);
  return out;
}

double neoHookeanEnergy(const NeoHookeanTet& t, const std::array<Eigen::Vector3d, 4>& x) {
  if (t.V == 0) return 0.0;
  const Eigen::Matrix3d F = edges(x) * t.G;
  const double J = F.determinant();
  if (!(J > 0)) return std::numeric_limits<double>::infinity();
  const double lnJ = std::log(J);
  return t.V * (0.5 * t.mu * (F.squaredNorm() - 3.0) - t.mu * lnJ + 0.5 * t.lambda * lnJ * lnJ);
}

Vec12 neoHookeanForce(const NeoHookeanTet& t, const std::array<Eigen::Vector3d, 4>& x) {
  Vec12 f = Vec12::Zero();
  if (t.V == 0) return f;
  const Eigen::Matrix3d F = edges(x) * t.G;
  const double J = F.determinant();
  const Eigen::Matrix3d Finv = F.inverse();
  const Eigen::Matrix3d P = t.mu * (F - Finv.transpose()) + t.lambda * std::log(J) * Finv.transpose();
  for (int a = 0; a < 4; ++a) f.segment<3>(3 * a) = -t.V * P * gradient(t.G, a);
  return f;
}

Mat12 neoHookeanHessian(const NeoHookeanTet& t, const std::array<Eigen::Vector3d, 4>& x, bool projectSpd) {
  Mat12 H = Mat12::Zero();
  if (t.V == 0) return H;
  const Eigen::Matrix3d F = edges(x) * t.G;
  const double lnJ = std::log(F.determinant());
  const Eigen::Matrix3d Finv = F.inverse(), FinvT = Finv.transpose();
  for (int b = 0; b < 4; ++b) {
    const Eigen::Vector3d gb = gradient(t.G, b);
    for (int c = 0; c < 3; ++c) {
      const Eigen::Matrix3d dF = Eigen::Vector3d::Unit(c) * gb.transpose();
      const Eigen::Matrix3d dP = t.mu * dF + (t.mu - t.lambda * lnJ) * FinvT * dF.transpose() * FinvT + t.lambda * (Finv * dF).trace() * FinvT;
      for (int a = 0; a < 4; ++a) H.block<3, 1>(3 * a, 3 * b + c) = t.V * dP * gradient(t.G, a);
    }
  }
  H = 0.5 * (H + H.transpose()).eval();
  if (projectSpd) {
    Eigen::SelfAdjointEigenSolver<Mat12> es(H);
    H = es.eigenvectors() * es.eigenvalues().cwiseMax(0.0).asDiagonal() * es.eigenvectors().transpose();
  }
  return H;
}

namespace {

double totalEnergy(const TetMesh& mesh, const std::vector<NeoHookeanTet>& tets, const std::vector<NormalSpring>& springs, const std::vector<Eigen::Vector3d>& x) {
  double e = springEnergy(springs, x);
  for (std::size_t t = 0; t < tets.size(); ++t) e += neoHookeanEnergy(tets[t], tetCorners(mesh.tets[t], x));
  return e;
}

}  // namespace

StaticSolveResult solveStaticNeoHookean(const TetMesh& mesh, const std::vector<NeoHookeanTet>& tets, const std::vector<char>& fixed,
                                        const std::vector<Eigen::Vector3d>& x0, const StaticSolveOptions& opt) {
  const std::size_t n = mesh.nodes.size();
  if (tets.size() != mesh.tets.size() || fixed.size() != n || x0.size() != n) throw Error("neo-Hookean solve: inconsistent sizes");
  const FreeDofs free = freeDofs(mesh, fixed, x0, opt.springs, "neo-Hookean solve");
  const std::vector<int>& dof = free.dof;
  const int dofs = free.count;
  StaticSolveResult res;
  res.x = x0;
  if (!std::isfinite(totalEnergy(mesh, tets, opt.springs, res.x))) throw Error("neo-Hookean solve: the start inverts a tet (start from the corotational answer)");
  if (dofs == 0) {
    res.converged = true;
    return res;
  }
  BlockAssembler asmb = tetAndSpringAssembler(mesh, opt.springs, free);
  DirectSolver solver;
  solver.cholmod().print = 0;
  const double tol = opt.tolerance * std::max(free.motion, 1e-9);
  std::vector<Eigen::Vector3d> springForce(n, Eigen::Vector3d::Zero());
  Eigen::VectorXd rhs(dofs);
  for (int it = 0; it < opt.maxIterations; ++it) {
    rhs.setZero();
    asmb.zero();
    for (std::size_t t = 0; t < mesh.tets.size(); ++t) {
      const auto x = tetCorners(mesh.tets[t], res.x);
      const Vec12 f = neoHookeanForce(tets[t], x);
      for (int a = 0; a < 4; ++a)
        if (const int d = dof[std::size_t(mesh.tets[t][std::size_t(a)])]; d >= 0) rhs.segment<3>(d) += f.segment<3>(3 * a);
      asmb.add(int(t), neoHookeanHessian(tets[t], x, true));
    }
    addSpringForces(opt.springs, res.x, springForce);
    for (const NormalSpring& s : opt.springs) {  // a node with two springs: its sum, once
      rhs.segment<3>(dof[std::size_t(s.node)]) += springForce[std::size_t(s.node)];
      springForce[std::size_t(s.node)].setZero();
    }
    addSpringBlocks(asmb, mesh, opt.springs);
    if (it == 0) solver.analyzePattern(asmb.matrix());
    solver.factorize(asmb.matrix());
    if (solver.info() != Eigen::Success) throw Error("neo-Hookean solve: the stiffness matrix is not positive definite (a free part of the mesh with no Dirichlet node)");
    ++res.factorizations;
    const Eigen::VectorXd dx = solver.solve(rhs);
    // Backtracking on the energy (infinite for an inverted tet, so none is ever accepted).
    const double e0 = totalEnergy(mesh, tets, opt.springs, res.x), slope = -rhs.dot(dx);
    std::vector<Eigen::Vector3d> trial = res.x;
    double alpha = 1.0;
    bool accepted = false;
    for (int ls = 0; ls < 30 && !accepted; ++ls, alpha *= 0.5) {
      for (std::size_t i = 0; i < n; ++i)
        if (dof[i] >= 0) trial[i] = res.x[i] + alpha * dx.segment<3>(dof[i]);
      accepted = totalEnergy(mesh, tets, opt.springs, trial) <= e0 + 1e-4 * alpha * slope;
    }
    const double update = accepted ? free.largestUpdate(trial, res.x) : 0.0;
    if (accepted) res.x.swap(trial);
    res.iterations = it + 1;
    res.lastUpdate = update;
    reportProgress(opt.progress, std::min(1.0, double(it + 1) / 20.0), "neo-Hookean static solve");
    if (update <= tol) {
      res.converged = accepted;
      break;
    }
  }
  res.invertedTets = countInvertedTets(mesh, res.x);
  return res;
}

}  // namespace handson
