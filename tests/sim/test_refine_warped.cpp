// The matrix-free refinements (sim/refine_warped.cpp) against the stored 12x12 stiffness blocks and
// the exact corotational Hessian, and across thread counts.
#include <gtest/gtest.h>

#include <random>

#include "sim/coarsening.h"
#include "sim/base/error.h"
#include "sim/static_solver.h"
#include "sim/two_level.h"

using namespace handson;

namespace {

struct Box {
  NestedMeshes nm = buildNestedMeshes({0, 0, 0}, {30, 20, 20}, 96, 8);
  std::vector<double> E, nu;
  std::vector<Mat12> K;
  FineConstraints c;
  Box() {
    std::mt19937 rng(3);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    for (std::size_t t = 0; t < nm.fine.tets.size(); ++t) {
      E.push_back(u(rng) < 0.3 ? 500.0 : 1.0);
      nu.push_back(0.2 + 0.25 * u(rng));
    }
    K = tetStiffnesses(nm.fine, E, nu);
    c.handleCount = 1;
    c.handleOf.assign(nm.fine.nodes.size(), -1);
    c.fixed.assign(nm.fine.nodes.size(), 0);
    for (std::size_t n = 0; n < nm.fine.nodes.size(); ++n) {
      const auto& p = nm.fine.nodes[n];
      if (p.x() < 1e-9) c.fixed[n] = 1;
      else if (p.x() > 30 - 1e-9) c.handleOf[n] = 0;
    }
  }
};

}  // namespace

TEST(RefineWarped, ProductIsTheRotatedStoredStiffness) {
  const Box b;
  const CoarseModel model(b.nm, b.K, b.c);
  const FineRefiner refiner(model, b.K, b.E, b.nu, RefineOptions{RefineMethod::Warped, 0});
  std::mt19937 rng(7);
  std::normal_distribution<double> g(0.0, 1.0);
  const TetMesh& F = b.nm.fine;
  // A large smooth deformation (a bend and a twist) plus noise, and a random direction.
  std::vector<Eigen::Vector3d> x = F.nodes, p(F.nodes.size());
  for (std::size_t i = 0; i < x.size(); ++i) {
    const Eigen::Vector3d& X = F.nodes[i];
    x[i] = Eigen::AngleAxisd(0.02 * X.x(), Eigen::Vector3d::UnitX()).toRotationMatrix() * X + Eigen::Vector3d(0, 0.01 * X.x() * X.x(), 0) +
           0.05 * Eigen::Vector3d(g(rng), g(rng), g(rng));
    p[i] = Eigen::Vector3d(g(rng), g(rng), g(rng));
  }
  // Independent answer: sum_t R_t K_t R_t^T p_t with the 12x12 blocks of tetStiffness and polarRotation.
  std::vector<Eigen::Vector3d> ref(F.nodes.size(), Eigen::Vector3d::Zero());
  for (std::size_t t = 0; t < F.tets.size(); ++t) {
    const Eigen::Matrix3d R = polarRotation(deformationGradient(tetCorners(F.tets[t], F.nodes), tetCorners(F.tets[t], x)));
    const Mat12 B = blockRotation(R);
    const Vec12 y = B * b.K[t] * B.transpose() * stack(tetCorners(F.tets[t], p));
    for (int a = 0; a < 4; ++a) ref[std::size_t(F.tets[t][std::size_t(a)])] += y.segment<3>(3 * a);
  }
  const auto got = refiner.product(x, p);
  double err = 0, scale = 0;
  for (std::size_t i = 0; i < ref.size(); ++i) {
    err = std::max(err, (got[i] - ref[i]).norm());
    scale = std::max(scale, ref[i].norm());
  }
  EXPECT_LT(err, 1e-11 * scale) << "the same numbers up to roundoff";
}

TEST(RefineWarped, AnalyticProductIsTheExactHessianWhereNoTwistIsClampedAndPositiveOtherwise) {
  const Box b;
  const CoarseModel model(b.nm, b.K, b.c);
  const FineRefiner refiner(model, b.K, b.E, b.nu);
  ASSERT_EQ(refiner.method(), RefineMethod::Analytic) << "the default";
  const TetMesh& F = b.nm.fine;
  std::mt19937 rng(9);
  std::normal_distribution<double> g(0.0, 1.0);
  std::vector<Eigen::Vector3d> p(F.nodes.size());
  for (auto& v : p) v = Eigen::Vector3d(g(rng), g(rng), g(rng));
  auto exactProduct = [&](const std::vector<Eigen::Vector3d>& x, bool project) {
    std::vector<Eigen::Vector3d> out(F.nodes.size(), Eigen::Vector3d::Zero());
    for (std::size_t t = 0; t < F.tets.size(); ++t) {
      const Mat12 H = corotationalHessian(b.K[t], tetCorners(F.tets[t], F.nodes), tetCorners(F.tets[t], x), project);
      const Vec12 y = H * stack(tetCorners(F.tets[t], p));
      for (int a = 0; a < 4; ++a) out[std::size_t(F.tets[t][std::size_t(a)])] += y.segment<3>(3 * a);
    }
    return out;
  };
  auto largest = [](const std::vector<Eigen::Vector3d>& a, const std::vector<Eigen::Vector3d>* minus) {
    double m = 0;
    for (std::size_t i = 0; i < a.size(); ++i) m = std::max(m, minus ? (a[i] - (*minus)[i]).norm() : a[i].norm());
    return m;
  };
  // Stretched 10 % along x and turned 40 degrees: every principal stress is tensile, so every twist
  // eigenvalue is positive and nothing is clamped: the product is the exact Hessian's (with the
  // rotation's variation), which corotationalHessian computes independently (its own derivation).
  std::vector<Eigen::Vector3d> x = F.nodes;
  const Eigen::Matrix3d R = Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 2).normalized()).toRotationMatrix();
  for (auto& v : x) v = R * Eigen::Vector3d(1.1 * v.x(), 1.02 * v.y(), 1.03 * v.z());
  const auto exact = exactProduct(x, false);
  const auto got = refiner.product(x, p);
  EXPECT_LT(largest(got, &exact), 1e-9 * largest(exact, nullptr)) << "the exact Hessian";
  // Compressed by 30 % and turned: every twist eigenvalue is negative and clamped away, so the
  // clamped form exceeds the exact one (exact = clamped + the negative twist part) and stays >= 0.
  for (std::size_t i = 0; i < x.size(); ++i) x[i] = R * (0.7 * F.nodes[i]);
  double exactQuad = 0, clampedQuad = 0;
  const auto exactC = exactProduct(x, false), clamped = refiner.product(x, p);
  for (std::size_t i = 0; i < p.size(); ++i) {
    exactQuad += p[i].dot(exactC[i]);
    clampedQuad += p[i].dot(clamped[i]);
  }
  EXPECT_GE(clampedQuad, 0.0);
  EXPECT_GT(clampedQuad, exactQuad) << "the clamped twist terms were negative";
  // Uniform compression: the clamped product is the warped stiffness's (every twist dropped).
  const FineRefiner warped(model, b.K, b.E, b.nu, RefineOptions{RefineMethod::Warped, 0});
  const auto w = warped.product(x, p);
  EXPECT_LT(largest(clamped, &w), 1e-9 * largest(w, nullptr));
}

TEST(RefineWarped, StepsConvergeToTheFineStaticAnswerWithAnyThreadCount) {
  const Box b;
  CoarseModel model(b.nm, b.K, b.c);
  const std::vector<RigidTransform> T = {RigidTransform::about({30, 10, 10}, Eigen::Vector3d(0.3, 0, 0), Eigen::Vector3d(2, 1, -1))};
  std::vector<char> dir;
  const auto x0 = prescribedPositions(b.nm.fine, b.c, T, &dir);
  const auto fine = solveStatic(b.nm.fine, b.K, dir, x0);
  ASSERT_TRUE(fine.converged);
  auto xc = model.restState();
  ASSERT_TRUE(model.solve(T, xc, 200).converged);
  const auto start = model.reconstruct(T, xc);
  auto rms = [&](const std::vector<Eigen::Vector3d>& x) {
    double s = 0;
    for (std::size_t i = 0; i < x.size(); ++i) s += (x[i] - fine.x[i]).squaredNorm();
    return std::sqrt(s / double(x.size()));
  };
  std::vector<std::vector<Eigen::Vector3d>> results;
  for (int threads : {1, 2, 3}) {
    const FineRefiner refiner(model, b.K, b.E, b.nu, RefineOptions{RefineMethod::Analytic, threads});
    auto x = start;
    const double e0 = rms(x);
    for (int k = 0; k < 8; ++k) refiner.step(T, xc, x, 10);
    std::printf("%d thread(s): RMS to the fine answer %.3e -> %.3e mm\n", threads, e0, rms(x));
    EXPECT_LT(rms(x), 1e-3 * e0) << "8 steps cut the coarse model's error a thousandfold";
    results.push_back(x);
  }
  for (std::size_t k = 1; k < results.size(); ++k) EXPECT_LT(rms(results[k]) - rms(results[0]), 1e-9) << "threads only reorder sums";
}

TEST(RefineWarped, RefusesMaterialsOfTheWrongSize) {
  const Box b;
  const CoarseModel model(b.nm, b.K, b.c);
  std::vector<double> shortE(b.E.begin(), b.E.end() - 1);
  EXPECT_THROW(FineRefiner(model, b.K, shortE, b.nu), Error);
  const FineRefiner projected(model, b.K);
  EXPECT_EQ(projected.method(), RefineMethod::Projected);
  EXPECT_THROW(projected.product(b.nm.fine.nodes, b.nm.fine.nodes), Error);
}
