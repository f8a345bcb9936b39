#pragma once
// The GPU deformation of the volume (docs/gpu-deformation.md), as frame-graph
// passes: interpolation of the fine node positions from the coarse state (deform_interpolate.comp),
// the box of voxels whose tissue moved since the last frame (deform_bounds.comp, deform_args.comp),
// and the tetrahedral rasterization of the fine mesh into a deformed copy of the volume and of the
// handle-id mask, redoing only that box (deform_clear.comp, deform_claim.comp, deform_resolve.comp). Per frame only the
// coarse state goes to the GPU (sim/fine_interpolation.h: kilobytes). CPU references:
// interpolateFineReference (sim/fine_interpolation.h) and rasterizeDeformed (sim/tet_raster.h).
#include <Eigen/Core>

#include <array>
#include <functional>
#include <memory>
#include <vector>

#include "compute_passes.h"
#include "deform_strain_pass.h"
#include "shaders/shared.h"
#include "sim/fine_interpolation.h"
#include "vk_graph_executor.h"
#include "vk_resources.h"

namespace handson::vk {

class Context;
struct ValidatedDeformSetup;

/// The static inputs, from the simulation scene.
struct DeformSetup {
  const FineInterpolationData* interpolation = nullptr;
  const std::vector<std::array<int, 4>>* fineTets = nullptr;
  Eigen::Vector3d regionLo{0, 0, 0}, regionHi{0, 0, 0};  ///< world box of the mesh at rest
  float background = 0.0f;                               ///< normalized value of uncovered region voxels
  Eigen::Matrix4d worldToIndex = Eigen::Matrix4d::Identity();
  /// A fine node's new position is taken (and its tets redone) once it moved by more than this
  /// many voxels from the last position taken: a trilinear sample then differs from the exact
  /// one by at most this fraction of the largest neighbouring voxel difference (~1 HU at a
  /// 1000 HU edge), with no drift (the comparison is against the position taken, not last frame's).
  double commitVoxels = 1e-3;
  /// Frames during motion (Redo::BricksDuringMotion) redo a brick only once the tissue around it
  /// may have moved more than this many voxels (along any axis) since the brick was last resampled:
  /// its image may lag the tissue by that much. A settled frame (Redo::Bricks) redoes every brick
  /// whose tissue moved at all. docs/gpu-deformation.md states what it means in HU.
  double motionLagVoxels = 0.5;
  /// Tets whose voxel range in the region exceeds this are skipped and counted (a torn state must
  /// not make one invocation loop for seconds); 0: defaultMaxTetVoxels of the rest mesh.
  std::uint64_t maxTetVoxels = 0;
  /// Per fine tet, its tissue's strain limit (sim/tissue_limits.h tetStrainLimits; inf: none). With
  /// it the strain passes also make the strain-over-limit volume the raymarch highlights tissue past
  /// its limit with; null: no limits. Finite values must be > 0; NaN is refused.
  const std::vector<float>* strainLimits = nullptr;
  /// Per handle (the order of the poses: CoarseFrameState::handles, setHandlePoses), its id in the
  /// mask when the resampling draws it where its pose puts it (a sliding handle), 0 when the fine
  /// tets draw it (a glued one); empty: none. Ids up to 255.
  std::vector<std::uint32_t> rigidIds;
  /// Per handle (as rigidIds), the index box [lo, hi] of its voxels at rest: the bricks a rigid
  /// handle's motion redoes (its rim may lie where no moved node is). Empty: the region's box.
  std::vector<std::array<Eigen::Vector3i, 2>> rigidRestBoxes;
};

/// What a frame redoes.
enum class Redo {
  /// The bricks (HANDSON_DEFORM_BRICK voxels a side) whose tissue may have moved more than
  /// motionLagVoxels since they were last resampled, redone at the exact fine positions; the others
  /// keep their image: the interactive path during motion.
  BricksDuringMotion,
  /// Every brick whose tissue moved at all since it was last resampled: the settled frame after
  /// motion, equal to a whole redo bit for bit; refined positions.
  Bricks,
  Moved,       ///< the box of the tets that moved since the last frame (the baseline before bricks)
  Region,      ///< every voxel of the simulated region
  WholeVolume  ///< every voxel of the volume (the baseline: a resampler without dirty regions)
};

struct DeformFrameStats {
  Eigen::Vector3i boxLo{0, 0, 0}, boxHi{-1, -1, -1};  ///< voxels redone (inclusive; empty when lo > hi)
  std::uint32_t movedTets = 0, coveredVoxels = 0, skippedTets = 0;
  bool bricks = false;           ///< the frame redid dirty bricks (Redo::Bricks*), not the box
  std::uint32_t dirtyBricks = 0;  ///< bricks redone (brick mode)
  bool allBricks = false;         ///< every brick was redone: a moved tet spanned too many to mark
  std::uint64_t boxVoxels() const;
  /// Voxels redone: the box's, or the dirty bricks' (each counted whole, HANDSON_DEFORM_BRICK³).
  std::uint64_t redoneVoxels() const;
  std::vector<PassTiming> timings;
};

class GpuDeformer {
 public:
  /// Uploads the static data and makes the deformed volume and mask: copies of `source` (R16_UNORM)
  /// and `sourceMask` (R8_UNORM), which must allow transfer reads and stay alive. Fine nodes start
  /// at rest. Throws handson::Error on inconsistent data or an unsupported device.
  GpuDeformer(const Context& ctx, const Image& source, const Image& sourceMask, const DeformSetup& setup, std::uint32_t framesInFlight = 2);
  ~GpuDeformer();

  struct Outputs {
    fg::ResourceHandle volume, mask;  ///< deformed images, left in Access::Sampled
  };
  const Image& maskImage() const { return mask_; }
  /// Where a frame's passes go in the caller's graph.
  struct FrameImports {
    std::uint32_t slot;  ///< the executor's frame slot (per-slot upload buffers; {} gives 0)
    /// The graph's handles of the source images when the caller imported them already (so its own
    /// passes on them are ordered with ours); else imported here.
    fg::ResourceHandle sourceVolume, sourceMask;
    Outputs outputs;  ///< the deformed images' handles when importOutputs() gave them already this frame
  };
  /// Adds one frame's passes.
  Outputs addPasses(fg::FrameGraph& graph, const CoarseFrameState& state, Redo redo = Redo::Moved, const FrameImports& at = {});
  /// Adds one frame's passes from fine node positions computed elsewhere (voxel index space: the
  /// two-level refinement of a held pose), uploaded through the slot's buffer; with Redo::Moved or Redo::Bricks only
  /// the moved box or the bricks whose tissue moved are redone. Megabytes, not kilobytes: for the occasional refined state, not every frame.
  Outputs addPassesFromPositions(fg::FrameGraph& graph, const std::vector<Eigen::Vector4f>& indexPositions, Redo redo = Redo::Moved,
                                 const FrameImports& at = {});
  /// Adds the strain passes (render/deform_strain_pass.h) at the fine positions this frame's
  /// addPasses / addPassesFromPositions computed, over the same box or bricks. Call it after one of
  /// those, in the same graph. With strain limits (DeformSetup::strainLimits) the raster also writes
  /// each voxel's strain over its tet's limit.
  using StrainOutputs = DeformStrainPass::Outputs;
  StrainOutputs addStrainPass(fg::FrameGraph& graph);
  /// Imports the strain volumes as the last strain passes left them (a frame without new
  /// positions); invalid handles before the first addStrainPass (perTet is never imported).
  StrainOutputs importStrainVolume(fg::FrameGraph& graph) { return strain_->importVolumes(graph); }
  bool hasStrainLimits() const { return strain_->hasLimits(); }
  /// The strain per fine tet, the strain volume and the strain-over-limit volume (x fastest), read
  /// back after a frame with the pass.
  std::vector<float> readStrain() const { return strain_->readPerTet(); }
  std::vector<float> readStrainVolume() const { return strain_->readVolume(); }
  std::vector<float> readStrainOverLimitVolume() const { return strain_->readOverLimitVolume(); }
  /// One frame on its own graph from fine positions (voxel index space; the region redone) with the
  /// strain passes, waited for; returns the strain per fine tet.
  std::vector<float> runStrain(const std::vector<Eigen::Vector4f>& indexPositions);
  /// Imports the deformed images alone (a frame without new state reads them as they are).
  Outputs importOutputs(fg::FrameGraph& graph);
  /// The region's voxel box (inclusive) on the volume grid.
  Eigen::Vector3i regionVoxelLo() const { return {p_.regionVoxLo.x, p_.regionVoxLo.y, p_.regionVoxLo.z}; }
  Eigen::Vector3i regionVoxelHi() const { return {p_.regionVoxHi.x, p_.regionVoxHi.y, p_.regionVoxHi.z}; }

  /// The handles' world poses the next frames from positions draw the rigid handles at
  /// (DeformSetup::rigidIds, one pose each); a frame from a coarse state takes its own.
  void setHandlePoses(const std::vector<Eigen::Matrix4f>& worldPoses);

  /// One frame on its own graph and executor, waited for; returns the box and counters.
  DeformFrameStats runFrame(const CoarseFrameState& state, Redo redo = Redo::Moved);
  /// One frame on its own graph from fine positions (voxel index space) taken as the next state after
  /// the current one (addPassesFromPositions), waited for.
  DeformFrameStats runFrameFromPositions(const std::vector<Eigen::Vector4f>& indexPositions, Redo redo);
  /// One Redo::Bricks frame from `state` (with the strain passes if asked) on its own graph, waited
  /// for: the images at the state's exact answer (the caller's frames must not be in flight).
  DeformFrameStats settle(const CoarseFrameState& state, bool withStrain);
  /// Resamples the region from fine node positions computed elsewhere (voxel index space: the
  /// fine reference, the two-level refinement), uploaded whole (for the command line, not frames).
  DeformFrameStats runFrame(const std::vector<Eigen::Vector4f>& indexPositions);

  /// Fine node positions last taken (voxel index space), deformed volume (u16) and mask, read back.
  std::vector<Eigen::Vector4f> readPositions() const;
  std::vector<std::uint16_t> readVolume() const;
  std::vector<std::uint8_t> readMask() const;
  const Image& volume() const { return volume_; }
  const Image& mask() const { return mask_; }
  std::size_t fineNodeCount() const { return nodes_; }
  std::size_t fineTetCount() const { return tets_; }

 private:
  void createPipelines();
  void uploadStaticData(const DeformSetup& setup, const ValidatedDeformSetup& valid);
  void importResources(fg::FrameGraph& g, bool withState, const FrameImports& at = {});
  Outputs addResamplePasses(fg::FrameGraph& g, Redo redo);
  void addResetPass(fg::FrameGraph& g, Redo redo);
  void addArgsPass(fg::FrameGraph& g, Redo redo);
  void addClearPass(fg::FrameGraph& g);
  void addClaimPass(fg::FrameGraph& g);
  void addResolvePass(fg::FrameGraph& g);
  /// The passes that choose what a frame redoes (the moved box; the bricks' lag and list).
  void addRedoSelection(fg::FrameGraph& g, Redo redo);
  /// The interpolation's commit threshold (voxels) for a frame of this kind.
  float commitFor(Redo redo) const;
  DeformFrameStats runOwn(const std::function<void(fg::FrameGraph&)>& build);

  struct Slot {
    std::unique_ptr<Buffer> positions, rotations, handles, fine, rigid;
  };
  /// Writes the slot's RigidDraws (the rigid handles at poses_, index space; their boxes' motion
  /// since lastPoses_, which become poses_).
  void writeRigidDraws(Slot& s);
  const Context& ctx_;
  const Image& source_;
  const Image& sourceMask_;
  Sampler nearest_;  ///< the shaders only texelFetch
  ComputePipeline interpolate_, bounds_, bricks_, args_, clear_, claim_, resolve_;
  Buffer params_, nodeInfo_, rest_, blocks_, elementCorners_, coarseRest_, tetBuffer_, restIdx_, pos_, prev_, box_, argsBuffer_, owner_, affine_;
  Buffer brickFlags_, brickList_;  ///< uint per brick: this frame's motion, then 1 = redo; the redone ones listed
  Buffer brickLag_;                ///< float per brick: the lag accumulated since it was last resampled
  Image volume_, mask_;
  std::vector<Slot> slots_;
  std::unique_ptr<GraphExecutor> ownExecutor_;
  std::unique_ptr<Buffer> boxReadback_;
  std::unique_ptr<DeformStrainPass> strain_;  ///< made once the setup is checked
  gpu::DeformParams p_{};
  std::size_t nodes_ = 0, tets_ = 0, coarseNodes_ = 0, coarseElements_ = 0;
  std::uint32_t handles_ = 0;
  float commit_ = 1e-3f, motionLag_ = 0.5f;
  std::vector<std::uint32_t> rigidIds_;
  std::vector<std::array<Eigen::Vector3i, 2>> rigidBoxes_;  ///< per handle: its voxels' index box at rest
  std::vector<Eigen::Matrix4f> poses_;      ///< the handles' world poses the rigid handles are drawn at
  std::vector<Eigen::Matrix4f> lastPoses_;  ///< those of the last frame written (the bricks' motion)
  Eigen::Matrix4d worldToIndex_ = Eigen::Matrix4d::Identity();
  struct Bound {
    fg::ResourceHandle params, nodeInfo, rest, blocks, elementCorners, coarseRest, tets, restIdx, posNew, posOld, box, args, owner, affine, source, sourceMask,
        volume, mask, positions, rotations, handles, brickFlags, brickList, brickLag, rigid;
    fg::ResourceHandle fineUpload;
    bool onlyOutputs = false;
  } h_;
};

}  // namespace handson::vk
