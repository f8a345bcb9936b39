// The corotational tet element and the fine static solve, against finite differences and
// analytic answers.
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <Eigen/Geometry>
#include <random>

#include "sim/base/error.h"
#include "sim/fem.h"
#include "sim/static_solver.h"

using namespace handson;

namespace {

const std::array<Eigen::Vector3d, 4> kRest = {Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(2, 0.1, 0), Eigen::Vector3d(0.3, 1.5, 0.2),
                                              Eigen::Vector3d(0.1, 0.4, 1.8)};

std::array<Eigen::Vector3d, 4> unstack(const Vec12& v) {
  return {v.segment<3>(0), v.segment<3>(3), v.segment<3>(6), v.segment<3>(9)};
}

// Central differences of the force (h = 1e-6 mm: truncation ~h^2, roundoff ~1e-10 / h, relative).
Mat12 forceJacobianFd(const Mat12& K, const Vec12& x) {
  Mat12 J;
  const double h = 1e-6;
  for (int i = 0; i < 12; ++i) {
    Vec12 a = x, b = x;
    a[i] += h;
    b[i] -= h;
    J.col(i) = (corotationalForce(K, kRest, unstack(a)) - corotationalForce(K, kRest, unstack(b))) / (2 * h);
  }
  return J;
}

}  // namespace

TEST(Fem, ForceIsMinusTheEnergyGradientEvenWhenInverted) {
  const Mat12 K = tetStiffness(kRest, 1e4, 0.4);
  std::mt19937 rng(3);
  std::normal_distribution<double> n(0.0, 1.0);
  const Eigen::Matrix3d R = Eigen::AngleAxisd(1.1, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  for (int trial = 0; trial < 3; ++trial) {
    Vec12 x;
    for (int i = 0; i < 4; ++i) x.segment<3>(3 * i) = R * kRest[std::size_t(i)];
    for (int i = 0; i < 12; ++i) x[i] += 0.3 * n(rng);
    if (trial == 2) x.segment<3>(9) = x.segment<3>(0) - (x.segment<3>(9) - x.segment<3>(0));  // push a corner through: inverted
    const Vec12 f = corotationalForce(K, kRest, unstack(x));
    // Central differences with h = 1e-6 (relative error ~h^2 plus roundoff ~1e-10 / h).
    const double h = 1e-6;
    Vec12 g;
    for (int i = 0; i < 12; ++i) {
      Vec12 a = x, b = x;
      a[i] += h;
      b[i] -= h;
      double ea = 0, eb = 0;
      corotationalForce(K, kRest, unstack(a), &ea);
      corotationalForce(K, kRest, unstack(b), &eb);
      g[i] = (ea - eb) / (2 * h);
    }
    EXPECT_LT((f + g).norm(), 1e-5 * f.norm()) << "trial " << trial << "\nf " << f.transpose() << "\n-g " << -g.transpose();
  }
}

TEST(Fem, WarpedStiffnessIsTheForceJacobianInRigidlyMovedConfigurations) {
  const Mat12 K = tetStiffness(kRest, 5e3, 0.3);
  for (double deg : {0.0, 37.0, 90.0, 180.0}) {
    const Eigen::Matrix3d R = Eigen::AngleAxisd(deg * M_PI / 180, Eigen::Vector3d(-1, 0.5, 2).normalized()).toRotationMatrix();
    Vec12 x;
    for (int i = 0; i < 4; ++i) x.segment<3>(3 * i) = R * kRest[std::size_t(i)] + Eigen::Vector3d(5, -2, 1);
    EXPECT_LT(corotationalForce(K, kRest, unstack(x)).norm(), 1e-9 * K.norm()) << "a rigid motion has no elastic force (" << deg << " deg)";
    const Mat12 B = blockRotation(R);
    const Mat12 Kw = B * K * B.transpose();
    EXPECT_LT((forceJacobianFd(K, x) + Kw).norm(), 1e-6 * Kw.norm()) << deg << " deg";
  }
}

TEST(Fem, StiffnessHasTheRigidModesAsItsKernelAndIsSymmetric) {
  const Mat12 K = tetStiffness(kRest, 1e3, 0.45);
  EXPECT_LT((K - K.transpose()).norm(), 1e-12 * K.norm());
  for (int a = 0; a < 3; ++a) {
    Vec12 t = Vec12::Zero(), r;
    for (int i = 0; i < 4; ++i) {
      t[3 * i + a] = 1;
      r.segment<3>(3 * i) = Eigen::Vector3d::Unit(a).cross(kRest[std::size_t(i)]);
    }
    EXPECT_LT((K * t).norm(), 1e-10 * K.norm());
    EXPECT_LT((K * r).norm(), 1e-10 * K.norm());
  }
  Eigen::SelfAdjointEigenSolver<Mat12> es(K);
  EXPECT_GT(es.eigenvalues()[6], 1e-6 * es.eigenvalues()[11]);  // exactly six zero modes
  EXPECT_TRUE(tetStiffness({kRest[0], kRest[0], kRest[2], kRest[3]}, 1e3, 0.3).isZero());  // degenerate: no stiffness, no NaN
}

TEST(Fem, PolarRotationIsAProperRotationForInvertedAndDegenerateF) {
  const Eigen::Matrix3d R = Eigen::AngleAxisd(0.7, Eigen::Vector3d(0, 1, 1).normalized()).toRotationMatrix();
  EXPECT_LT((polarRotation(R * Eigen::Vector3d(2, 1, 0.5).asDiagonal()) - R).norm(), 1e-12);
  // Inverted along its weakest direction: the rotation is still R (the element pushes back).
  EXPECT_LT((polarRotation(R * Eigen::Vector3d(1, 1.2, -0.3).asDiagonal()) - R).norm(), 1e-12);
  for (const Eigen::Matrix3d& F : {Eigen::Matrix3d(Eigen::Matrix3d::Zero()), Eigen::Matrix3d(Eigen::Vector3d(1, 0, 0).asDiagonal()),
                                   Eigen::Matrix3d(-Eigen::Matrix3d::Identity()), Eigen::Matrix3d(Eigen::Matrix3d::Constant(std::nan("")))}) {
    const Eigen::Matrix3d Q = polarRotation(F);
    EXPECT_TRUE(Q.allFinite());
    EXPECT_NEAR(Q.determinant(), 1.0, 1e-12);
    EXPECT_LT((Q.transpose() * Q - Eigen::Matrix3d::Identity()).norm(), 1e-12);
  }
}

TEST(Fem, WarmStartedPolarIterationGivesPolarRotationsAnswer) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  auto randomRotation = [&](double maxAngle) {
    const Eigen::Vector3d axis = Eigen::Vector3d(u(rng), u(rng), u(rng)).normalized();
    return Eigen::Matrix3d(Eigen::AngleAxisd(maxAngle * u(rng), axis).toRotationMatrix());
  };
  // Uninverted F with stretches from 0.3 to 3, from a cold start (identity) and from warm starts
  // within 0.5 rad: the same rotation as polarRotation to 1e-9 (its own convergence is ~1e-13).
  for (int i = 0; i < 500; ++i) {
    const Eigen::Matrix3d R = randomRotation(M_PI);
    const Eigen::Matrix3d V = randomRotation(M_PI);
    const Eigen::Vector3d s(std::exp(1.1 * u(rng)), std::exp(1.1 * u(rng)), std::exp(1.1 * u(rng)));
    const Eigen::Matrix3d F = R * V * s.asDiagonal() * V.transpose();
    Eigen::Quaterniond cold = Eigen::Quaterniond::Identity();
    Eigen::Quaterniond warm(R * randomRotation(0.5));
    EXPECT_LT((polarRotationWarm(F, cold) - polarRotation(F)).norm(), 1e-9) << i;
    EXPECT_LT((polarRotationWarm(F, warm) - polarRotation(F)).norm(), 1e-9) << i;
    EXPECT_LT((warm.toRotationMatrix() - polarRotation(F)).norm(), 1e-9) << "the warm start is left at the answer";
  }
  // A drag: F turning by small steps, each solve warm-started from the last, stays on the answer.
  Eigen::Quaterniond q = Eigen::Quaterniond::Identity();
  const Eigen::Matrix3d S = Eigen::Vector3d(1.3, 0.8, 1.05).asDiagonal();
  for (int k = 0; k <= 200; ++k) {
    const Eigen::Matrix3d F = Eigen::AngleAxisd(0.01 * k, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix() * S;
    EXPECT_LT((polarRotationWarm(F, q) - polarRotation(F)).norm(), 1e-9) << k;
  }
  // Inverted, degenerate and non-finite F: polarRotation's proper rotation.
  const Eigen::Matrix3d R = Eigen::AngleAxisd(0.7, Eigen::Vector3d(0, 1, 1).normalized()).toRotationMatrix();
  for (const Eigen::Matrix3d& F : {Eigen::Matrix3d(R * Eigen::Vector3d(1, 1.2, -0.3).asDiagonal()), Eigen::Matrix3d(Eigen::Matrix3d::Zero()),
                                   Eigen::Matrix3d(Eigen::Vector3d(1, 0, 0).asDiagonal()), Eigen::Matrix3d(-Eigen::Matrix3d::Identity()),
                                   Eigen::Matrix3d(Eigen::Matrix3d::Constant(std::nan("")))}) {
    Eigen::Quaterniond w = Eigen::Quaterniond::Identity();
    const Eigen::Matrix3d Q = polarRotationWarm(F, w);
    EXPECT_TRUE(Q.allFinite());
    EXPECT_NEAR(Q.determinant(), 1.0, 1e-12);
    if (F.allFinite() && F.norm() > 0) {
      EXPECT_LT((Q - polarRotation(F)).norm(), 1e-12);
    }
  }
}

TEST(FineStatic, BarUnderPrescribedEndDisplacementMatchesLinearElasticity) {
  // A 40 x 10 x 10 mm bar, ends held on the uniaxial-stress field u = eps (x, -nu y, -nu z), sides
  // free: linear elasticity's answer is that field everywhere, with end force E eps A. Linear tets
  // reproduce linear fields exactly; the corotational model departs from linear by O(eps^2).
  const double E = 6e3, nu = 0.3, eps = 1e-4, L = 40, W = 10;
  const KuhnGrid g({0, -5, -5}, {4, 2.5, 2.5}, {10, 4, 4});
  const TetMesh m = g.mesh();
  const auto K = tetStiffnesses(m, std::vector<double>(m.tets.size(), E), std::vector<double>(m.tets.size(), nu));
  auto exact = [&](const Eigen::Vector3d& X) -> Eigen::Vector3d { return X + eps * Eigen::Vector3d(X.x(), -nu * X.y(), -nu * X.z()); };
  std::vector<char> fixed(m.nodes.size(), 0);
  std::vector<Eigen::Vector3d> x0 = m.nodes;
  for (std::size_t i = 0; i < m.nodes.size(); ++i)
    if (m.nodes[i].x() < 1e-9 || m.nodes[i].x() > L - 1e-9) {
      fixed[i] = 1;
      x0[i] = exact(m.nodes[i]);
    }
  const auto res = solveStatic(m, K, fixed, x0);
  ASSERT_TRUE(res.converged);
  double err = 0;
  for (std::size_t i = 0; i < m.nodes.size(); ++i) err = std::max(err, (res.x[i] - exact(m.nodes[i])).norm());
  EXPECT_LT(err, 1e-6 * eps * L) << "max node error vs the analytic field (mm)";
  const auto f = internalForces(m, K, res.x);
  double end = 0;
  for (std::size_t i = 0; i < m.nodes.size(); ++i)
    if (m.nodes[i].x() > L - 1e-9) end -= f[i].x();  // the reaction the support must supply
  EXPECT_NEAR(end, E * eps * W * W, 1e-3 * E * eps * W * W);
}

TEST(FineStatic, RigidRotationOfTheBoundaryGivesARigidMotion) {
  const KuhnGrid g({-6, -6, -6}, {3, 3, 3}, {4, 4, 4});
  const TetMesh m = g.mesh();
  const auto K = tetStiffnesses(m, std::vector<double>(m.tets.size(), 1e4), std::vector<double>(m.tets.size(), 0.4));
  for (double deg : {90.0, 180.0}) {
    const Eigen::Matrix3d R = Eigen::AngleAxisd(deg * M_PI / 180, Eigen::Vector3d(1, 1, 0).normalized()).toRotationMatrix();
    const Eigen::Vector3d t(3, 0, -1);
    std::vector<char> fixed(m.nodes.size(), 0);
    std::vector<Eigen::Vector3d> x0 = m.nodes, rigid(m.nodes.size());
    for (std::size_t i = 0; i < m.nodes.size(); ++i) {
      rigid[i] = R * m.nodes[i] + t;
      if (m.nodes[i].cwiseAbs().maxCoeff() > 6 - 1e-9) {
        fixed[i] = 1;
        x0[i] = rigid[i];
      }
    }
    const auto res = solveStatic(m, K, fixed, x0);
    EXPECT_TRUE(res.converged) << deg;
    double err = 0;
    for (std::size_t i = 0; i < m.nodes.size(); ++i) err = std::max(err, (res.x[i] - rigid[i]).norm());
    EXPECT_LT(err, 1e-6) << deg << " deg: the free nodes follow the rigid motion (mm)";
    EXPECT_EQ(res.invertedTets, 0);
    double fmax = 0;
    for (const auto& f : internalForces(m, K, res.x)) fmax = std::max(fmax, f.norm());
    EXPECT_LT(fmax, 1e-6 * 1e4 * 3) << "no elastic force in a rigid motion";
  }
}

TEST(FineStatic, RefusesSingularAndNonFiniteInput) {
  const KuhnGrid g({0, 0, 0}, {1, 1, 1}, {2, 2, 2});
  const TetMesh m = g.mesh();
  const auto K = tetStiffnesses(m, std::vector<double>(m.tets.size(), 1e3), std::vector<double>(m.tets.size(), 0.3));
  EXPECT_THROW(solveStatic(m, K, std::vector<char>(m.nodes.size(), 0), m.nodes), Error);
  std::vector<char> fixed(m.nodes.size(), 0);
  fixed[0] = 1;
  auto x0 = m.nodes;
  x0[0].x() = std::nan("");
  EXPECT_THROW(solveStatic(m, K, fixed, x0), Error);
  EXPECT_THROW(tetStiffnesses(m, {1.0}, {0.3}), Error);
}

TEST(Fem, ExactHessianMatchesFiniteDifferencesOfTheForce) {
  const Mat12 K = tetStiffness(kRest, 1e4, 0.4);
  std::mt19937 rng(5);
  std::normal_distribution<double> n(0.0, 1.0);
  const Eigen::Matrix3d R = Eigen::AngleAxisd(2.2, Eigen::Vector3d(3, -1, 2).normalized()).toRotationMatrix();
  for (int trial = 0; trial < 4; ++trial) {
    Vec12 x;
    for (int i = 0; i < 4; ++i) x.segment<3>(3 * i) = R * kRest[std::size_t(i)];
    for (int i = 0; i < 12; ++i) x[i] += 0.25 * n(rng);
    const Mat12 H = corotationalHessian(K, kRest, unstack(x), false);
    EXPECT_LT((H + forceJacobianFd(K, x)).norm(), 1e-5 * H.norm()) << "trial " << trial;
    EXPECT_LT((H - H.transpose()).norm(), 1e-8 * H.norm()) << "the Hessian of an energy is symmetric";
    // The projected Hessian is positive semi-definite and equals H where H already is.
    const Mat12 P = corotationalHessian(K, kRest, unstack(x), true);
    Eigen::SelfAdjointEigenSolver<Mat12> es(P);
    EXPECT_GE(es.eigenvalues().minCoeff(), -1e-9 * H.norm());
  }
}
