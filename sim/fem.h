#pragma once
// Linear corotational FEM on tetrahedra (docs/simulation-model.md, the fine model):
// per tet, F = D_s D_m^-1, R = polar(F) (inversion-safe), f_e = -R K_e (R^T x_e - X_e),
// K_e = V B^T C(E, nu) B. For an isotropic C this force is exactly minus the gradient of
// E_e = 1/2 (R^T x_e - X_e)^T K_e (R^T x_e - X_e) (the rotation's variation drops out), which the
// tests check by finite differences; R K_e R^T ("warped stiffness") is its Jacobian in any rigidly
// moved rest configuration.
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>
#include <vector>

namespace handson {

using Mat12 = Eigen::Matrix<double, 12, 12>;
using Vec12 = Eigen::Matrix<double, 12, 1>;

/// Isotropic linear elastic stiffness of a tet with rest corners X (12x12, corner-major xyz).
/// E in Pa (any consistent unit), nu in [0, 0.5). Degenerate tets give a zero matrix.
Mat12 tetStiffness(const std::array<Eigen::Vector3d, 4>& X, double youngs, double poisson);

/// The rotation of polar(F) for any F, inverted (det F < 0) and degenerate ones included: from the
/// SVD F = U S V^T with the sign of the smallest singular direction flipped when det(U V^T) < 0,
/// so the result is always a proper rotation (det +1) and the element pushes back out of inversion.
Eigen::Matrix3d polarRotation(const Eigen::Matrix3d& F);

/// polarRotation(F) by Newton's iteration on the rotation, warm-started from `q` (the last answer
/// for this element; identity the first time) and left there: for a rotation R with S = R^T F, the
/// update R <- R exp([w]) with w = 2 (tr(S) I - sym S)^-1 axial(skew S) makes R^T F symmetric to
/// first order, so it converges quadratically (a frame's small change: 1-2 steps, against 5-8
/// inverse-and-scale steps of polarRotation). Stops after a step with |w| < `stepTolerance` rad:
/// what is left is O(|w|^2), so the default 1e-5 leaves < 1e-10 rad. An iteration that calls it
/// again from the same q each time it moves x may pass a larger tolerance (one step a call: the
/// rotation keeps converging with x, and is exact at x's fixed point). Inverted or nearly
/// degenerate F (det F <= 0, or tr(S) I - sym S not positive definite), or no convergence in 8
/// steps: falls back to polarRotation(F) - the same rotation either way.
Eigen::Matrix3d polarRotationWarm(const Eigen::Matrix3d& F, Eigen::Quaterniond& q, double stepTolerance = 1e-5);

/// Deformation gradient of a tet: rest corners X, current corners x.
Eigen::Matrix3d deformationGradient(const std::array<Eigen::Vector3d, 4>& X, const std::array<Eigen::Vector3d, 4>& x);

/// Block-diagonal rotation diag(R, R, R, R).
Mat12 blockRotation(const Eigen::Matrix3d& R);

/// Corotational elastic force on the 4 corners (12 vector) and energy.
Vec12 corotationalForce(const Mat12& K, const std::array<Eigen::Vector3d, 4>& X, const std::array<Eigen::Vector3d, 4>& x, double* energy = nullptr);

/// Exact Jacobian of minus the corotational force (the energy's Hessian), with the rotation's
/// variation: dR = R [w]x, w = 2 (tr(S) I - S)^-1 axial(skew(R^T dF)), S = R^T F. Where tr(S) I - S
/// is near singular (two singular values summing to ~0, at the inversion boundary) the rotation
/// terms are dropped (warped stiffness). If `projectSpd`, negative eigenvalues are clamped to zero
/// so the assembled matrix stays positive definite (projected Newton).
Mat12 corotationalHessian(const Mat12& K, const std::array<Eigen::Vector3d, 4>& X, const std::array<Eigen::Vector3d, 4>& x, bool projectSpd);

/// The 4 corner positions of tet `tet` taken from a per-node array.
inline std::array<Eigen::Vector3d, 4> tetCorners(const std::array<int, 4>& tet, const std::vector<Eigen::Vector3d>& x) {
  return {x[std::size_t(tet[0])], x[std::size_t(tet[1])], x[std::size_t(tet[2])], x[std::size_t(tet[3])]};
}

/// [v]x, the cross-product matrix: [v]x u = v x u.
inline Eigen::Matrix3d crossMatrix(const Eigen::Vector3d& v) {
  Eigen::Matrix3d m;
  m << 0, -v.z(), v.y(), v.z(), 0, -v.x(), -v.y(), v.x(), 0;
  return m;
}

/// axial(skew(A)): the vector a with (A - A^T) / 2 = [a]x.
inline Eigen::Vector3d axialOfSkew(const Eigen::Matrix3d& A) { return 0.5 * Eigen::Vector3d(A(2, 1) - A(1, 2), A(0, 2) - A(2, 0), A(1, 0) - A(0, 1)); }

/// Stacks 4 points into a 12 vector.
Vec12 stack(const std::array<Eigen::Vector3d, 4>& p);

}  // namespace handson
