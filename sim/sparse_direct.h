#pragma once
// The sparse direct solver of the fine reference: CHOLMOD's supernodal Cholesky (SuiteSparse, with
// METIS ordering) through Eigen's wrapper. Eigen's own SimplicialLLT is 10-50x slower on the fine
// 3D meshes (its fill-reducing AMD ordering and simplicial factorization), and the fine reference
// is refactorized every Newton iteration. Symbolic analysis once per sparsity pattern. CHOLMOD's
// supernodal kernels are dense BLAS calls: the Makefile installs OpenBLAS (libopenblas0-pthread),
// which Debian's alternatives then use for libblas.so.3 instead of the reference BLAS (measured:
// the fine solve of 36,864 tets 7.6 s -> 4.1 s on this 2-core machine; more on larger meshes).
#include <Eigen/CholmodSupport>
#include <Eigen/SparseCore>

namespace handson {

using SparseMatrix = Eigen::SparseMatrix<double, Eigen::ColMajor, int>;
using DirectSolver = Eigen::CholmodSupernodalLLT<SparseMatrix, Eigen::Lower>;

}  // namespace handson
