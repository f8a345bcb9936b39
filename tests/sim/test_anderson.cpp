#include <gtest/gtest.h>

#include <Eigen/Dense>

#include "sim/anderson.h"

namespace handson {
namespace {

// A slow linear fixed-point iteration x <- x + w (b - A x): A symmetric positive definite with
// eigenvalues 1 .. 100 (n = 6), w = 1/100, so the plain iteration's error shrinks by 0.99 a step.
struct SlowLinearMap {
  Eigen::MatrixXd A;
  Eigen::VectorXd b, solution;
  SlowLinearMap() {
    const int n = 6;
    const Eigen::MatrixXd Q = Eigen::HouseholderQR<Eigen::MatrixXd>(Eigen::MatrixXd::Random(n, n)).householderQ();
    const Eigen::VectorXd eig = Eigen::VectorXd::LinSpaced(n, 1.0, 100.0);
    A = Q * eig.asDiagonal() * Q.transpose();
    b = Eigen::VectorXd::LinSpaced(n, -1.0, 2.0);
    solution = A.ldlt().solve(b);
  }
  Eigen::VectorXd update(const Eigen::VectorXd& x) const { return (b - A * x) / 100.0; }
};

TEST(AndersonAcceleration, ReachesALinearMapsFixedPointInAsManyStepsAsItHasDimensions) {
  // On a linear map with n unknowns and depth >= n Anderson's type II mixing is GMRES on the
  // residual in exact arithmetic (Walker & Ni 2011): the fixed point after at most n + 1 steps.
  // Tolerance 1e-8 relative: the secant least squares lose a few digits to conditioning
  // (eigenvalue ratio 100); the plain iteration after as many steps is still ~94 % of the way off.
  const SlowLinearMap map;
  AndersonAcceleration aa(6);
  Eigen::VectorXd x = Eigen::VectorXd::Zero(6), plain = x;
  for (int k = 0; k < 7; ++k) {
    x += aa.step(x, map.update(x));
    plain += map.update(plain);
  }
  EXPECT_LT((x - map.solution).norm(), 1e-8 * map.solution.norm());
  EXPECT_GT((plain - map.solution).norm(), 0.5 * map.solution.norm());
  EXPECT_EQ(aa.pairs(), 6);
}

TEST(AndersonAcceleration, WithNoPairItIsThePlainStepAndANewRunFormsNoPairAcrossRuns) {
  const SlowLinearMap map;
  AndersonAcceleration aa(3);
  const Eigen::VectorXd x0 = Eigen::VectorXd::Ones(6);
  EXPECT_TRUE(aa.step(x0, map.update(x0)).isApprox(map.update(x0)));
  aa.begin();  // a new run: the next step keeps no pair with x0
  const Eigen::VectorXd x1 = Eigen::VectorXd::Zero(6);
  EXPECT_TRUE(aa.step(x1, map.update(x1)).isApprox(map.update(x1)));
  EXPECT_EQ(aa.pairs(), 0);
  // Within the run pairs form, at most the depth of them.
  Eigen::VectorXd x = x1 + map.update(x1);
  for (int k = 0; k < 5; ++k) x += aa.step(x, map.update(x));
  EXPECT_EQ(aa.pairs(), 3);
  aa.reset();
  EXPECT_EQ(aa.pairs(), 0);
}

TEST(AndersonAcceleration, DepthZeroIsThePlainIterationAndParallelSecantsDoNotBreakIt) {
  const SlowLinearMap map;
  AndersonAcceleration none(0);
  Eigen::VectorXd x = Eigen::VectorXd::Zero(6);
  for (int k = 0; k < 3; ++k) {
    const Eigen::VectorXd f = map.update(x);
    EXPECT_TRUE(none.step(x, f).isApprox(f));
    x += f;
  }
  // The same iterate twice: a zero secant, which the pivoted QR drops (a finite step, not NaN).
  AndersonAcceleration aa(2);
  const Eigen::VectorXd y = Eigen::VectorXd::Ones(6), f = map.update(y);
  aa.step(y, f);
  const Eigen::VectorXd s = aa.step(y, f);
  EXPECT_TRUE(s.allFinite());
  EXPECT_TRUE(s.isApprox(f));
}

}  // namespace
}  // namespace handson
