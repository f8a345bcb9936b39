#pragma once
// The coarse solve on a worker thread: the render loop never waits for it. Handle transforms go in
// (the newest replaces any not yet taken), the newest completed state comes out. For each input the
// worker runs the quasi-static coarse solve (warm start, an iteration budget), reconstructs the fine
// nodes and publishes; while no newer input arrives it keeps refining toward the fine answer (the
// two-level steps) and publishes after each, so a held pose sharpens over the next frames.
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "sim/coarsening.h"
#include "sim/handle_reaction.h"
#include "sim/sim_scene.h"
#include "sim/tissue_limits.h"
#include "sim/two_level.h"

namespace handson {

struct SimWorkerOptions {
  int coarseIterations = 3;   ///< coarse corotational iterations per input (warm started)
  int refineSteps = 0;        ///< two-level steps after each input while it stays the newest (after the
                              ///< coarse solve settled; their snapshots carry fine positions)
  int refineIterations = 10;  ///< PCG iterations per step
  /// The refinement's linearization (sim/two_level.h); the matrix-free ones need the scene's
  /// materials (the SimScene constructor), the fineK-only constructor always refines with Projected.
  RefineMethod refineMethod = RefineMethod::Analytic;
  int refineThreads = 0;      ///< matrix-free methods: threads for the element passes (0: the hardware's)
  bool reconstructFine = true;    ///< fine nodes on the CPU (false: the GPU interpolates them from the coarse state)
  bool elementRotations = false;  ///< publish each coarse element's rotation (what the GPU interpolation needs)
  /// While an input stays the newest and its coarse solve has not converged: up to this many more
  /// iterations, published every coarseIterations (a held pose settles; 0: off).
  int idleIterations = 0;
  /// A jump between consecutive inputs larger than this (per handle: translation in mm, rotation in
  /// degrees) is solved in increments, each from the last, keeping the iteration in its basin.
  double continuationMm = 10.0, continuationDeg = 30.0;
  /// With the scene constructor and refinement: the last refinement step's snapshot also carries
  /// the tissue past its strain limit by this table (the scene's; sim/tissue_limits.h). Unset: none.
  std::optional<MaterialTable> tissueLimits;
  /// Per handle, whether it moves (tissue past its limit is put down to the nearest moving one);
  /// empty: all of them.
  std::vector<char> movingHandles;
};

struct SimSnapshot {
  std::uint64_t input = 0;              ///< which setHandles() call this answers (1, 2, ...)
  int refineStep = 0;                   ///< 0: the coarse answer; k: after k refinement steps
  std::vector<Eigen::Vector3d> coarse;  ///< coarse node positions
  std::vector<Eigen::Vector3d> fine;    ///< fine node positions (empty without reconstructFine)
  std::vector<Eigen::Matrix3d> rotations;  ///< per coarse element (with elementRotations)
  std::vector<RigidTransform> handles;  ///< the input's handle transforms
  /// Each handle's reaction (sim/handle_reaction.h): from the coarse model's condensed blocks for a
  /// coarse answer, from the fine tets at the refined positions after a refinement step.
  std::vector<HandleReaction> reactions;
  /// The tissue past its strain limit (with SimWorkerOptions::tissueLimits): a held pose's last
  /// refinement step is published as soon as it is done, then once more, the same state with this
  /// report (the strain of every fine tet: a fraction of a second the state need not wait for).
  std::optional<TissueLimitReport> limits;
  CoarseSolveStats stats;
  bool settled = false;                 ///< no more coarse snapshots for this input (converged, or the idle budget spent)
  double seconds = 0.0;                 ///< worker time for this snapshot since its input was taken
  double refineMs = 0.0;                ///< the refinement step's own time (refineStep > 0); the coarse
                                        ///< solve's is in stats (all continuation increments summed)
  std::string error;                    ///< non-empty: the input was refused (the state is the last good one)
};

class SimWorker {
 public:
  /// The model and stiffness must outlive the worker, and nothing else may use the model meanwhile.
  SimWorker(CoarseModel& model, const std::vector<Mat12>& fineK, const SimWorkerOptions& options = {});
  /// The scene's stiffness and materials (the warped refinement can run); the scene must outlive the
  /// worker unchanged.
  SimWorker(CoarseModel& model, const SimScene& scene, const SimWorkerOptions& options = {});
  ~SimWorker();
  SimWorker(const SimWorker&) = delete;
  SimWorker& operator=(const SimWorker&) = delete;

  /// Queues new handle transforms; returns their input number. Never blocks on the solve.
  std::uint64_t setHandles(std::vector<RigidTransform> handles);
  /// The newest snapshot published since the last call (nullopt if none). Never blocks on the solve.
  std::optional<SimSnapshot> takeLatest();
  /// Waits until a snapshot for `input` (or a newer one) with at least `refineStep` steps is
  /// published, at most `timeoutSeconds`; returns it (for tests and headless runs).
  std::optional<SimSnapshot> waitFor(std::uint64_t input, int refineStep = 0, double timeoutSeconds = 60.0);

 private:
  struct RunState;
  struct Input;
  void run();
  std::optional<Input> nextInput();
  bool newer();
  std::optional<CoarseSolveStats> solveInput(const Input& in, RunState& r, std::vector<Eigen::Vector3d>& fine);
  bool settle(const Input& in, RunState& r, CoarseSolveStats st, std::vector<Eigen::Vector3d>& fine);
  void refine(const Input& in, const RunState& r, std::vector<Eigen::Vector3d> fine);
  SimSnapshot snapshot(const Input& in, const std::vector<Eigen::Vector3d>& x, const CoarseSolveStats& st) const;
  static SimSnapshot failed(const Input& in, RunState& r, const std::string& what);
  void publish(SimSnapshot s);
  /// The last refinement step's state again, with its tissue report (on a failure to compute it,
  /// nothing: the state stands as published).
  void publishWithLimits(SimSnapshot s, std::chrono::steady_clock::time_point t0);

  CoarseModel& model_;
  const std::vector<Mat12>& fineK_;
  FineRefiner refiner_;
  SimWorkerOptions options_;
  const SimScene* scene_ = nullptr;       // the scene constructor's (tissue limits)
  std::optional<NearestHandle> nearest_;  // built on the worker thread at the first report
  std::mutex mutex_;
  std::condition_variable wake_, published_;
  std::optional<std::vector<RigidTransform>> pending_;
  std::uint64_t submitted_ = 0;
  std::optional<SimSnapshot> latest_;  // not yet taken
  std::uint64_t lastInput_ = 0;
  int lastStep_ = -1;
  bool stop_ = false;
  std::thread thread_;
};

}  // namespace handson
