#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <vector>

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
    // A fixed orthogonal Q (a Householder reflector), so the eigenvectors do not depend on a
    // library's random numbers.
    const Eigen::VectorXd v = Eigen::VectorXd::LinSpaced(n, 1.0, 6.0);
    const Eigen::MatrixXd Q = Eigen::MatrixXd::Identity(n, n) - 2.0 * v * v.transpose() / v.squaredNorm();
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

TEST(AndersonAcceleration, ParallelSecantsDropOutAndTheStepStaysExact) {
  // f(x) = -(x - x*) / 2 from a start whose error lies along one direction: every secant is
  // parallel to the first. One pair is the secant method, exact on a linear map: the fixed point
  // at the second step; the next pair, parallel to it, drops out (a finite step, not NaN).
  const Eigen::VectorXd star = Eigen::VectorXd::LinSpaced(5, 1.0, 5.0), dir = Eigen::VectorXd::LinSpaced(5, -2.0, 2.0);
  auto update = [&](const Eigen::VectorXd& y) -> Eigen::VectorXd { return -0.5 * (y - star); };
  AndersonAcceleration aa(3);
  Eigen::VectorXd x = star + 4.0 * dir;
  x += aa.step(x, update(x));  // plain: half way
  x += aa.step(x, update(x));  // one pair: exact
  EXPECT_LT((x - star).norm(), 1e-12 * star.norm());
  const Eigen::VectorXd y = star + 1e-3 * dir;  // another start on the same line
  const Eigen::VectorXd s = aa.step(y, update(y));
  EXPECT_TRUE(s.allFinite());
  EXPECT_LT((y + s - star).norm(), 1e-9 * star.norm());
}

TEST(AndersonAcceleration, AfterTheRingWrapsItMixesTheLastPairs) {
  // Depth 2 over 5 steps of the slow linear map: the fifth step must be the least-squares mix of
  // the last two secant pairs, computed here densely from the iterates (tolerance 1e-10 relative:
  // rounding in two different least-squares methods).
  const SlowLinearMap map;
  AndersonAcceleration aa(2);
  std::vector<Eigen::VectorXd> xs{Eigen::VectorXd::Zero(6)}, fs;
  Eigen::VectorXd last;
  for (int k = 0; k < 5; ++k) {
    fs.push_back(map.update(xs.back()));
    last = aa.step(xs.back(), fs.back());
    xs.push_back(xs.back() + last);
  }
  const std::size_t k = fs.size() - 1;
  Eigen::MatrixXd dX(6, 2), dF(6, 2);
  for (int j = 0; j < 2; ++j) {
    dX.col(j) = xs[k - std::size_t(j)] - xs[k - std::size_t(j) - 1];
    dF.col(j) = fs[k - std::size_t(j)] - fs[k - std::size_t(j) - 1];
  }
  const Eigen::VectorXd gamma = dF.colPivHouseholderQr().solve(fs[k]);
  const Eigen::VectorXd expected = fs[k] - (dX + dF) * gamma;
  EXPECT_EQ(aa.pairs(), 2);
  EXPECT_LT((last - expected).norm(), 1e-10 * expected.norm());
}

TEST(AndersonAcceleration, DepthZeroIsThePlainIterationAndARepeatedIterateAddsNoPair) {
  const SlowLinearMap map;
  AndersonAcceleration none(0);
  Eigen::VectorXd x = Eigen::VectorXd::Zero(6);
  for (int k = 0; k < 3; ++k) {
    const Eigen::VectorXd f = map.update(x);
    EXPECT_TRUE(none.step(x, f).isApprox(f));
    x += f;
  }
  // The same iterate twice: a zero secant, skipped (no pair; the plain step).
  AndersonAcceleration aa(2);
  const Eigen::VectorXd y = Eigen::VectorXd::Ones(6), f = map.update(y);
  aa.step(y, f);
  const Eigen::VectorXd s = aa.step(y, f);
  EXPECT_TRUE(s.allFinite());
  EXPECT_TRUE(s.isApprox(f));
  EXPECT_EQ(aa.pairs(), 0);
}

TEST(AndersonAcceleration, TheGuardDropsAFarMixAndItsPairsAndKeepsAnOrdinaryOne) {
  // One secant along which the map barely changes: x 0 -> (1,0,0), f (1,0,0) -> (1.001,0,0). The
  // least squares fits f with gamma = 1.001 / 0.001 = 1001, so the mix extrapolates to
  // 1.001 - 1.001 * 1001 = -1001 along it, 1000x the plain update: guarded at 10x, the plain
  // update comes back exactly and the pair goes. On the slow linear map (6 unknowns, two 3-vectors)
  // the guard never acts: the same steps as unguarded, to the last bit.
  const Eigen::Vector3d x0 = Eigen::Vector3d::Zero(), f0(1.0, 0.0, 0.0), x1(1.0, 0.0, 0.0), f1(1.001, 0.0, 0.0);
  AndersonAcceleration open(2), guarded(2);
  open.step(x0, f0);
  guarded.guardedStep(x0, f0, 10.0);
  const Eigen::VectorXd far = open.step(x1, f1);
  EXPECT_NEAR(far[0], -1001.0, 1e-6);  // what the guard is for
  const Eigen::VectorXd kept = guarded.guardedStep(x1, f1, 10.0);
  EXPECT_EQ(kept, Eigen::VectorXd(f1));
  EXPECT_EQ(guarded.pairs(), 0);
  // Nothing of the dropped run is paired with the next call either.
  EXPECT_EQ(Eigen::VectorXd(guarded.guardedStep(x1 + f1, f1, 10.0)), Eigen::VectorXd(f1));
  EXPECT_EQ(guarded.pairs(), 0);

  const SlowLinearMap map;
  AndersonAcceleration a(3), b(3);
  Eigen::VectorXd xa = Eigen::VectorXd::Zero(6), xb = xa;
  for (int k = 0; k < 5; ++k) {
    const Eigen::VectorXd sa = a.step(xa, map.update(xa)), sb = b.guardedStep(xb, map.update(xb), 10.0);
    EXPECT_EQ(sa, sb) << "step " << k;
    xa += sa;
    xb += sb;
  }
  EXPECT_EQ(b.pairs(), 3);
}

}  // namespace
}  // namespace handson
