#pragma once
// Corotational coarsening (docs/simulation-model.md, the coarse model; solvers in docs/simulation.md).
//
// Per coarse element e, its fine nodes split into the n corners c, handle nodes D (not corners),
// boundary nodes b (on e's faces and edges: u_b = N_b u_c) and interior nodes I, condensed:
// u_I = H u_c + G u_D. The coarse element keeps K_h = Phi_c^T K Phi_c and K_hd = Phi_c^T K Phi_D,
// and for each handle k touching it the 3n x 9 block A_k = K_hd^k Reshape(X_D^k) and the 3n x 3 block
// B_k = ColumnAdd(K_hd^k), so a frame costs the same whatever the handle's fine node count:
//   f_c = -R_c [K_h (R_c^T x_c - X_c) + sum_k (A_k vec(R_c^T R_k - I) + B_k R_c^T t_k)].
// Interior fine nodes are rebuilt from per-node data (H_f and, per handle, G_f's 3x9 and 3x3 blocks).
//
// Two kinds of coarse element over the same coarse nodes (CoarseElement):
//  - Tet: each coarse Kuhn tet (n = 4, the spec's formulation). Its flat faces fix its volume by its
//    4 corners: one volume constraint per tet, six per grid cell, which locks near-incompressible
//    tissue (nu = 0.45) the way linear tets do.
//  - Cell: each grid cell, the union of its 6 Kuhn tets (n = 8). Its faces still follow the Kuhn
//    triangulation linearly (N_b = the coarse tet's barycentric weights, so neighbours conform), but
//    the cell's internal diagonal faces are condensed with the interior: one volume constraint per
//    cell. Same coarse nodes and dofs; the rotation R_c is the polar rotation of the least-squares
//    affine fit of the corners (for a tet, the exact F = D_s D_m^-1).
#include <Eigen/Core>
#include <cstdint>
#include <iosfwd>
#include <memory>
#include <unordered_map>
#include <vector>

#include "sim/fem.h"
#include "sim/fine_interpolation.h"
#include "sim/base/progress.h"
#include "sim/rigid_transform.h"
#include "sim/sliding_interface.h"
#include "sim/sparse_direct.h"
#include <Eigen/SparseCholesky>
#include "sim/static_solver.h"
#include "sim/tet_mesh.h"

namespace handson {

struct HandleReaction;  // sim/handle_reaction.h

/// Dirichlet roles of the fine nodes.
struct FineConstraints {
  std::vector<int> handleOf;  ///< per fine node: handle index (0-based) or -1
  std::vector<char> fixed;    ///< per fine node: held at rest (the region's outer boundary)
  int handleCount = 0;
  /// Sliding interfaces (sim/sliding_interface.h): the handles' surface nodes, free (handleOf -1) and
  /// held to their handle's surface in the normal direction only. Empty: every interface is glued.
  std::vector<SlideNode> slide;
};

struct CoarseSolveStats {
  int iterations = 0, factorizations = 0;
  int pcgIterations = 0;    ///< CoarseSolver::Pcg: inner conjugate-gradient iterations, all together
  int andersonStalls = 0;   ///< CoarseSolver::Pcg: Anderson acceleration given up for the plain iteration (0 or 1)
  double lastUpdate = 0.0;  ///< largest coarse node update of the last iteration (mm)
  bool converged = false;
  double solveMs = 0.0;     ///< wall time of the solve (all of it), of which:
  double boundaryMs = 0.0;  ///< the rigid handles' boundary forces (the 3n x 9 / 3n x 3 blocks)
  double rotationMs = 0.0;  ///< the element rotations (and, Pcg, the preconditioner's node rotations)
  double productMs = 0.0;   ///< Assembled: assembling R K_h R^T; Pcg: the matrix-free residuals and products
  double factorMs = 0.0;    ///< sparse Cholesky factorizations
  double backSolveMs = 0.0; ///< triangular solves with the factor
};

/// The iteration cap of a one-off coarse answer (`deform`, the benchmarks), against a frame's few
/// iterations: such an answer is iterated to convergence (the phantom's kidney moved 10 mm, sliding:
/// 24 iterations; 50 had been the cap, and before the damping's recovery, coarse_pcg.cpp, it took 526).
constexpr int kOneOffSolveIterations = 5000;

/// How the Pcg solve iterates (docs/simulation.md, "pcg"; the defaults measured in results.md,
/// 2026-12-06, the second entry, and 2026-12-07, the sixth: a sliding kidney dragged 10 mm and
/// turned 30 degrees in ten frames of three iterations ends 4.1 % of its largest motion from
/// converged with these, 6.2 % without Anderson acceleration, 46 % with one nonlinear CG step an
/// iteration).
struct PcgOptions {
  /// Conjugate-gradient iterations on A(R) d = r per solve() iteration, restarted from d = 0 each
  /// time (1-16). 1 instead carries the directions over a call's iterations (nonlinear conjugate
  /// gradients): cheaper per iteration, and it stalls where element rotations vary sharply (a
  /// sliding interface).
  int cgIterations = 2;
  /// Refactorize the preconditioner at the current element rotations once an element has turned
  /// more than this from the rotations it was factorized at (degrees, 0-180; 0: never, the rest
  /// factor throughout).
  double refreshDeg = 10.0;
  /// ... and only from this iteration of a solve() call on (0-based): a frame's three iterations
  /// never pay for a factorization (~27 ms at the default mesh), a longer solve does (the phantom's
  /// sliding kidney from rest: 81 iterations against 143 with the rest factor throughout).
  int refreshFromIteration = 3;
  /// Anderson acceleration of the iteration (sim/anderson.h): secant pairs kept, 0-16 (0: the
  /// plain iteration with its damping, the earlier default). Uniform cells and tets only: graded
  /// cells keep the plain iteration (results.md, 2026-12-07, sixth entry).
  int andersonDepth = 3;
  bool operator==(const PcgOptions&) const = default;
};

enum class CoarseElement { Tet = 0, Cell = 1 };
const char* coarseElementName(CoarseElement e);

/// How CoarseModel::solve() iterates toward the same fixed point, f_c(x) = 0 (docs/simulation.md,
/// "The coarse solve"):
///  - Assembled (the baseline, kept for comparison): every iteration assembles the warped stiffness
///    sum R K_h R^T into a sparse matrix and steps x += A_f^-1 (b(R) - A(R) x), with A_f a Cholesky
///    factor of that matrix refactorized every third call and whenever the updates stop halving.
///  - Pcg (the default): no assembly. Each iteration takes the element rotations by a warm-started
///    Newton polar iteration, the residual element by element with fixed-size blocks, then a few
///    conjugate-gradient iterations on A(R) d = r, matrix-free, preconditioned by a Cholesky factor
///    of the warped stiffness at reference rotations turned by per-node rotations relative to them
///    (exact when all elements turned alike since). The reference is the rest until an element has
///    turned more than the refresh angle from it in a call's later iterations (PcgOptions), then
///    the rotations of that iteration, refactorized.
enum class CoarseSolver { Assembled, Pcg };
const char* coarseSolverName(CoarseSolver s);

/// Where the cell elements are smaller than the coarse grid's cells (docs/simulation-model.md,
/// "Graded cells"). Every coarse cell with a handle node within `splitWithinCells` cell sizes of
/// its box splits into 8 half-size cells (a leaf of m/2 fine cells, m = NestedMeshes::refinement,
/// which must be even), each a cell element with its own rotation. A half-size cell's corner on a
/// face or edge of a whole cell is a hanging node: it follows the whole cell's Kuhn face
/// interpolation, x_h = sum_q w_q x_q (the two ends of an edge or of the face's Kuhn diagonal), so
/// the model stays conforming. A negative distance (the default) keeps the uniform grid.
struct CoarseGrading {
  double splitWithinCells = -1.0;
  bool graded() const { return !(splitWithinCells < 0.0); }  // NaN counts, to be refused
};

class CoarseModel {
 public:
  /// Precomputes the condensed elements. `fineK`: rest stiffness per fine tet.
  CoarseModel(const CoarseModel&) = delete;
  CoarseModel(const NestedMeshes& meshes, const std::vector<Mat12>& fineK, const FineConstraints& constraints, const ProgressFn& progress = {},
              CoarseElement element = CoarseElement::Cell, const CoarseGrading& grading = {});
  /// The model of a cut scene from the model of the scene before the cut (uniform cells, uncut,
  /// built on the same meshes before cutScene changed them): only the cells holding a fine node the
  /// cuts split, copied or gave another role are condensed again, split into their pieces
  /// (sim/coarse_cut.cpp); the rest is taken from `uncut`. The same model as built whole, but for
  /// the order of its records. Throws handson::Error for a model that is not uncut uniform cells, or
  /// a scene that does not fit it.
  CoarseModel(const CoarseModel& uncut, const NestedMeshes& meshes, const std::vector<Mat12>& fineK, const FineConstraints& constraints,
              const ProgressFn& progress = {});

  /// The precomputed model, for the on-disk cache (sim/scene_cache.h).
  void save(std::ostream& os) const;
  /// A saved model over `meshes` (the scene it was built on). Throws handson::Error when the data is
  /// truncated, corrupt or does not fit the meshes; `bytes` bounds what may be read.
  static std::unique_ptr<CoarseModel> load(std::istream& is, std::uint64_t bytes, const NestedMeshes& meshes);

  ~CoarseModel();
  CoarseModel& operator=(const CoarseModel&) = delete;

  CoarseElement elementKind() const { return kind_; }
  /// The iteration solve() uses (default Pcg); switching keeps the state x the caller holds.
  void setSolver(CoarseSolver s) { solverKind_ = s; }
  CoarseSolver solver() const { return solverKind_; }
  /// Builds what solve() needs (Pcg: the rest stiffness's Cholesky factor, ~40 ms at 2,000 dofs)
  /// now rather than in the first call; solve() does it itself otherwise. Throws handson::Error.
  void prepareSolve();
  /// How the Pcg solve iterates. Throws handson::Error on a value out of its range.
  void setPcgOptions(const PcgOptions& o);
  const PcgOptions& pcgOptions() const { return pcgOptions_; }
  std::size_t elementCount() const { return elements_.size(); }
  /// Corners per element: 4 (Tet) or 8 (Cell).
  int cornersPerElement() const { return kind_ == CoarseElement::Tet ? 4 : 8; }
  /// The coarse node of corner c of element e.
  int elementCorner(int e, int c) const { return elements_[std::size_t(e)].node[std::size_t(c)]; }
  /// The element each fine tet belongs to.
  int elementOfFineTet(std::size_t t) const;
  /// Built on a cut fine mesh: cells the cut separates are one element per piece of their tissue
  /// (so there are more elements than cells, and coarse nodes with copies; docs/cutting.md).
  bool cut() const { return cut_ != nullptr; }

  /// Coarse node positions at rest: the coarse mesh's nodes, then (graded) the half-size cells'
  /// other corners. A state x holds one position per coarse node, hanging ones included.
  std::vector<Eigen::Vector3d> restState() const { return nodes_; }
  /// Built with a CoarseGrading that split cells (half-size cells near the handles).
  bool graded() const { return graded_; }
  /// Graded: the hanging coarse nodes (coarseRole() -3).
  std::size_t hangingNodeCount() const { return hangingNodes_.size(); }
  /// Quasi-static corotational iterations from `x` (warm start), at most `maxIterations`, stopping
  /// when the largest update is below tolerance x the largest handle displacement.
  CoarseSolveStats solve(const std::vector<RigidTransform>& handles, std::vector<Eigen::Vector3d>& x, int maxIterations, double tolerance = 1e-6);
  /// Fine node positions from a coarse state (the nonlinear shape functions).
  std::vector<Eigen::Vector3d> reconstruct(const std::vector<RigidTransform>& handles, const std::vector<Eigen::Vector3d>& x) const;

  /// The resultant elastic force and torque on each handle at coarse state x (sim/handle_reaction.h:
  /// units, sign, moment centre), from the condensed blocks alone - no fine work. Throws
  /// handson::Error on a size mismatch.
  std::vector<HandleReaction> handleReactions(const std::vector<RigidTransform>& handles, const std::vector<Eigen::Vector3d>& x) const;
  /// The elastic energy the coarse state x stores (N mm, i.e. mJ): sum_e 1/2 q_e^T H_e q_e over the
  /// condensed elements in the solve's frames, springs included. For a translation U of a handle in
  /// the linear regime the force along U is 2E/|U| (Clapeyron): a check of handleReactions().
  double storedEnergy(const std::vector<RigidTransform>& handles, const std::vector<Eigen::Vector3d>& x) const;

  /// The reconstruction packed for the GPU interpolation pass (see sim/fine_interpolation.h).
  FineInterpolationData interpolationData() const;
  /// R_e of every coarse element at state x (what reconstruct() uses).
  std::vector<Eigen::Matrix3d> elementRotations(const std::vector<Eigen::Vector3d>& x) const;

  const NestedMeshes& meshes() const { return meshes_; }
  const FineConstraints& constraints() const { return constraints_; }

  // The coarse space as the coarse level of a two-level solver on the fine mesh (linearized at the
  // coarse state x): P maps coarse free-dof increments to fine node increments (corners: identity;
  // face nodes: N_b; interior nodes: R_c H_f R_c^T; Dirichlet fine nodes: 0).
  /// P^T r for a fine per-node vector r (Dirichlet nodes ignored); size freeCoarseDofs().
  /// `R`: elementRotations(x) of the coarse state x (computed once by the caller, not per call).
  Eigen::VectorXd restrictToCoarse(const std::vector<Eigen::Vector3d>& r, const std::vector<Eigen::Matrix3d>& R) const;
  /// P c, added to out (per fine node).
  void prolongAdd(const Eigen::VectorXd& c, const std::vector<Eigen::Matrix3d>& R, std::vector<Eigen::Vector3d>& out) const;
  /// A_c^-1 b with the coarse matrix of the last solve() iteration (Pcg: its preconditioner, the
  /// factor at its reference rotations turned by the last solve's node rotations).
  Eigen::VectorXd coarseSolve(const Eigen::VectorXd& b) const;
  /// Coarse nodes held by Dirichlet conditions: -2 fixed at rest, k >= 0 moved by handle k, -1 free,
  /// -3 hanging (graded: follows the whole cell it lies on).
  const std::vector<int>& coarseRole() const { return coarseRole_; }
  std::size_t freeCoarseDofs() const { return std::size_t(dofCount_); }

 private:
  CoarseModel(const NestedMeshes& meshes, CoarseElement kind);
  void buildAssembler();
  /// Graded: the leaves (half-size cells near the handles, whole cells elsewhere), their corner
  /// nodes (nodes_ grows) and the hanging nodes' weights (sim/coarse_grading.cpp).
  void buildGradedLeaves(const CoarseGrading& grading, std::vector<std::vector<int>>& tetsOf);
  /// A cut fine mesh (NestedMeshes::cutSource; uniform cell elements): the cells a cut separates
  /// split into one element per piece of their tissue, each piece's corners its own side's coarse
  /// nodes, copies of the grid's (the virtual node algorithm, sim/coarse_cut.cpp).
  struct CutCells {
    std::vector<int> cell;                  ///< per element: its grid cell
    std::vector<int> elementOfTet;          ///< per fine tet: its element
    std::vector<std::array<int, 8>> node;   ///< per element: its corners' coarse nodes (cellNodes order)
    std::vector<std::array<int, 8>> fine;   ///< per element: each corner's fine node in its piece, -1 where the piece holds none (virtual)
  };
  /// Replaces the cells' tets (tetsOf) by the elements', sets cut_ and adds the corners' copies to
  /// nodes_ and nodeFine_ (-1: a virtual node).
  void separateCutCells(std::vector<std::vector<int>>& tetsOf);
  /// Per corner entry 8k + c of element k: its group's root, its grid node, the copies of the
  /// grid node's fine node its piece holds.
  struct CutEntries {
    const std::vector<int>& group;
    const std::vector<int>& grid;
    const std::vector<std::vector<int>>& copies;
  };
  void assignCutCorners(CutCells& cut, const CutEntries& entries);
  /// The incremental build's untouched cells, from the uncut model (sim/coarse_cut.cpp).
  void takeUntouched(const CoarseModel& uncut, const std::vector<char>& touchedCell);
  /// The springs that give a virtual corner a stiffness (sim/coarse_cut.cpp), after the elements are built.
  void stiffenVirtualCorners();
  /// Their stiffness against the model's mean corner stiffness.
  static constexpr double kVirtualCornerStiffness = 1e-3;
  /// The Kuhn interpolation weights of element e's corners at p (its cell's, or its leaf's).
  Eigen::Matrix<double, 8, 1> elementWeights(int e, const Eigen::Vector3d& p, bool* onBoundary) const;
  /// Hanging nodes take their masters' weighted positions.
  void expandHanging(std::vector<Eigen::Vector3d>& x) const;
  /// The rest stiffness sum_e K_h over the free dofs, hanging corners through their masters.
  SparseMatrix restStiffness() const { return warpedStiffness(nullptr); }
  /// sum_e R_e K_h R_e^T over the free dofs (hanging corners through their masters); R null: the rest.
  SparseMatrix warpedStiffness(const std::vector<Eigen::Matrix3d>* R) const;
  /// The per-element condensation of Tet and Cell elements (linear faces); `only`: the elements to
  /// condense (the others, and the records of their nodes, are in place already).
  void buildConforming(const std::vector<Mat12>& fineK, const std::vector<std::vector<int>>& tetsOf, const ProgressFn& progress,
                       const std::vector<char>* only = nullptr);
  /// Each ungraded element's fine tets (a coarse tet's, or a grid cell's).
  std::vector<std::vector<int>> ungradedTets() const;
  /// The coarse nodes' Dirichlet roles, the free dofs and their assembler, the handles' centroids.
  void finishBuild(const ProgressFn& progress);
  struct ConformingBuild;
  struct ElementSystem;
  /// Sets the Dirichlet coarse nodes of x and returns the convergence threshold (mm).
  double pinDirichlet(const std::vector<RigidTransform>& handles, std::vector<Eigen::Vector3d>& x, double tolerance) const;
  CoarseSolveStats solveAssembled(const std::vector<RigidTransform>& handles, std::vector<Eigen::Vector3d>& x, int maxIterations, double tol);
  // The matrix-free solve (sim/coarse_pcg.cpp).
  struct PcgWorkspace;
  CoarseSolveStats solvePcg(const std::vector<RigidTransform>& handles, std::vector<Eigen::Vector3d>& x, int maxIterations, double tol);
  void preparePcg(CoarseSolveStats& st);
  template <int N>
  void pcgRotations(const std::vector<Eigen::Vector3d>& x, bool nodes);
  template <int N>
  void pcgResidual(const std::vector<RigidTransform>& handles, const std::vector<Eigen::Vector3d>& x, Eigen::VectorXd& r, double& boundaryMs) const;
  template <int N>
  void pcgProduct(const Eigen::VectorXd& p, Eigen::VectorXd& out) const;
  void pcgNodeRotations();
  void pcgRefresh(CoarseSolveStats& st);
  /// One iteration's conjugate-gradient step on A(R) d = r into pcg_->d (`carry`: a later iteration).
  void pcgStep(bool carry, CoarseSolveStats& st);
  /// Anderson acceleration of the update in pcg_->d (sim/anderson.h); returns the plain update's largest node step.
  double andersonStep(const std::vector<Eigen::Vector3d>& x);
  void pcgFactorize(const std::vector<Eigen::Matrix3d>* Q, CoarseSolveStats& st);
  void pcgPrecondition(const Eigen::VectorXd& r, Eigen::VectorXd& z) const;
  bool pcgReady() const;
  // Per-frame temporaries on the stack (at most 24 rows); stored blocks sized to the element kind
  // (a tet's 12x12 is a quarter of a cell's 24x24).
  using MatE = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, 0, 24, 24>;
  using VecE = Eigen::Matrix<double, Eigen::Dynamic, 1, 0, 24, 1>;
  struct HandleBlock {
    int handle;
    Eigen::Matrix<double, Eigen::Dynamic, 9> A;
    Eigen::Matrix<double, Eigen::Dynamic, 3> B;
  };
  struct Element {
    std::array<int, 8> node{};  ///< coarse corner nodes (first n)
    /// The handles' condensed stiffness against their unit motions (12h x 12h, h = handles.size(),
    /// block (a, b) for handles[a], handles[b]): handleReactions() needs it, the solve does not.
    Eigen::MatrixXd Q;
    Eigen::MatrixXd Kh;
    Eigen::VectorXd KhX;        ///< K_h X_c (constant)
    Eigen::Matrix3d fitInv;     ///< (sum dX dX^T)^-1 of the rest corners about their centroid
    std::array<Eigen::Vector3d, 8> dX;
    std::vector<HandleBlock> handles;
    /// It holds a sliding interface's nodes (springs, or slide nodes held on its faces): their
    /// normals are fixed in the element's frame, so handleReactions() takes it in the solve's frame.
    bool slides = false;
  };
  struct InteriorNode {
    int fine, element;
    Eigen::Matrix<double, 3, Eigen::Dynamic> H;
    struct G {
      int handle;
      Eigen::Matrix<double, 3, 9> A;
      Eigen::Matrix<double, 3, 3> B;
    };
    std::vector<G> g;
  };
  struct BoundaryNode {
    int fine, element;
    Eigen::Matrix<double, 8, 1> N;  ///< weights of the element's corners (first n)
  };
  Eigen::Matrix3d elementRotation(int e, const std::vector<Eigen::Vector3d>& x) const;
  /// An element's condensed load in the frame R (sim/handle_reaction.cpp): corner displacements d
  /// (3n), handle motion parameters p (12h), corner forces K_h d + sum_a [A_a B_a] p_a (3n), and per
  /// handle the gradient g_a against its 12 motion parameters.
  struct ElementLoad {
    VecE d, corner;
    Eigen::VectorXd p;
    std::vector<Eigen::Matrix<double, 12, 1>> g;
  };
  ElementLoad elementLoad(const Element& el, const Eigen::Matrix3d& R, const std::vector<Eigen::Vector3d>& x, const std::vector<RigidTransform>& handles) const;
  Eigen::Vector3d elementMoment(const Element& el, const Eigen::Matrix3d& R, const ElementLoad& L, const std::vector<RigidTransform>& handles) const;
  /// d elementMoment / d w for the frame turned by w (R exp([w]x)).
  Eigen::Matrix3d momentJacobian(const Element& el, const Eigen::Matrix3d& R, const ElementLoad& L, const std::vector<RigidTransform>& handles) const;
  /// The rotation at which the element's condensed energy is stationary (its forces moment-free),
  /// from R0 by Levenberg-Marquardt steps, and the element's load L there (sim/handle_reaction.cpp).
  Eigen::Matrix3d stationaryRotation(const Element& el, const Eigen::Matrix3d& R0, const std::vector<Eigen::Vector3d>& x, const std::vector<RigidTransform>& handles,
                                     ElementLoad& L) const;

  // The anchored skeleton inside the elements (held fine nodes that are not on a face of held
  // corners) is Dirichlet at rest: an internal handle, index handleCount, whose transform is the
  // identity, so its nodes stay at X in the world frame whatever the element's rotation (its term
  // A vec(R_c^T - I) in every element it touches).
  int anchorHandle() const { return constraints_.handleCount; }
  /// The caller's handle transforms with the anchor's identity appended (index anchorHandle()).
  std::vector<RigidTransform> withAnchor(const std::vector<RigidTransform>& handles) const;
  /// Element e's non-corner fine nodes (`nodes`, local order, corners first) by role: Dirichlet
  /// (handle or anchor), on its faces (with the corners' weights) or interior. `Xt`: a tet element's
  /// rest corners.
  struct ElementNodes {
    std::vector<int> D, B, I;
    std::vector<Eigen::Matrix<double, 8, 1>> Bw;
    std::vector<int> S;                            ///< slide nodes on the element's faces
    std::vector<Eigen::Matrix<double, 8, 1>> Sw;   ///< their corners' weights
    std::vector<int> Dhandle;            ///< per D node: its handle (or the anchor)
    std::vector<Eigen::Vector3d> DX;     ///< per D node: its rest position
    void addDirichlet(int local, int handle, const Eigen::Vector3d& X) {
      D.push_back(local);
      Dhandle.push_back(handle);
      DX.push_back(X);
    }
  };
  /// Sliding interfaces: the spring of each slide node inside an element or at its corner, shared
  /// among the elements where it touches tissue (its stiffness over their count), enters each as a
  /// Dirichlet *ghost* node of the handle at the slide node's rest position, joined to it by
  /// k/c n n^T - so the springs are condensed with the rest.
  /// A slide node that touches no tissue tet of an element (only its handle's own, stiffness-free
  /// tets) moves with the handle there: the element's energy does not depend on it.
  struct SlideShares {
    std::vector<int> slideOf;      ///< per fine node: index into constraints_.slide, or -1
    std::vector<int> elementCount; ///< per fine node: the elements where it touches a tissue tet
    std::vector<char> rigidTet;    ///< per fine tet: no stiffness (a sliding handle's own)
    std::vector<char> coarseNode;  ///< per fine node: a coarse node (a corner, or a hanging node) - never held exactly
    bool slides(int fine) const { return !slideOf.empty() && slideOf[std::size_t(fine)] >= 0; }
    /// On a face and held to the surface exactly (roles S): a slide node that is no coarse node.
    bool heldExactly(int fine) const { return slides(fine) && !coarseNode[std::size_t(fine)]; }
    /// The slide indices among `nodes` that touch a tissue tet of `tets`, and per local node whether
    /// it does (`touches`, sized to nodes).
    std::vector<int> of(const std::vector<int>& nodes, const std::vector<int>& tets, const TetMesh& fine, const std::unordered_map<int, int>& local,
                        std::vector<char>& touches) const;
  };
  SlideShares slideShares(const std::vector<std::vector<int>>& tetsOf, const std::vector<Mat12>& fineK) const;
  /// The rows of the slide nodes on element faces (roles.S, whose surface ghosts are PhiD's columns from
  /// `firstGhost` on): tangentially the face's corners, normally the handle,
  /// u = (I - n n^T) N_b u_c + n n^T u_ghost - so the element beside agrees on them.
  void holdSurfaceSlides(const ElementNodes& roles, const std::vector<int>& nodes, const SlideShares& slide, std::size_t firstGhost, Eigen::MatrixXd& Phic,
                         Eigen::MatrixXd& PhiD) const;
  /// Adds ghost `g` (local index) of slide entry `s` joined to local node `l` to K and to `roles`.
  void addGhost(Eigen::MatrixXd& K, int l, int g, const SlideShares& shares, int s, ElementNodes& roles) const;
  /// A slide node on a face (not a corner, roles S) moves tangentially with the face's corners and
  /// normally with its handle, exactly (no spring: a spring on the corners' linear field would lock
  /// the interface to the handle, the surface cutting the faces at any angle).
  /// `touches`: per local node, whether it touches a tissue tet of the element (slide nodes that do not
  /// are Dirichlet nodes of their handle).
  ElementNodes classifyNodes(int e, const Element& el, const std::vector<int>& nodes, const std::array<Eigen::Vector3d, 4>& Xt, const SlideShares& slide,
                             const std::vector<char>& touches) const;
  std::vector<int> localNodes(int e, const Element& el, ConformingBuild& b) const;
  ElementSystem elementSystem(int e, const Element& el, const std::vector<int>& nodes, ConformingBuild& b) const;
  void condenseInterior(int e, ElementSystem& sys) const;
  /// The condensed blocks with the system's shape functions: Kh = Phi_c^T K Phi_c, the handles' A
  /// and B from Phi_c^T K Phi_D, and Q.
  void condenseBlocks(const ElementSystem& sys, Element& el) const;
  /// Adds element el's forces in frame Rc (its load L) to the reactions of the handles it touches.
  void addElementReaction(const Element& el, const Eigen::Matrix3d& Rc, const ElementLoad& L, const std::vector<Eigen::Vector3d>& x,
                          const std::vector<RigidTransform>& handles, std::vector<HandleReaction>& r) const;
  void recordReconstruction(int e, const ElementSystem& sys, ConformingBuild& b);
  /// All corners with a weight in w are held (fixed).
  bool onHeldCorners(const Element& el, const Eigen::Matrix<double, 8, 1>& w) const;
  /// Symmetrizes el.Kh and derives KhX, the corners' offsets and fitInv.
  void finishElement(Element& el) const;
  /// Adds the blocks of one handle node at rest position X (blk: 3n x 3, K_hd's columns of the node).
  void addHandleBlock(Element& el, int handle, const Eigen::Vector3d& X, const Eigen::Ref<const Eigen::MatrixXd>& blk) const;
  static void addInteriorHandleBlock(InteriorNode& in, int handle, const Eigen::Vector3d& X, const Eigen::Matrix3d& blk);
  VecE handleTerm(const Element& el, const Eigen::Matrix3d& Rc, const std::vector<RigidTransform>& handles) const;

  const NestedMeshes& meshes_;
  FineConstraints constraints_;
  std::vector<Eigen::Vector3d> nodes_;  ///< coarse node rest positions (the coarse mesh's, then graded extras)
  std::vector<int> nodeFine_;           ///< fine node of each coarse node (-1: a cut's virtual node)
  bool graded_ = false;
  struct Leaf {
    Eigen::Vector3i lo;  ///< fine grid node of its lowest corner
    int size;            ///< fine cells per edge
    std::array<int, 8> node;  ///< coarse corner nodes, in KuhnGrid::cellNodes order
  };
  std::vector<Leaf> leaves_;                                   ///< graded: element e's cube
  std::unique_ptr<CutCells> cut_;                              ///< a cut fine mesh's elements (null: uncut)
  std::vector<int> leafOfFineTet_;                             ///< graded: the element of each fine tet
  std::vector<std::vector<std::pair<int, double>>> hang_;      ///< per coarse node: masters and weights (hanging only)
  std::vector<int> hangingNodes_;
  CoarseElement kind_;
  int nc_ = 4;
  std::vector<Element> elements_;
  std::vector<InteriorNode> interior_;
  std::vector<BoundaryNode> boundary_;
  std::vector<int> coarseRole_, dof_;
  std::vector<Eigen::Vector3d> handleRestCentroid_;  ///< each handle's free fine nodes' centroid at rest (handleReactions)
  int dofCount_ = 0;
  std::unique_ptr<BlockAssembler> assembler_;
  // The coarse system (10^2-10^4 dofs) with Eigen's simplicial Cholesky: CHOLMOD's per-call
  // workspaces and BLAS threads cost more than they save at this size (measured on the phantom
  // kidney scene, 6,318 coarse tets / 2,022 dofs: 35.8 ms a frame with CHOLMOD, 18.5 with Eigen).
  Eigen::SimplicialLLT<SparseMatrix, Eigen::Lower> solver_;
  bool factorize(const SparseMatrix& A);
  Eigen::VectorXd backSolve(const Eigen::VectorXd& b) const;
  bool analyzed_ = false, factorized_ = false;
  int callsSinceFactorization_ = 0;
  CoarseSolver solverKind_ = CoarseSolver::Pcg;
  PcgOptions pcgOptions_;
  std::unique_ptr<PcgWorkspace> pcg_;
};

/// Plain coarse FEM for comparison: coarse tets with the volume-averaged Young's modulus and Poisson
/// ratio of their fine tets, Dirichlet at coarse nodes only (handle nodes and the outer boundary),
/// fine nodes interpolated linearly. Returns the fine node positions.
std::vector<Eigen::Vector3d> plainCoarseSolve(const NestedMeshes& meshes, const std::vector<double>& fineYoungs, const std::vector<double>& finePoisson,
                                              const FineConstraints& constraints, const std::vector<RigidTransform>& handles);

/// A handle node's 12 unit motions at rest position X (3 x 12): column 3c+r is e_r X_c (the motion
/// u = M X with M = e_r e_c^T), column 9+j is e_j (a translation). A handle's motion R X + t is
/// u = (R - I) X + t = U(X) [vec(R - I); t] (vec column-major), the order of A_k's and B_k's columns.
Eigen::Matrix<double, 3, 12> unitMotions(const Eigen::Vector3d& X);

/// Fine-mesh Dirichlet positions: handle nodes moved by their transform, fixed nodes at rest, the
/// rest free (at rest) - the start of the fine static solve.
std::vector<Eigen::Vector3d> prescribedPositions(const TetMesh& fine, const FineConstraints& c, const std::vector<RigidTransform>& handles,
                                                 std::vector<char>* dirichlet = nullptr);

}  // namespace handson
