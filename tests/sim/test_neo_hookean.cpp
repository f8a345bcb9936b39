// The Neo-Hookean tet (sim/neo_hookean.h) against finite differences and the linear material, and its
// static solve against the corotational one where both hold.
#include "sim/neo_hookean.h"

#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <cmath>

#include "sim/base/error.h"
#include "sim/tet_mesh.h"

namespace handson {
namespace {

const std::array<Eigen::Vector3d, 4> kRest = {Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(2, 0.1, 0), Eigen::Vector3d(0.3, 1.5, 0.2),
                                              Eigen::Vector3d(0.1, 0.4, 1.8)};

std::array<Eigen::Vector3d, 4> deformed(const Eigen::Matrix3d& F, const Eigen::Vector3d& t) {
  std::array<Eigen::Vector3d, 4> x;
  for (int a = 0; a < 4; ++a) x[std::size_t(a)] = F * kRest[std::size_t(a)] + t;
  return x;
}

Vec12 stacked(const std::array<Eigen::Vector3d, 4>& x) {
  Vec12 v;
  for (int a = 0; a < 4; ++a) v.segment<3>(3 * a) = x[std::size_t(a)];
  return v;
}

std::array<Eigen::Vector3d, 4> unstacked(const Vec12& v) { return {v.segment<3>(0), v.segment<3>(3), v.segment<3>(6), v.segment<3>(9)}; }

TEST(NeoHookean, TheForceAndHessianAreTheEnergysDerivatives) {
  // A large, uninverted deformation (stretches of 0.6-1.5 and a shear): central differences with
  // h = 1e-6 mm (truncation ~h^2, rounding ~1e-16 E / h) agree within 1e-5 of the largest entry.
  const NeoHookeanTet t = neoHookeanTet(kRest, 1e4, 0.45);
  Eigen::Matrix3d F;
  F << 1.5, 0.3, 0.0, 0.1, 0.6, 0.2, 0.0, 0.2, 1.1;
  const Vec12 x = stacked(deformed(F, {1, 2, 3}));
  const Vec12 f = neoHookeanForce(t, unstacked(x));
  const Mat12 H = neoHookeanHessian(t, unstacked(x), false);
  const double h = 1e-6;
  Vec12 fd;
  Mat12 Hd;
  for (int i = 0; i < 12; ++i) {
    Vec12 a = x, b = x;
    a[i] += h;
    b[i] -= h;
    fd[i] = -(neoHookeanEnergy(t, unstacked(a)) - neoHookeanEnergy(t, unstacked(b))) / (2 * h);
    Hd.col(i) = -(neoHookeanForce(t, unstacked(a)) - neoHookeanForce(t, unstacked(b))) / (2 * h);
  }
  EXPECT_LT((f - fd).cwiseAbs().maxCoeff(), 1e-5 * f.cwiseAbs().maxCoeff());
  EXPECT_LT((H - Hd).cwiseAbs().maxCoeff(), 1e-5 * H.cwiseAbs().maxCoeff());
  // Projected: positive semi-definite, and H itself where H already was.
  const Mat12 P = neoHookeanHessian(t, unstacked(x), true);
  EXPECT_GT(Eigen::SelfAdjointEigenSolver<Mat12>(P).eigenvalues().minCoeff(), -1e-9 * P.norm());
}

TEST(NeoHookean, AtSmallStrainItIsTheLinearMaterialAndRigidMotionsCostNothing) {
  // At rest the Hessian is the linear stiffness (tetStiffness, same E and nu) to rounding; a rigid
  // motion has zero energy and force; an inverted tet has infinite energy.
  const NeoHookeanTet t = neoHookeanTet(kRest, 1e4, 0.45);
  const Mat12 K = tetStiffness(kRest, 1e4, 0.45);
  EXPECT_LT((neoHookeanHessian(t, kRest, false) - K).norm(), 1e-9 * K.norm());
  const Eigen::Matrix3d R = Eigen::AngleAxisd(0.8, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  EXPECT_NEAR(neoHookeanEnergy(t, deformed(R, {4, 5, 6})), 0.0, 1e-9);
  EXPECT_LT(neoHookeanForce(t, deformed(R, {4, 5, 6})).norm(), 1e-9 * K.norm());
  Eigen::Matrix3d flip = Eigen::Matrix3d::Identity();
  flip(0, 0) = -1;
  EXPECT_TRUE(std::isinf(neoHookeanEnergy(t, deformed(flip, {0, 0, 0}))));
}

// A 20 x 4 x 4 mm bar of 2 mm cubes (6 Kuhn tets each), its x = 0 end held and its x = 20 end moved.
struct Bar {
  TetMesh mesh;
  std::vector<char> fixed;
  std::vector<Eigen::Vector3d> x0;
  Bar(const Eigen::Vector3d& endMotion) {
    const int nx = 11, ny = 3, nz = 3;
    auto id = [&](int i, int j, int k) { return i + nx * (j + ny * k); };
    for (int k = 0; k < nz; ++k)
      for (int j = 0; j < ny; ++j)
        for (int i = 0; i < nx; ++i) mesh.nodes.emplace_back(2.0 * i, 2.0 * j, 2.0 * k);
    for (int k = 0; k + 1 < nz; ++k)
      for (int j = 0; j + 1 < ny; ++j)
        for (int i = 0; i + 1 < nx; ++i) {
          const int c[8] = {id(i, j, k), id(i + 1, j, k), id(i, j + 1, k), id(i + 1, j + 1, k), id(i, j, k + 1), id(i + 1, j, k + 1), id(i, j + 1, k + 1), id(i + 1, j + 1, k + 1)};
          // The six tets of the cube around its diagonal 0-7 (all positively oriented).
          const int p[6][2] = {{1, 3}, {3, 2}, {2, 6}, {6, 4}, {4, 5}, {5, 1}};
          for (const auto& q : p) mesh.tets.push_back({c[0], c[q[0]], c[q[1]], c[7]});
        }
    for (auto& t : mesh.tets) {
      const auto X = tetCorners(t, mesh.nodes);
      if ((X[1] - X[0]).cross(X[2] - X[0]).dot(X[3] - X[0]) < 0) std::swap(t[1], t[2]);
    }
    fixed.assign(mesh.nodes.size(), 0);
    x0 = mesh.nodes;
    for (std::size_t n = 0; n < mesh.nodes.size(); ++n)
      if (mesh.nodes[n].x() == 0.0 || mesh.nodes[n].x() == 20.0) {
        fixed[n] = 1;
        if (mesh.nodes[n].x() == 20.0) x0[n] += endMotion;
      }
  }
};

double rmsDifference(const std::vector<Eigen::Vector3d>& a, const std::vector<Eigen::Vector3d>& b) {
  double s = 0;
  for (std::size_t i = 0; i < a.size(); ++i) s += (a[i] - b[i]).squaredNorm();
  return std::sqrt(s / double(a.size()));
}

TEST(NeoHookean, TheStaticSolveAgreesWithTheCorotationalOneAtSmallStrainAndPartsFromItAtLarge) {
  // Stretched by 0.1 % the two materials agree to 1e-3 of the motion (both are linear elasticity
  // there); stretched by 40 % they differ by more than 1 % of it (Neo-Hookean stiffens in tension
  // and its lateral contraction differs).
  const std::vector<double> E(240, 1e4), nu(240, 0.45);
  for (const double stretch : {0.02, 8.0}) {
    const Bar bar(Eigen::Vector3d(stretch, 0, 0));
    ASSERT_EQ(bar.mesh.tets.size(), 240u);
    const StaticSolveResult co = solveStatic(bar.mesh, tetStiffnesses(bar.mesh, E, nu), bar.fixed, bar.x0);
    ASSERT_TRUE(co.converged);
    const StaticSolveResult nh = solveStaticNeoHookean(bar.mesh, neoHookeanTets(bar.mesh, E, nu), bar.fixed, co.x);
    ASSERT_TRUE(nh.converged);
    EXPECT_EQ(nh.invertedTets, 0);
    const double d = rmsDifference(co.x, nh.x);
    if (stretch < 1) EXPECT_LT(d, 1e-3 * stretch);
    else EXPECT_GT(d, 1e-2 * stretch);
  }
  // A start that inverts a tet is refused, not solved from.
  Bar bar(Eigen::Vector3d(-30, 0, 0));
  EXPECT_THROW(solveStaticNeoHookean(bar.mesh, neoHookeanTets(bar.mesh, E, nu), bar.fixed, bar.x0), Error);
}

}  // namespace
}  // namespace handson
