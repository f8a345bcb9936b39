// The corotational coarsening against the fine reference, on the phantom and on simple boxes.
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <Eigen/SparseCholesky>
#include <Eigen/SparseCore>
#include <cstdio>
#include <functional>
#include <limits>
#include <map>
#include <random>
#include <set>
#include <sstream>

#include "sim/coarsening.h"
#include "sim/base/error.h"
#include "sim/phantom.h"
#include "sim/sim_scene.h"
#include "sim/static_solver.h"
#include "sim/two_level.h"

using namespace handson;

namespace {

std::vector<SimHandle> kidneyHandle(const Phantom& p) {
  SimHandle h;
  h.voxels = voxelsLabelled(p.labels, label::kKidneyRight);
  return {h};
}

}  // namespace

TEST(Coarsening, KidneyMoved10mmAndRotated30DegMatchesTheFineReference) {
  PhantomOptions po;
  po.spacingMm = 4.0;
  const Phantom p = makePhantom(po);
  const auto handles = kidneyHandle(p);
  SimSettings s;
  s.coarseTets = 600;
  s.fineTets = 600 * 64;
  s.interface = SimSettings::Interface::Glued;  // the measured figures below are glued (sliding: test_sliding_interface.cpp)
  const SimScene sc = buildSimScene(p.ct, handles, s);
  const std::vector<RigidTransform> T = {RigidTransform::about(sc.handleCentroid[0], Eigen::Vector3d(0, 0, 30.0 * M_PI / 180), Eigen::Vector3d(10, 0, 0))};
  const auto fine = solveFineStatic(sc, T);
  ASSERT_TRUE(fine.converged);
  CoarseModel model(sc.meshes, sc.fineK, sc.constraints);
  auto xc = model.restState();
  const auto st = model.solve(T, xc, 50);
  ASSERT_TRUE(st.converged);
  const auto coarse = model.reconstruct(T, xc);
  const auto plain = plainCoarseSolve(sc.meshes, sc.youngs, sc.poisson, sc.constraints, T);
  const auto ec = compareDeformation(sc, T, coarse, fine.x), ep = compareDeformation(sc, T, plain, fine.x);
  std::printf("coarse %zu tets, fine %zu tets; fine: %d iterations; coarse: %d iterations\n", sc.meshes.coarse.tets.size(), sc.meshes.fine.tets.size(),
              fine.iterations, st.iterations);
  std::printf("handle motion %.2f mm; coarsened: RMS %.4f max %.4f L2 %.4f; plain: RMS %.4f max %.4f L2 %.4f\n", ec.handleMotionMm, ec.rmsOfMotion,
              ec.maxOfMotion, ec.relativeL2, ep.rmsOfMotion, ep.maxOfMotion, ep.relativeL2);
  // The condensed coarse model alone is no better than plain coarse FEM on this scene (bone at
  // 15 GPa next to 3-8 kPa soft tissue locks its linear element boundaries; docs/simulation-model.md): measured,
  // not asserted beyond sanity. The two-level refinement is what meets the accuracy bounds.
  EXPECT_LT(ec.rmsOfMotion, 0.6);
  // The linearizations from the coarse answer: the analytic matrix-free one (the default), the
  // warped stiffness alone and the projected exact Hessian (the baseline).
  std::vector<double> rms, rmsWarped, rmsProjected;
  for (const RefineMethod method : {RefineMethod::Analytic, RefineMethod::Warped, RefineMethod::Projected}) {
    const FineRefiner refiner(model, sc.fineK, sc.youngs, sc.poisson, RefineOptions{method, 0});
    auto x = coarse;
    auto& out = method == RefineMethod::Analytic ? rms : method == RefineMethod::Warped ? rmsWarped : rmsProjected;
    for (int frame = 0; frame < 4; ++frame) {
      refiner.step(T, xc, x, 10);
      out.push_back(compareDeformation(sc, T, x, fine.x).rmsOfMotion);
      std::printf("refined frame %d (%s, 10 PCG iterations): RMS %.4f\n", frame + 1, refineMethodName(method), out.back());
    }
  }
  // Measured after two and four frames: analytic 0.021 and 0.0018, warped 0.042 and 0.0086, projected
  // 0.022 and 0.0021 (with the default coarse solve's coarse correction, the rotated rest factor).
  // Bounds with margin for compiler and BLAS roundoff differences.
  EXPECT_LT(rms[1], 0.05) << "<= 5 % of the handle's motion after two frames";
  EXPECT_LT(rms[3], 0.005) << "<= 0.5 % after four";
  EXPECT_LT(rmsWarped[1], 0.10);
  EXPECT_LT(rmsWarped[3], 0.02);
  EXPECT_LT(rmsProjected[1], 0.05);
  EXPECT_LT(rmsProjected[3], 0.005);
  EXPECT_LT(3 * rms[3], ep.rmsOfMotion) << "at least 3x better than plain coarse FEM";

  // Graded cells (the cells holding kidney nodes halved, hanging nodes tied to the whole cells)
  // against the same reference, alone and as the coarse level of the refinement.
  CoarseModel graded(sc.meshes, sc.fineK, sc.constraints, {}, CoarseElement::Cell, CoarseGrading{0.0});
  auto xg = graded.restState();
  const auto sg = graded.solve(T, xg, 5000);
  ASSERT_TRUE(sg.converged);
  const auto coarseGraded = graded.reconstruct(T, xg);
  const auto eg = compareDeformation(sc, T, coarseGraded, fine.x);
  const FineRefiner gradedRefiner(graded, sc.fineK, sc.youngs, sc.poisson, RefineOptions{RefineMethod::Analytic, 0});
  auto xr = coarseGraded;
  for (int frame = 0; frame < 2; ++frame) gradedRefiner.step(T, xg, xr, 10);
  const double rmsGraded2 = compareDeformation(sc, T, xr, fine.x).rmsOfMotion;
  std::printf("graded cells: %zu elements, %zu hanging nodes, %d iterations; RMS %.4f max %.4f; refined twice %.4f\n", graded.elementCount(),
              graded.hangingNodeCount(), sg.iterations, eg.rmsOfMotion, eg.maxOfMotion, rmsGraded2);
  // Measured: 250 cells (127 hanging nodes), RMS 0.2248 against the uniform cells' 0.2304 (on this
  // coarse scene a cell or two spans kidney to fixed face; bench sim measures the default scene),
  // 0.024 after two refinement frames against 0.021. Deterministic; the bounds hold the ordering
  // and the refinement's bound.
  EXPECT_LT(eg.rmsOfMotion, ec.rmsOfMotion);
  EXPECT_LT(rmsGraded2, 0.05) << "<= 5 % of the handle's motion after two frames, as with the uniform cells";
}

namespace {

// A box with a random 1000x stiffness contrast, fixed faces and a ball-shaped handle moved by a tiny
// rigid motion (the corotational model is linear there).
struct GalerkinBox {
  NestedMeshes nm = buildNestedMeshes({0, 0, 0}, {40, 30, 30}, 216, 64);
  std::vector<Mat12> K;
  FineConstraints c;
  double d = 1e-4;
  std::vector<RigidTransform> T;
  GalerkinBox() {
    const TetMesh& F = nm.fine;
    std::mt19937 rng(11);
    std::uniform_real_distribution<double> u01(0.0, 1.0);
    std::vector<double> E(F.tets.size()), nu(F.tets.size(), 0.4);
    for (auto& e : E) e = u01(rng) < 0.2 ? 1000.0 : 1.0;  // 1000x contrast
    K = tetStiffnesses(F, E, nu);
    c.handleCount = 1;
    c.handleOf.assign(F.nodes.size(), -1);
    c.fixed.assign(F.nodes.size(), 0);
    for (std::size_t n = 0; n < F.nodes.size(); ++n) {
      const auto& p = F.nodes[n];
      if (p.x() < 1e-9 || p.y() < 1e-9 || p.z() < 1e-9 || p.x() > 40 - 1e-9 || p.y() > 30 - 1e-9 || p.z() > 30 - 1e-9) c.fixed[n] = 1;
      else if ((p - Eigen::Vector3d(17, 14, 16)).norm() < 7.0) c.handleOf[n] = 0;  // a ball, not aligned with the coarse elements
    }
    T = {RigidTransform::about({17, 14, 16}, Eigen::Vector3d(0, 0, d / 7.0), Eigen::Vector3d(d, -d, 0.5 * d))};
  }
};

// The minimiser of the fine energy 1/2 u^T K u over u = Tm q + uD: (Tm^T K Tm) q = -Tm^T K uD, by a
// sparse Cholesky (LDL^T) of the reduced matrix. Returns u; empty if the factorization fails.
Eigen::VectorXd galerkinMinimiser(const GalerkinBox& box, const Eigen::SparseMatrix<double>& Tm, const Eigen::VectorXd& uD) {
  const TetMesh& F = box.nm.fine;
  const int nd = 3 * int(F.nodes.size());
  std::vector<Eigen::Triplet<double>> trip;
  for (std::size_t t = 0; t < F.tets.size(); ++t)
    for (int a = 0; a < 4; ++a)
      for (int b = 0; b < 4; ++b)
        for (int r = 0; r < 3; ++r)
          for (int cc = 0; cc < 3; ++cc) trip.emplace_back(3 * F.tets[t][std::size_t(a)] + r, 3 * F.tets[t][std::size_t(b)] + cc, box.K[t](3 * a + r, 3 * b + cc));
  Eigen::SparseMatrix<double> Kf(nd, nd);
  Kf.setFromTriplets(trip.begin(), trip.end());
  const Eigen::SparseMatrix<double> A = Eigen::SparseMatrix<double>(Tm.transpose()) * (Kf * Tm);
  const Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> ldlt(A);
  if (ldlt.info() != Eigen::Success) return {};
  return Tm * ldlt.solve(-(Tm.transpose() * (Kf * uD))) + uD;
}

// The largest difference between a model's fine positions xm and the displacements ub, and the largest
// of ub (mm).
std::pair<double, double> largestDifference(const std::vector<Eigen::Vector3d>& xm, const TetMesh& F, const Eigen::VectorXd& ub) {
  double err = 0, scale = 0;
  for (std::size_t n = 0; n < F.nodes.size(); ++n) {
    err = std::max(err, (xm[n] - F.nodes[n] - ub.segment<3>(3 * Eigen::Index(n))).norm());
    scale = std::max(scale, ub.segment<3>(3 * Eigen::Index(n)).norm());
  }
  return {err, scale};
}

class CoarseningKinds : public ::testing::TestWithParam<CoarseElement> {};
INSTANTIATE_TEST_SUITE_P(BothElementKinds, CoarseningKinds, ::testing::Values(CoarseElement::Cell, CoarseElement::Tet),
                         [](const auto& p) { return std::string(coarseElementName(p.param)); });

}  // namespace

TEST_P(CoarseningKinds, InTheLinearRegimeItIsTheGalerkinProjectionOntoItsSubspace) {
  // Brute force, independent of the per-element condensation: minimise the fine energy 1/2 u^T K u
  // over displacements with the handle nodes prescribed, nodes on the coarse elements' faces and
  // edges following the face's corners linearly (the coarse Kuhn tet's barycentric weights), corners
  // and interior nodes free. For tet elements every coarse tet face is such a face; for cell
  // elements only the grid cells' faces (the cells' internal diagonal faces are interior). The
  // coarse model (element condensation, then the coarse solve and the reconstruction) must give the
  // same displacements.
  const GalerkinBox box;
  const NestedMeshes& nm = box.nm;
  const TetMesh& F = nm.fine;
  const auto& K = box.K;
  const auto& c = box.c;
  const auto& T = box.T;
  const double d = box.d;
  CoarseModel model(nm, K, c, {}, GetParam());
  auto xc = model.restState();
  ASSERT_TRUE(model.solve(T, xc, 20, 1e-8).converged);
  const auto xm = model.reconstruct(T, xc);

  // The brute-force subspace: q = (coarse corner dofs, interior node dofs).
  const std::size_t nf = F.nodes.size();
  std::vector<int> cornerOf(nf, -1);
  for (std::size_t v = 0; v < nm.coarse.nodes.size(); ++v) cornerOf[std::size_t(nm.coarseNodeInFine[v])] = int(v);
  std::vector<int> qIndex(nf, -1);
  int nq = 0;
  std::vector<std::pair<int, Eigen::Vector4d>> onFace(nf, {-1, Eigen::Vector4d::Zero()});
  for (std::size_t n = 0; n < nf; ++n) {
    if (c.fixed[n] || c.handleOf[n] >= 0) continue;
    if (cornerOf[n] >= 0) {
      qIndex[n] = (nq += 3) - 3;
      continue;
    }
    Eigen::Vector4d lam;
    const int t = nm.coarseGrid.locate(F.nodes[n], &lam);
    bool face = lam.minCoeff() < 1e-9;
    if (GetParam() == CoarseElement::Cell) {
      // On a grid plane: some coordinate is a whole number of cells.
      const Eigen::Vector3d g = (F.nodes[n] - nm.coarseGrid.origin()).cwiseQuotient(nm.coarseGrid.cell());
      face = ((g - g.array().round().matrix()).array().abs() < 1e-9).any();
    }
    if (face) onFace[n] = {t, lam};
    else qIndex[n] = (nq += 3) - 3;
  }
  const int nd = 3 * int(nf);
  // The subspace map u = Tm q + uD (sparse: a node follows itself or the corners of its face).
  std::vector<Eigen::Triplet<double>> tt;
  Eigen::VectorXd uD = Eigen::VectorXd::Zero(nd);
  auto identity3 = [&](std::size_t n, int col, double w) {
    for (int r = 0; r < 3; ++r) tt.emplace_back(3 * int(n) + r, col + r, w);  // duplicates add up
  };
  for (std::size_t n = 0; n < nf; ++n) {
    if (c.handleOf[n] >= 0 && !c.fixed[n]) uD.segment<3>(3 * Eigen::Index(n)) = T[0].apply(F.nodes[n]) - F.nodes[n];
    if (qIndex[n] >= 0) identity3(n, qIndex[n], 1.0);
    if (onFace[n].first >= 0 && !c.fixed[n])
      for (int k = 0; k < 4; ++k) {
        const int corner = nm.coarseNodeInFine[std::size_t(nm.coarse.tets[std::size_t(onFace[n].first)][std::size_t(k)])];
        if (qIndex[std::size_t(corner)] >= 0) identity3(n, qIndex[std::size_t(corner)], onFace[n].second[k]);
        else if (c.handleOf[std::size_t(corner)] >= 0 && !c.fixed[std::size_t(corner)])
          uD.segment<3>(3 * Eigen::Index(n)) += onFace[n].second[k] * (T[0].apply(F.nodes[std::size_t(corner)]) - F.nodes[std::size_t(corner)]);
      }
  }
  Eigen::SparseMatrix<double> Tm(nd, nq);
  Tm.setFromTriplets(tt.begin(), tt.end());
  const Eigen::VectorXd ub = galerkinMinimiser(box, Tm, uD);
  ASSERT_EQ(ub.size(), nd);
  const auto [err, scale] = largestDifference(xm, F, ub);
  double ec = 0, eb = 0, ei = 0;
  for (std::size_t n = 0; n < nf; ++n) {
    const double e = (xm[n] - F.nodes[n] - ub.segment<3>(3 * Eigen::Index(n))).norm();
    if (cornerOf[n] >= 0) ec = std::max(ec, e);
    else if (onFace[n].first >= 0) eb = std::max(eb, e);
    else if (qIndex[n] >= 0) ei = std::max(ei, e);
  }
  EXPECT_GT(ec, 0.0);  // free corners, face and interior nodes all took part
  EXPECT_GT(eb, 0.0);
  EXPECT_GT(ei, 0.0);
  EXPECT_GT(scale, 0.5 * d);
  // Differences: the corotational model's second-order terms, relative size ~ motion / element size
  // (1e-4 mm / 10 mm), and roundoff (K spans 1e3).
  EXPECT_LT(err, 1e-4 * scale) << "max difference " << err << " mm of " << scale;
}

TEST(Coarsening, CellElementsHoldTheTetSubspaceSoTheirEnergyLiesBetweenTheTetsAndTheFineMinimum) {
  // A cell element's space (Kuhn-linear faces, free interior) contains the tet elements' space (the
  // same faces, plus the cells' diagonal faces held linear), and both lie in the fine space: in the
  // linear regime the Galerkin answers' elastic energies (the minimum over each space with the same
  // prescribed nodes) are ordered fine <= cell <= tet, and the errors' energy norms likewise.
  const GalerkinBox box;
  std::vector<char> dir;
  const auto x0 = prescribedPositions(box.nm.fine, box.c, box.T, &dir);
  StaticSolveOptions so;
  so.tolerance = 1e-10;
  const auto fine = solveStatic(box.nm.fine, box.K, dir, x0, so);
  ASSERT_TRUE(fine.converged);
  double energy[2];
  for (CoarseElement kind : {CoarseElement::Cell, CoarseElement::Tet}) {
    CoarseModel model(box.nm, box.K, box.c, {}, kind);
    auto xc = model.restState();
    ASSERT_TRUE(model.solve(box.T, xc, 20, 1e-8).converged);
    energy[kind == CoarseElement::Tet] = elasticEnergy(box.nm.fine, box.K, model.reconstruct(box.T, xc));
  }
  const double ef = elasticEnergy(box.nm.fine, box.K, fine.x);
  std::printf("elastic energy: fine %.6e, cell elements %.6e, tet elements %.6e\n", ef, energy[0], energy[1]);
  // Relative slack 1e-6: the corotational model's second-order terms are ~1e-5 of the motion
  // (motion / element size), their effect on the energy ~1e-10 relative; roundoff ~1e-12.
  EXPECT_LE(ef, energy[0] * (1 + 1e-6));
  EXPECT_LT(energy[0], energy[1]) << "strictly: the cells free their diagonal faces";
}

TEST(Coarsening, GradedCellsAreTheGalerkinProjectionOntoTheirConformingSubspace) {
  // Graded cells (CoarseGrading): the cells within reach of the handle ball split into 8 half-size
  // cells. Brute force, independent of the model's leaves, hanging nodes and condensation: the leaves
  // are re-derived from the rule (a cell splits when its closed box holds a handle node), and the
  // subspace is: a leaf corner is free unless it lies on a face or edge of a whole (unsplit) cell,
  // where it follows that cell's Kuhn interpolation; any other node on a leaf's boundary follows the
  // LARGEST leaf it lies on (so on a face between a whole and a half-size cell it follows the whole
  // cell - equal to the half-size cell's interpolation only if the model conforms); the rest is free.
  const GalerkinBox box;
  CoarseModel model(box.nm, box.K, box.c, {}, CoarseElement::Cell, CoarseGrading{0.0});
  const NestedMeshes& nm = box.nm;
  const TetMesh& F = nm.fine;
  const auto& c = box.c;
  const auto& T = box.T;
  ASSERT_TRUE(model.graded());
  EXPECT_GT(model.hangingNodeCount(), 0u) << "the scene must have whole cells beside split ones";
  auto xc = model.restState();
  ASSERT_TRUE(model.solve(T, xc, 200, 1e-9).converged);
  const auto xm = model.reconstruct(T, xc);

  const KuhnGrid& G = nm.coarseGrid;
  struct Leaf { Eigen::Vector3d lo, size; };
  std::vector<Leaf> leaves;
  std::vector<char> whole;
  const double eps = 1e-9;
  auto inBox = [&](const Eigen::Vector3d& p, const Eigen::Vector3d& lo, const Eigen::Vector3d& size) {
    return ((p - lo).array() >= -eps).all() && ((p - lo - size).array() <= eps).all();
  };
  for (int k = 0; k < G.cells().z(); ++k)
    for (int j = 0; j < G.cells().y(); ++j)
      for (int i = 0; i < G.cells().x(); ++i) {
        const Eigen::Vector3d lo = G.origin() + G.cell().cwiseProduct(Eigen::Vector3d(i, j, k));
        bool split = false;
        for (std::size_t n = 0; n < F.nodes.size() && !split; ++n) split = c.handleOf[n] >= 0 && !c.fixed[n] && inBox(F.nodes[n], lo, G.cell());
        if (!split) {
          leaves.push_back({lo, G.cell()});
          whole.push_back(1);
        } else {
          for (int q = 0; q < 8; ++q) leaves.push_back({lo + 0.5 * G.cell().cwiseProduct(Eigen::Vector3d(q & 1, q >> 1 & 1, q >> 2 & 1)), 0.5 * G.cell()});
          whole.resize(leaves.size(), 0);
        }
      }
  auto cornerPos = [&](const Leaf& L, int q) -> Eigen::Vector3d { return L.lo + L.size.cwiseProduct(Eigen::Vector3d(q & 1, q >> 1 & 1, q >> 2 & 1)); };
  auto isCorner = [&](const Leaf& L, const Eigen::Vector3d& p) {
    for (int q = 0; q < 8; ++q)
      if ((cornerPos(L, q) - p).norm() < 1e-6) return true;
    return false;
  };
  auto onBoundary = [&](const Leaf& L, const Eigen::Vector3d& p) {
    if (!inBox(p, L.lo, L.size)) return false;
    const Eigen::Vector3d a = (p - L.lo).cwiseQuotient(L.size);
    return ((a.array().abs() < 1e-9) || ((a.array() - 1).abs() < 1e-9)).any();
  };
  // Fine node index of each position (the leaves' corners are fine nodes).
  std::map<std::array<long, 3>, int> nodeAt;
  auto key = [](const Eigen::Vector3d& p) { return std::array<long, 3>{std::lround(p.x() * 1e4), std::lround(p.y() * 1e4), std::lround(p.z() * 1e4)}; };
  for (std::size_t n = 0; n < F.nodes.size(); ++n) nodeAt[key(F.nodes[n])] = int(n);
  std::set<int> leafCorners;
  for (const Leaf& L : leaves)
    for (int q = 0; q < 8; ++q) leafCorners.insert(nodeAt.at(key(cornerPos(L, q))));
  // Per fine node: a free q index, or a list of (fine node, weight) it follows.
  const std::size_t nf = F.nodes.size();
  std::vector<int> qIndex(nf, -1);
  std::vector<std::vector<std::pair<int, double>>> follows(nf);
  int nq = 0;
  auto kuhn = [&](const Leaf& L, const Eigen::Vector3d& p) {
    const KuhnGrid cube(L.lo, L.size, Eigen::Vector3i::Ones());
    const Eigen::Matrix<double, 8, 1> w = cube.cellWeights(0, p);
    std::vector<std::pair<int, double>> out;
    for (int q = 0; q < 8; ++q)
      if (w[q] > 1e-12) out.push_back({nodeAt.at(key(cornerPos(L, q))), w[q]});
    return out;
  };
  for (std::size_t n = 0; n < nf; ++n) {
    if (c.fixed[n] || c.handleOf[n] >= 0) continue;
    const Eigen::Vector3d& p = F.nodes[n];
    if (leafCorners.count(int(n))) {
      for (std::size_t l = 0; l < leaves.size() && follows[n].empty(); ++l)
        if (whole[l] && onBoundary(leaves[l], p) && !isCorner(leaves[l], p)) follows[n] = kuhn(leaves[l], p);
      if (follows[n].empty()) qIndex[n] = (nq += 3) - 3;
      continue;
    }
    int best = -1;
    for (std::size_t l = 0; l < leaves.size(); ++l)
      if (onBoundary(leaves[l], p) && (best < 0 || leaves[l].size.x() > leaves[std::size_t(best)].size.x())) best = int(l);
    if (best >= 0) follows[n] = kuhn(leaves[std::size_t(best)], p);
    else qIndex[n] = (nq += 3) - 3;
  }
  // u = Tm q + uD; a followed node that itself follows (a hanging corner) is expanded once more.
  const int nd = 3 * int(nf);
  std::vector<Eigen::Triplet<double>> tt;
  Eigen::VectorXd uD = Eigen::VectorXd::Zero(nd);
  std::function<void(int, int, double)> addTo = [&](int row, int node, double w) {
    const auto m = std::size_t(node);
    if (qIndex[m] >= 0)
      for (int r = 0; r < 3; ++r) tt.emplace_back(3 * row + r, qIndex[m] + r, w);
    else if (c.handleOf[m] >= 0 && !c.fixed[m])
      uD.segment<3>(3 * row) += w * (T[0].apply(F.nodes[m]) - F.nodes[m]);
    else
      for (const auto& [k, wk] : follows[m]) addTo(row, k, w * wk);
  };
  for (std::size_t n = 0; n < nf; ++n) {
    if (c.fixed[n]) continue;
    if (c.handleOf[n] >= 0 || qIndex[n] >= 0) addTo(int(n), int(n), 1.0);
    else
      for (const auto& [k, w] : follows[n]) addTo(int(n), k, w);
  }
  Eigen::SparseMatrix<double> Tm(nd, nq);
  Tm.setFromTriplets(tt.begin(), tt.end());
  const Eigen::VectorXd ub = galerkinMinimiser(box, Tm, uD);
  ASSERT_EQ(ub.size(), nd);
  const auto [err, scale] = largestDifference(xm, F, ub);
  EXPECT_GT(scale, 0.5 * box.d);
  // As for the uniform cells: the corotational model's second-order terms (motion / element size,
  // 1e-4 mm / 5 mm) and roundoff.
  EXPECT_LT(err, 1e-4 * scale) << "max difference " << err << " mm of " << scale;
}

TEST(Coarsening, GradedCellsRefuseWhatTheyCannotDo) {
  const GalerkinBox box;
  CoarseGrading grading;
  grading.splitWithinCells = 1.0;
  EXPECT_THROW(CoarseModel(box.nm, box.K, box.c, {}, CoarseElement::Tet, grading), Error);
  grading.splitWithinCells = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW(CoarseModel(box.nm, box.K, box.c, {}, CoarseElement::Cell, grading), Error);
  // An odd number of fine cells per coarse cell has no half-size cells on the fine grid.
  const NestedMeshes odd = buildNestedMeshes({0, 0, 0}, {40, 30, 30}, 216, 27);
  FineConstraints c;
  c.handleCount = 1;
  c.handleOf.assign(odd.fine.nodes.size(), -1);
  c.fixed.assign(odd.fine.nodes.size(), 0);
  c.handleOf[odd.fine.nodes.size() / 2] = 0;
  std::vector<double> E(odd.fine.tets.size(), 1.0), nu(odd.fine.tets.size(), 0.4);
  grading.splitWithinCells = 0.0;
  EXPECT_THROW(CoarseModel(odd, tetStiffnesses(odd.fine, E, nu), c, {}, CoarseElement::Cell, grading), Error);
  // The assembled baseline solver and the cache take the uniform grid only.
  CoarseModel model(box.nm, box.K, box.c, {}, CoarseElement::Cell, grading);
  model.setSolver(CoarseSolver::Assembled);
  auto x = model.restState();
  EXPECT_THROW(model.solve(box.T, x, 5), Error);
  std::ostringstream os;
  EXPECT_THROW(model.save(os), Error);
}

TEST(Coarsening, GradedProlongationIsTheModelsLinearizationAndRestrictionItsTranspose) {
  // The two-level solver's P (prolongAdd) must be the coarse model's own linearization at rest: the
  // fine displacement of a tiny coarse change c is reconstruct(rest + c) - rest, hanging nodes
  // following their masters; and restrictToCoarse must be P^T: r . (P c) = (P^T r) . c.
  const GalerkinBox box;
  CoarseModel model(box.nm, box.K, box.c, {}, CoarseElement::Cell, CoarseGrading{0.0});
  ASSERT_GT(model.hangingNodeCount(), 0u);
  const std::size_t nf = box.nm.fine.nodes.size();
  std::mt19937 rng(5);
  std::normal_distribution<double> g(0.0, 1.0);
  Eigen::VectorXd c(Eigen::Index(model.freeCoarseDofs()));
  for (Eigen::Index i = 0; i < c.size(); ++i) c[i] = g(rng);
  std::vector<Eigen::Vector3d> r(nf);
  for (auto& v : r) v = Eigen::Vector3d(g(rng), g(rng), g(rng));
  for (std::size_t n = 0; n < nf; ++n)
    if (box.c.fixed[n] || box.c.handleOf[n] >= 0) r[n].setZero();  // P^T ignores Dirichlet nodes
  const std::vector<Eigen::Matrix3d> R(model.elementCount(), Eigen::Matrix3d::Identity());
  std::vector<Eigen::Vector3d> pc(nf, Eigen::Vector3d::Zero());
  model.prolongAdd(c, R, pc);
  double lhs = 0;
  for (std::size_t n = 0; n < nf; ++n) lhs += r[n].dot(pc[n]);
  const double rhs = model.restrictToCoarse(r, R).dot(c);
  EXPECT_NEAR(lhs, rhs, 1e-10 * std::abs(lhs));
  // The linearization: the handles at rest, the free coarse nodes moved by eps c, hanging ones
  // re-expanded by a solve with no iterations (pinDirichlet does it).
  const double eps = 1e-7;
  auto x = model.restState();
  int k = 0;
  for (std::size_t v = 0; v < x.size(); ++v)
    if (model.coarseRole()[v] == -1) x[v] += eps * c.segment<3>(3 * k++);
  const std::vector<RigidTransform> rest{RigidTransform{}};
  model.solve(rest, x, 0);
  const auto xf = model.reconstruct(rest, x);
  double err = 0, scale = 0;
  for (std::size_t n = 0; n < nf; ++n) {
    err = std::max(err, ((xf[n] - box.nm.fine.nodes[n]) / eps - pc[n]).norm());
    scale = std::max(scale, pc[n].norm());
  }
  // Second-order terms eps * |c| / cell relative, roundoff 1e-16 / eps.
  EXPECT_LT(err, 1e-5 * scale) << err << " of " << scale;
}
