#pragma once
// The simulation in a running session, for the window and for headless replay alike. When the set
// of simulated handles changes (active handles move, fixed ones hold), a background thread builds
// the scene (region, nested meshes, materials) and the coarse model, with progress; until it is
// ready, moved handles are drawn rigidly. Then the coarse solve runs on its worker thread (newest
// handle poses in, newest coarse state out, a held pose settles) and every frame carries the newest
// state to the renderer's deformation passes: the tissue around a moved handle deforms on screen.
// The render loop never waits for the build or the solve.
#include <array>
#include <atomic>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "app/session/stage_times.h"
#include "interaction/handles.h"
#include "render/volume_renderer.h"
#include "sim/handle_reaction.h"
#include "sim/sim_scene.h"
#include "sim/tissue_cut.h"
#include "sim/sim_worker.h"
#include "sim/tissue_limits.h"
#include "sim/volume.h"

namespace handson {

struct DeformationOptions {
  bool enabled = true;
  SimSettings sim;               ///< region padding, coarse and fine resolutions, materials
  int coarseIterations = 3;      ///< per new pose (warm started)
  int idleIterations = 300;      ///< more while a pose is held, until converged
  int refineSteps = 0;           ///< then two-level refinement steps toward the fine answer (shown as they land)
  std::string cacheDir;          ///< on-disk preprocessing cache (sim/scene_cache.h); empty: none
};

class DeformationController {
 public:
  enum class State { Off, Building, Ready, Failed };

  /// `image` (the original values: materials come from them), `quantized` (the renderer's copy) and
  /// `renderer` must outlive this.
  DeformationController(const Volume& image, const QuantizedVolume& quantized, VolumeRenderer& renderer, DeformationOptions options = {});
  ~DeformationController();
  DeformationController(const DeformationController&) = delete;
  DeformationController& operator=(const DeformationController&) = delete;

  /// Before submitting a frame: follows the handles (a changed set restarts the build), sends
  /// changed poses to the worker, and attaches the newest coarse state to the request. Returns
  /// whether the frame shows the simulated deformation (the caller then turns the rigid preview off).
  /// `attach` false: follow and send, but attach nothing yet.
  bool prepareFrame(FrameRequest& request, const HandleSet& handles, bool attach = true);

  /// The same, but waits for the build and for the solve of the current poses to settle (at most
  /// `seconds` each): deterministic frames for replays and tests.
  bool prepareFrameSettled(FrameRequest& request, const HandleSet& handles, double seconds = 120.0);

  /// The deformed volume as shown (after the last frame finished), on the input's grid and value
  /// type: region voxels from the GPU, the rest of the image unchanged. False when nothing is
  /// simulated yet.
  bool exportDeformed(Volume& out) const;
  /// The fine mesh as shown, for ParaView (`meshPath`, .vtu): rest positions, point data
  /// displacement (mm) and dirichlet (0/1), cell data youngs_modulus, poisson_ratio, coarse_element,
  /// strain; and the strain as shown (sim/strain.h) on the input's grid, 0 outside the simulated
  /// region (`strainPath`, written by extension). Both atomically, from one read-back of the drawn
  /// fine positions and one strain computation (the volume rasterized on the CPU: an export's cost,
  /// not a frame's). False when nothing is simulated yet.
  bool exportMeshAndStrain(const std::string& meshPath, const std::string& strainPath) const;

  /// The handles' interface with the tissue (SimSettings::Interface, the "set-interface" action): a
  /// change rebuilds the model on the next frame (moved handles drawn rigidly meanwhile), as a
  /// changed handle set does.
  void setInterface(SimSettings::Interface i);
  SimSettings::Interface interface() const { return options_.sim.interface; }
  /// Cuts the tissue along the quads, at once (the "cut" action; docs/cutting.md): the model is
  /// rebuilt on the next frame with every cut so far, its coarse model updated from the uncut one
  /// where the cuts pass. A cut the scene refuses (it separates nothing, or leaves tissue held by
  /// nothing) is dropped by the first build after it, the others kept; status() names it. False (nothing
  /// changes) for no quad or more than kMaxCutQuads (a stroke across the body at 4 mm is ~100).
  bool addCut(const std::vector<CutQuad>& quads);
  static constexpr std::size_t kMaxCutQuads = 1024;
  /// Every cut undone (the "clear-cuts" action): rebuilt on the next frame.
  void clearCuts();
  /// The cuts kept so far (each a group of quads cut at once).
  const std::vector<std::vector<CutQuad>>& cuts() const { return cuts_; }

  State state() const;
  /// "" when off; else the build's stage and progress, the model's size, or the failure.
  std::string status() const;
  /// What the shown state is, for the UI and the timing log: "" (off), "building", "failed",
  /// "rest" (nothing moved yet), "coarse" (the coarse solve still settling), "refining k/N" (the
  /// coarse solve converged, k of the N refinement steps shown), "converged" (the coarse solve
  /// converged and every refinement step shown), "unconverged" (it stopped without converging).
  std::string modelState() const;
  /// Seconds from the worker taking the shown state's pose to publishing it (how long after the
  /// pose a refined state landed); 0 when nothing is shown.
  double shownSeconds() const { return shownSeconds_; }
  /// Input number of the newest state shown, and whether its coarse solve had converged.
  std::uint64_t shownInput() const { return shownInput_; }
  /// The shown state's reaction on each simulated handle (sim/handle_reaction.h), with the app's
  /// handle id of each (active handles, then fixed ones); empty when nothing is shown.
  std::vector<std::pair<int, HandleReaction>> shownReactions() const;
  /// The shown state's refinement step (0: the coarse model's answer).
  int shownRefineStep() const { return shownRefineStep_; }
  /// The shown state's tissue past its strain limit (sim/tissue_limits.h), with the app's handle
  /// ids: "none" or "2.40 cm³ (organ-and-blood ...), from handle 3 (2.40 cm³)"; empty unless the
  /// shown state is a held pose's last refinement step (only fine positions tell the strain) and
  /// its report has come (a fraction of a second after it).
  std::string shownTissueLimits() const;
  bool shownConverged() const { return shownConverged_; }
  /// The simulated region's fine cell (largest edge, mm): how far the deformed volume's resampling
  /// can move a surface from where the rigidly moved handle puts it; 0 before a model is built.
  double fineCellMm() const;
  /// Failures so far, for a caller that saves the session when one happens: poses the solve
  /// refused, solves that stopped without converging (each counted once per episode: until a pose
  /// is solved again), a build that failed. status() describes the newest.
  std::uint64_t failures() const;
  /// Blocks until the build ends (ready or failed), at most `seconds` (tests, headless runs).
  bool waitBuilt(double seconds);
  /// Builds started so far (a changed handle set, changed settings, a handle outgrowing its
  /// region). A build of a small scene may end before the caller looks at state(): this tells
  /// that one was started whatever the timing.
  std::uint64_t buildsStarted() const { return buildsStarted_; }
  /// Blocks until the worker published its last state for the newest poses sent (converged, or its
  /// iteration budget spent), at most
  /// `seconds`; the next prepareFrame shows it. False on timeout or when nothing is simulated.
  bool waitSettled(double seconds);
  /// The worker's CPU time behind the states taken since the last call: "coarse-solve" (all of
  /// it), "boundary-forces" (the part spent on the rigid handles' blocks), "refinement" (a
  /// two-level step). On the worker thread, not the render thread's; for the timing log.
  std::vector<std::pair<std::string, double>> takeStageTimes() { return stages_.take(); }

 private:
  struct Model;  // scene, coarse model, packed interpolation data, worker
  struct Key {
    std::vector<int> ids;
    std::vector<std::size_t> sizes, firstVoxels;
    bool operator==(const Key& o) const { return ids == o.ids && sizes == o.sizes && firstVoxels == o.firstVoxels; }
  };
  static Key keyOf(const HandleSet& handles);
  void startBuild(const HandleSet& handles);
  void stopAll();
  void adoptBuilt();
  /// The cuts applied to a freshly built model (on the builder thread): those the scene refuses are
  /// left out and listed in the model's refusedCuts.
  struct CutBuild {
    const std::vector<std::vector<CutQuad>>& cuts;
    CoarseSolver solver;
    const ProgressFn& progress;
  };
  static void cutBuilt(Model& m, const CutBuild& b);
  bool outgrown(const std::vector<RigidTransform>& poses) const;
  void pull();  // the worker's newest snapshot into state_

  const Volume& image_;
  const QuantizedVolume& quantized_;
  Eigen::Vector3d imageLo_, imageHi_;  // the image's world box (voxel centres)
  VolumeRenderer& renderer_;
  DeformationOptions options_;
  Key key_;
  bool rebuild_ = false;  // the settings changed: rebuild on the next frame
  std::vector<std::vector<CutQuad>> cuts_;  // applied by every build, in order
  std::size_t confirmedCuts_ = 0;            // the first ones, taken by an adopted build
  std::vector<int> simIds_;  // handle ids in simulation order (active, then fixed)
  std::vector<bool> simActive_;
  std::vector<std::pair<Eigen::Vector3d, Eigen::Vector3d>> restBoxes_;  // world box of each simulated handle at rest
  std::vector<std::array<Eigen::Vector3i, 2>> restVoxelBoxes_;         // index box of each simulated handle's voxels (rigid drawing)
  std::vector<std::vector<Eigen::Vector3d>> restOutline_;              // each simulated handle's outside at rest (4 mm points)
  std::thread builder_;
  std::shared_ptr<std::atomic<bool>> builderDone_;
  struct Retired {
    std::thread thread;
    std::shared_ptr<std::atomic<bool>> done;
  };
  std::vector<Retired> retired_;  // cancelled builds, joined once finished
  void reapBuilders(bool wait);
  std::atomic<std::uint64_t> generation_{0};
  mutable std::mutex mutex_;  // guards the builder's results and progress
  std::unique_ptr<Model> built_;  // handed over by the builder
  std::string buildStage_, error_;
  double buildFraction_ = 0.0;
  bool building_ = false;
  std::uint64_t buildsStarted_ = 0;
  std::unique_ptr<Model> model_;  // in use (worker running, renderer deforming)
  std::vector<RigidTransform> sentPoses_;
  std::uint64_t lastSent_ = 0, shownInput_ = 0;
  bool shownConverged_ = false, shownSettled_ = false;
  CoarseSolveStats shownStats_;
  std::vector<HandleReaction> shownReactions_;
  std::optional<TissueLimitReport> shownLimits_;
  /// The fine node positions as drawn (world mm); empty when they cannot be read.
  std::vector<Eigen::Vector3d> drawnFinePositions() const;
  std::uint64_t failures_ = 0;
  bool unconverged_ = false;  // the last settled state shown stopped without converging
  std::uint64_t answeredInput_ = 0;  // newest input answered, with a state or an error
  bool answeredSettled_ = false;
  std::string lastError_;
  std::optional<CoarseFrameState> state_;
  bool stateFresh_ = false;
  std::vector<Eigen::Vector4f> finePositions_;  // a refined state (voxel index space)
  bool fineFresh_ = false;
  int shownRefineStep_ = 0;
  double shownSeconds_ = 0.0;
  StageTimes stages_;
};

}  // namespace handson
