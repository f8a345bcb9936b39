#pragma once
// The hyperelastic fine reference (docs/tissue-physics.md, "Where the linear material stops
// holding"): compressible Neo-Hookean tets,
//   psi(F) = mu/2 (tr(F^T F) - 3) - mu ln J + lambda/2 (ln J)^2,   J = det F,
// with the Lame parameters of the tet's Young's modulus and Poisson ratio (at small strain it is the
// linear material the corotational model uses). Per tet, F = D_s G with G = D_m^-1 (3x3; D_m, D_s the
// rest and current edge matrices [x1-x0, x2-x0, x3-x0]), energy V psi(F), and
//   first Piola-Kirchhoff stress  P = mu (F - F^-T) + lambda ln J F^-T,
//   corner forces                 f_a = -V P g_a   (g_a = row a-1 of G for a = 1..3, g_0 = -sum),
//   stress differential           dP = mu dF + (mu - lambda ln J) F^-T dF^T F^-T + lambda tr(F^-1 dF) F^-T,
// so the 12x12 Hessian's column (b, c) is V [dP(dF = e_c g_b^T) g_a]_a. An inverted or flat tet
// (J <= 0) has infinite energy: the solver's line search never accepts one.
#include <array>
#include <limits>
#include <vector>

#include "sim/fem.h"
#include "sim/base/progress.h"
#include "sim/static_solver.h"
#include "sim/tet_mesh.h"

namespace handson {

struct NeoHookeanTet {
  Eigen::Matrix3d G = Eigen::Matrix3d::Zero();  ///< D_m^-1 (zero for a degenerate tet: no energy)
  double V = 0, lambda = 0, mu = 0;
};

/// The tet's rest data from its corners and material (E > 0 or 0 for no stiffness, 0 <= nu < 0.5).
NeoHookeanTet neoHookeanTet(const std::array<Eigen::Vector3d, 4>& X, double youngs, double poisson);
/// Per tet of `mesh` from per-tet materials. Throws handson::Error on wrong sizes.
std::vector<NeoHookeanTet> neoHookeanTets(const TetMesh& mesh, const std::vector<double>& youngs, const std::vector<double>& poisson);

/// V psi(F) at corners x; +infinity where J <= 0.
double neoHookeanEnergy(const NeoHookeanTet& t, const std::array<Eigen::Vector3d, 4>& x);
/// The corner forces -dE/dx (12, corner-major xyz). J must be > 0.
Vec12 neoHookeanForce(const NeoHookeanTet& t, const std::array<Eigen::Vector3d, 4>& x);
/// d^2E/dx^2 (12x12); with `projectSpd`, negative eigenvalues clamped to zero. J must be > 0.
Mat12 neoHookeanHessian(const NeoHookeanTet& t, const std::array<Eigen::Vector3d, 4>& x, bool projectSpd);

/// Static equilibrium of the Neo-Hookean mesh (plus options.springs), by projected Newton with
/// backtracking on the energy, from x0 (Dirichlet nodes, fixed != 0, at their values; the free ones
/// where the solve starts: it must be uninverted, so a large motion starts from the corotational
/// answer). Throws handson::Error when x0 inverts a tet, or as solveStatic does.
StaticSolveResult solveStaticNeoHookean(const TetMesh& mesh, const std::vector<NeoHookeanTet>& tets, const std::vector<char>& fixed,
                                        const std::vector<Eigen::Vector3d>& x0, const StaticSolveOptions& options = {});

}  // namespace handson
