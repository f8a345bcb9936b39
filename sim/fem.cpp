#include "fem.h"

#include <Eigen/Dense>
#include <Eigen/SVD>
#include <cmath>

namespace handson {

Vec12 stack(const std::array<Eigen::Vector3d, 4>& p) {
  Vec12 v;
  for (int i = 0; i < 4; ++i) v.segment<3>(3 * i) = p[std::size_t(i)];
  return v;
}

Mat12 tetStiffness(const std::array<Eigen::Vector3d, 4>& X, double E, double nu) {
  Eigen::Matrix3d Dm;
  Dm << X[1] - X[0], X[2] - X[0], X[3] - X[0];
  const double det = Dm.determinant();
  const double V = std::abs(det) / 6.0;
  const double scale = (X[1] - X[0]).norm() + (X[2] - X[0]).norm() + (X[3] - X[0]).norm();
  if (!(V > 1e-12 * scale * scale * scale) || !std::isfinite(E) || !std::isfinite(nu)) return Mat12::Zero();
  const Eigen::Matrix3d Dinv = Dm.inverse();
  // Shape function gradients: rows of Dinv give grad N1..N3; grad N0 = -(sum).
  std::array<Eigen::Vector3d, 4> g;
  for (int i = 0; i < 3; ++i) g[std::size_t(i + 1)] = Dinv.row(i).transpose();
  g[0] = -(g[1] + g[2] + g[3]);
  Eigen::Matrix<double, 6, 12> B = Eigen::Matrix<double, 6, 12>::Zero();
  for (int i = 0; i < 4; ++i) {
    const Eigen::Vector3d& d = g[std::size_t(i)];
    B(0, 3 * i) = d.x();
    B(1, 3 * i + 1) = d.y();
    B(2, 3 * i + 2) = d.z();
    B(3, 3 * i) = d.y(), B(3, 3 * i + 1) = d.x();      // gamma_xy
    B(4, 3 * i + 1) = d.z(), B(4, 3 * i + 2) = d.y();  // gamma_yz
    B(5, 3 * i) = d.z(), B(5, 3 * i + 2) = d.x();      // gamma_xz
  }
  const double lambda = E * nu / ((1 + nu) * (1 - 2 * nu));
  const double mu = E / (2 * (1 + nu));
  Eigen::Matrix<double, 6, 6> C = Eigen::Matrix<double, 6, 6>::Zero();
  C.topLeftCorner<3, 3>().setConstant(lambda);
  C.topLeftCorner<3, 3>().diagonal().array() += 2 * mu;
  C.bottomRightCorner<3, 3>().diagonal().setConstant(mu);
  return V * B.transpose() * C * B;
}

Eigen::Matrix3d deformationGradient(const std::array<Eigen::Vector3d, 4>& X, const std::array<Eigen::Vector3d, 4>& x) {
  Eigen::Matrix3d Dm, Ds;
  Dm << X[1] - X[0], X[2] - X[0], X[3] - X[0];
  Ds << x[1] - x[0], x[2] - x[0], x[3] - x[0];
  return Ds * Dm.inverse();
}

Eigen::Matrix3d polarRotation(const Eigen::Matrix3d& F) {
  if (!F.allFinite()) return Eigen::Matrix3d::Identity();
  // Uninverted, well-conditioned F (the common case): Higham's scaled Newton iteration
  // X <- (g X + X^-T / g) / 2 converges quadratically to the same rotation, faster than a 3x3 SVD.
  const double fn = F.norm();
  if (F.determinant() > 1e-2 * fn * fn * fn) {
    Eigen::Matrix3d X = F;
    for (int it = 0; it < 20; ++it) {
      const Eigen::Matrix3d Xit = X.inverse().transpose();
      const double g = it < 4 ? std::sqrt(std::sqrt(Xit.squaredNorm() / X.squaredNorm())) : 1.0;
      const Eigen::Matrix3d Y = 0.5 * (g * X + Xit / g);
      if ((Y - X).squaredNorm() < 1e-26) return Y;
      X = Y;
    }
  }
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(F, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d U = svd.matrixU();
  const Eigen::Matrix3d V = svd.matrixV();
  if ((U * V.transpose()).determinant() < 0) U.col(2) = -U.col(2);  // singular values are sorted: col 2 is the smallest
  return U * V.transpose();
}

Eigen::Matrix3d polarRotationWarm(const Eigen::Matrix3d& F, Eigen::Quaterniond& q, double stepTolerance) {
  const double fn2 = F.squaredNorm();
  if (!F.allFinite() || !(fn2 > 0)) {
    q.setIdentity();
    return Eigen::Matrix3d::Identity();
  }
  if (F.determinant() > 1e-3 * fn2 * std::sqrt(fn2)) {
    for (int it = 0; it < 8; ++it) {
      const Eigen::Matrix3d R = q.toRotationMatrix();
      const Eigen::Matrix3d S = R.transpose() * F;
      const Eigen::Vector3d skew = axialOfSkew(S);
      Eigen::Matrix3d M = -0.5 * (S + S.transpose());
      M.diagonal().array() += S.trace();
      // At the polar rotation S is symmetric positive definite, and M's eigenvalues are the sums of
      // two of S's: positive. At the other stationary points (R turned by a half turn from it) some
      // sum is negative. So M must be positive definite (leading minors, scaled) to go on.
      const double tm = M.trace();
      const double det = M.determinant();
      if (!(tm > 0) || !(M(0, 0) > 0) || !(M(0, 0) * M(1, 1) - M(0, 1) * M(1, 0) > 0) || !(det > 1e-9 * tm * tm * tm)) break;
      const Eigen::Vector3d w = 2.0 * (M.inverse() * skew);
      const double angle = w.norm();
      if (!(angle < 1.0)) break;  // far from the answer: the direct method is safer
      if (angle < std::min(stepTolerance, 1e-3)) {
        // Newton converges quadratically: after this step the error is O(angle^2).
        // exp([w]) as the unit quaternion (1, w/2) normalized: exact to O(angle^3).
        q = (q * Eigen::Quaterniond(1.0, 0.5 * w.x(), 0.5 * w.y(), 0.5 * w.z())).normalized();
        return q.toRotationMatrix();
      }
      q = (q * Eigen::Quaterniond(Eigen::AngleAxisd(angle, w / angle))).normalized();
    }
  }
  const Eigen::Matrix3d R = polarRotation(F);
  q = Eigen::Quaterniond(R).normalized();
  return R;
}

Mat12 blockRotation(const Eigen::Matrix3d& R) {
  Mat12 B = Mat12::Zero();
  for (int i = 0; i < 4; ++i) B.block<3, 3>(3 * i, 3 * i) = R;
  return B;
}

Vec12 corotationalForce(const Mat12& K, const std::array<Eigen::Vector3d, 4>& X, const std::array<Eigen::Vector3d, 4>& x, double* energy) {
  const Eigen::Matrix3d R = polarRotation(deformationGradient(X, x));
  Vec12 local;
  for (int i = 0; i < 4; ++i) local.segment<3>(3 * i) = R.transpose() * x[std::size_t(i)] - X[std::size_t(i)];
  const Vec12 kl = K * local;
  if (energy) *energy = 0.5 * local.dot(kl);
  Vec12 f;
  for (int i = 0; i < 4; ++i) f.segment<3>(3 * i) = -R * kl.segment<3>(3 * i);
  return f;
}

Mat12 corotationalHessian(const Mat12& K, const std::array<Eigen::Vector3d, 4>& X, const std::array<Eigen::Vector3d, 4>& x, bool projectSpd) {
  Eigen::Matrix3d Dm, Ds;
  Dm << X[1] - X[0], X[2] - X[0], X[3] - X[0];
  Ds << x[1] - x[0], x[2] - x[0], x[3] - x[0];
  const Eigen::Matrix3d DmInv = Dm.inverse();
  const Eigen::Matrix3d F = Ds * DmInv;
  const Eigen::Matrix3d R = polarRotation(F);
  const Mat12 B = blockRotation(R);
  Mat12 H = B * K * B.transpose();
  const Eigen::Matrix3d S = R.transpose() * F;
  const Eigen::Matrix3d M = S.trace() * Eigen::Matrix3d::Identity() - 0.5 * (S + S.transpose());
  const Eigen::Vector3d sv = Eigen::JacobiSVD<Eigen::Matrix3d>(F).singularValues();
  if (F.allFinite() && std::abs(M.determinant()) > 1e-8 * std::pow(sv.maxCoeff() + 1e-300, 3)) {
    const Eigen::Matrix3d Minv2 = 2.0 * M.inverse();
    // W: dw/dx (3x12). dF for dof (node j, axis c): e_c times row (j-1) of DmInv (node 0: minus their sum).
    Eigen::Matrix<double, 3, 12> W;
    for (int j = 0; j < 4; ++j) {
      const Eigen::RowVector3d row = j == 0 ? Eigen::RowVector3d(-(DmInv.row(0) + DmInv.row(1) + DmInv.row(2))) : Eigen::RowVector3d(DmInv.row(j - 1));
      for (int c = 0; c < 3; ++c) {
        const Eigen::Matrix3d A = R.transpose() * (Eigen::Vector3d::Unit(c) * row);
        W.col(3 * j + c) = Minv2 * axialOfSkew(A);
      }
    }
    Vec12 local;
    for (int i = 0; i < 4; ++i) local.segment<3>(3 * i) = R.transpose() * x[std::size_t(i)] - X[std::size_t(i)];
    const Vec12 g = K * local;
    Eigen::Matrix<double, 12, 3> G, Xr;
    for (int i = 0; i < 4; ++i) {
      G.middleRows<3>(3 * i) = crossMatrix(g.segment<3>(3 * i));
      Xr.middleRows<3>(3 * i) = crossMatrix(R.transpose() * x[std::size_t(i)]);
    }
    H += B * (K * Xr - G) * W;
  }
  if (projectSpd) {
    const Mat12 Hs = 0.5 * (H + H.transpose());
    Eigen::SelfAdjointEigenSolver<Mat12> es(Hs);
    const Eigen::Matrix<double, 12, 1> ev = es.eigenvalues().cwiseMax(0.0);
    H = es.eigenvectors() * ev.asDiagonal() * es.eigenvectors().transpose();
  }
  return H;
}

}  // namespace handson
