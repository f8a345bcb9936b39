#pragma once
// The sparse direct solver behind the simulation: CHOLMOD's supernodal Cholesky (SuiteSparse, with
// METIS ordering) through Eigen's wrapper. Eigen's own SimplicialLLT is 10-50x slower on the fine
// 3D meshes (its fill-reducing AMD ordering and simplicial factorization), and the fine reference
// is refactorized every warped-stiffness iteration. Symbolic analysis once per sparsity pattern.
#include <Eigen/CholmodSupport>
#include <Eigen/SparseCore>

namespace handson {

using SparseMatrix = Eigen::SparseMatrix<double, Eigen::ColMajor, int>;
using DirectSolver = Eigen::CholmodSupernodalLLT<SparseMatrix, Eigen::Lower>;

}  // namespace handson
