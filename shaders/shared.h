// Shared between C++ and GLSL: workgroup sizes, binding numbers and the parameter-block layouts of
// the compute passes. C++ includes it with glm types; GLSL includes it with GL_GOOGLE_include_directive.
// Every block is made of 16-byte groups (a mat4, a vec4, an ivec4, a vec3 or ivec3 and one scalar,
// or four scalars), so std140, std430 and C++ agree; the static_asserts below keep them so. Each
// field means one thing and says so by its name; flags are bits with names. The blocks are read-only storage buffers (std430), not
// uniform buffers: lavapipe (Mesa 22.3) inlines uniform-buffer values that steer loops and compiles
// a new shader variant each time the buffer is bound, every frame, keeping each until the device is
// destroyed (two LLVM compiles and ~0.5 MiB a frame, measured with `handson soak`).
#ifndef HANDSON_SHADERS_SHARED_H
#define HANDSON_SHADERS_SHARED_H

#ifdef __cplusplus
#include <cstddef>
#include <cstdint>
#include <glm/glm.hpp>
namespace handson::gpu {
using mat4 = glm::mat4;
using vec4 = glm::vec4;
using ivec4 = glm::ivec4;
using uvec4 = glm::uvec4;
using vec3 = glm::vec3;
using ivec3 = glm::ivec3;
using uint = std::uint32_t;
#define HS_CONST constexpr std::uint32_t
#else
#define HS_CONST const uint
#endif

// Workgroup sizes. Macros, because GLSL's local_size_x needs a literal (a constant would become
// LocalSizeId, which needs maintenance4).
#define HANDSON_RAYMARCH_GROUP_X 8
#define HANDSON_RAYMARCH_GROUP_Y 8
#define HANDSON_PICK_GROUP_X 64
#define HANDSON_BRICK_GROUP_X 64
#define HANDSON_GROW_BRICK 8          // region growing: bricks of 8^3 voxels, one workgroup each
#define HANDSON_COMPACT_GROUP_X 64
#define HANDSON_DEFORM_GROUP_X 64     // deformation passes: one invocation per fine node or tet
#define HANDSON_DEFORM_CLEAR_GROUP 4  // deform_clear.comp: 4^3 voxels per workgroup
#define HANDSON_DEFORM_BRICK 8        // dirty bricks of 8^3 voxels: (8/4)^3 = 8 workgroups each
HS_CONST kRaymarchGroupX = HANDSON_RAYMARCH_GROUP_X;
HS_CONST kRaymarchGroupY = HANDSON_RAYMARCH_GROUP_Y;
HS_CONST kPickGroupX = HANDSON_PICK_GROUP_X;
HS_CONST kBrickGroupX = HANDSON_BRICK_GROUP_X;

// Empty-space skipping: bricks of kBrickSize^3 voxels, each with the min/max normalized value over
// the brick plus a one-voxel apron (every voxel a trilinear sample inside the brick can touch).
HS_CONST kBrickSize = 8;
// Bindings of brick_minmax.comp (one push-descriptor set).
HS_CONST kBindBrickMinmaxVolume = 0;
HS_CONST kBindBrickMinmaxOut = 1;

// Transfer-function lookup table: kTfEntries RGBA entries spanning the volume's value window, one
// row over value alone, or kTfGradientRows rows (row-major: row r at the gradient magnitude
// r / (kTfGradientRows - 1) of RenderParams.tfRowGradient) over value and gradient magnitude and
// then their envelope, the rows' largest entries (render/tf_table.h).
HS_CONST kTfEntries = 4096;
HS_CONST kTfGradientRows = 16;

// Picking: when the surface a ray stops at is not a handle's, a handle met just behind it (within
// kPickHandleReachVoxels voxels or kPickHandleReachMm along the ray, whichever is longer) is the one
// reported: the one- or two-voxel boundary layer that a deformation stretches over a moved handle,
// or a trilinear blend at its edge, covers what the user sees and touches as the handle.
#define HANDSON_PICK_HANDLE_REACH_VOXELS 2.0
#define HANDSON_PICK_HANDLE_REACH_MM 4.0

// Render flags.
HS_CONST kFlagEmptySpaceSkipping = 1u;
HS_CONST kFlagEarlyTermination = 2u;
HS_CONST kFlagShading = 4u;
HS_CONST kFlagStrainOverlay = 8u;  // raymarch: colour tissue by its strain (RenderParams.strainFrom/To/Weight)
HS_CONST kFlagLabelTint = 16u;     // raymarch: colour tissue by its organ label (kBindLabels, kLabelPalette)
HS_CONST kFlagClipBox = 32u;       // raymarch and pick: only inside RenderParams.clipMin..clipMax (world box)
HS_CONST kFlagClipPlane = 64u;     // raymarch and pick: only where dot(clipPlane.xyz, x) >= clipPlane.w
HS_CONST kFlagLimitHighlight = 128u;  // raymarch: colour tissue past its strain limit (kBindStrainLimit)
HS_CONST kFlagJitter = 256u;  // raymarch: each pixel's first sample offset by its blue-noise rank (kBindJitter, jitterPhase)
HS_CONST kFlagAccumulate = 512u;  // raymarch: a still frame's running sum in kBindAccum (summedFrames frames in it)
HS_CONST kFlagShowSum = 1024u;    // raymarch with kFlagAccumulate: the still frame is complete: show its sum's mean, march nothing

// Bindings of the raymarch and pick passes (one push-descriptor set).
HS_CONST kBindParams = 0;     // RenderParams (read-only storage buffer)
HS_CONST kBindVolume = 1;     // sampler3D, R16_UNORM, normalized value window
HS_CONST kBindTf = 2;         // storage buffer vec4[kTfEntries * rows] (rows: 1 or kTfGradientRows + 1)
HS_CONST kBindOccupancy = 3;  // storage buffer uint[brick count], 1 = brick may be visible
HS_CONST kBindOutput = 4;     // raymarch: rgba8 storage image; pick: storage buffer PickResult[]
HS_CONST kBindPickInput = 5;  // pick: storage buffer vec4[] (xy = NDC point)
HS_CONST kBindMask = 6;       // sampler3D, R8_UNORM handle ids (id / 255), same grid as the volume
HS_CONST kBindHandles = 7;    // storage buffer vec4[kMaxHandleIds]: rgb tint, a = tint weight (0: none)
HS_CONST kMaxHandleIds = 256; // id 0 = no handle
HS_CONST kMaxMovingHandles = 8;  // handles drawn at a rigid pose (RenderParams.moving, count in movingCount)
HS_CONST kBindStrain = 8;     // raymarch only: sampler3D, R32 float strain on the volume's grid (texelFetch)
HS_CONST kBindLabels = 9;     // raymarch only: sampler3D, R16_UNORM organ labels (label / 65535) on the volume's grid
HS_CONST kBindStrainLimit = 10;  // raymarch only: sampler3D, R32 float strain over its tissue's limit (texelFetch; 0: none)
HS_CONST kBindJitter = 11;    // raymarch only: storage buffer uint[kJitterTile²], the blue-noise tile's ranks (render/blue_noise.h)
HS_CONST kBindAccum = 12;     // raymarch only: rgba32f storage image, the running sum of a still frame's jitter phases
HS_CONST kJitterTile = 64;    // the tile's side (kBlueNoiseSize)
HS_CONST kJitterPhaseStep = 2531;  // each jitter phase shifts the ranks by round(kJitterTile² / golden ratio) (odd: all residues)
HS_CONST kLabelPaletteSize = 12;  // label l is drawn in colour l % 12 (shaders/raymarch.comp, labelTint)
// The label palette's rgb triples (GLSL and C++ alike: float[](HANDSON_LABEL_PALETTE)) and weight.
#define HANDSON_LABEL_PALETTE                                                                                      \
  0.90, 0.30, 0.25, 0.25, 0.65, 0.95, 0.35, 0.85, 0.35, 0.95, 0.80, 0.20, 0.75, 0.40, 0.90, 0.20, 0.85, 0.80, \
      0.95, 0.55, 0.15, 0.95, 0.45, 0.70, 0.55, 0.75, 0.25, 0.40, 0.45, 0.95, 0.70, 0.55, 0.35, 0.85, 0.85, 0.85
#define HANDSON_LABEL_TINT_WEIGHT 0.45
// Tissue past its strain limit (kFlagLimitHighlight: strain over limit > 1) is drawn in this colour,
// at this weight, over whatever tint it had: magenta, apart from the strain ramp's yellow to red.
#define HANDSON_LIMIT_COLOUR 0.95, 0.10, 0.90
#define HANDSON_LIMIT_WEIGHT 0.85

// A handle drawn moved rigidly (until the simulation deforms the tissue around it): for a sample at
// voxel index x, currentToRest * x is where the handle's material was.
struct MovingHandle {
  mat4 currentToRest;  // index space -> index space
  uvec4 id;            // x: handle id
  vec4 boxMin;         // xyz: where the handle now is, index space (a bound with a voxel's margin)
  vec4 boxMax;
};

// Camera and volume, for raymarching and picking.
// World space is the volume's physical space (RAS+, mm).
struct RenderParams {
  mat4 invViewProj;   // clip (Vulkan NDC, z in [0,1]) -> world
  mat4 worldToIndex;  // world (mm) -> continuous voxel index (voxel centres at integers)
  mat4 indexToWorld;  // inverse of the above
  vec3 eye;              // the eye's world position
  float opacityStepMm;   // the step the transfer function's opacities are given for (mm)
  ivec3 volumeDims;      // voxel counts
  int outputWidth;       // the output image (pixels)
  ivec3 brickCount;      // bricks of kBrickSize^3 voxels along each axis
  int outputHeight;
  float stepMm;          // the ray's step at full quality (picking always takes it)
  float stepScale;       // the raymarch's step over stepMm (the frame budget; 1: full quality)
  float earlyStopAlpha;  // kFlagEarlyTermination: a ray stops once this opaque
  float pickAlpha;       // a pick lands where the ray's opacity reaches this
  vec4 background;       // rgba composited behind the volume
  float ambient;         // shading (kFlagShading): Blinn-Phong's terms
  float diffuse;
  float specular;
  float shininess;
  uint flags;            // kFlag* bits
  uint pickCount;        // points in kBindPickInput
  uint maxSteps;         // a ray's most steps (twice the volume's diagonal, and some)
  uint movingCount;      // moving[0, movingCount) are drawn at their rigid pose
  float tfRowGradient;   // the gradient magnitude (normalized value per mm) of the transfer function's
                         // last row; 0: its table is over value alone (one row, no gradient computed)
  uint jitterPhase;      // kFlagJitter: which phase of the blue-noise offsets this frame takes
  uint summedFrames;     // kFlagAccumulate: the frames already summed in kBindAccum (0 starts the sum)
  float strainFrom;      // the strain overlay: the strain where the colour starts,
  float strainTo;        // where it is full,
  float strainWeight;    // and its weight there
  float pickFaintAlpha;  // a pick ray that never reaches pickAlpha but ends at least this opaque lands at
                         // its most visible sample (the largest share of the pixel's colour); 0: off
  float unused1;
  vec4 clipMin;          // xyz: the clip box's low corner (world mm; kFlagClipBox)
  vec4 clipMax;          // xyz: its high corner
  vec4 clipPlane;        // xyz unit normal n, w = D: what is kept is n.x >= D (world mm; kFlagClipPlane)
  MovingHandle moving[kMaxMovingHandles];
};

// One picked point: world.w = 1 on a hit, 0 on a miss; voxel.xyz = nearest voxel index, voxel.w =
// the handle id at the hit (0: none).
struct PickResult {
  vec4 world;
  ivec4 voxel;
};

// Region growing (shaders/region_grow.comp, region_compact.comp). Keys are uint per voxel of a
// box around the seed: steps (paper criterion) or the float bits of the squared distance in mm^2
// (smoothed criterion); 0xffffffff = unreached. See interaction/region_grow.h.
HS_CONST kGrowUnreached = 0xffffffffu;
HS_CONST kGrowListHeader = 4;  // active-brick lists start with {groups x, 1, 1, 0} (indirect dispatch)
HS_CONST kGrowMaxLocalIterations = 24;
// Bindings (one push-descriptor set each).
// region_grow.comp
HS_CONST kBindRegionGrowVolume = 0;
HS_CONST kBindRegionGrowKeys = 1;
HS_CONST kBindRegionGrowAccept = 2;
HS_CONST kBindRegionGrowList = 3;
HS_CONST kBindRegionGrowFlags = 4;
HS_CONST kBindRegionGrowReached = 5;
// region_compact.comp
HS_CONST kBindRegionCompactFlags = 0;
HS_CONST kBindRegionCompactList = 1;
HS_CONST kBindRegionCompactReached = 2;

// live_mask.comp: the live selection painted into a box of the handle-id mask (4 ids a word)
HS_CONST kBindLiveMaskKeys = 0;
HS_CONST kBindLiveMaskBase = 1;
HS_CONST kBindLiveMaskOut = 2;
#define HANDSON_LIVE_MASK_GROUP_X 64
HS_CONST kLiveMaskId = 255u;  // interaction/handles.h: HandleSet::kLiveSelectionId

struct LiveMaskPush {
  ivec4 boxDims;  // xyz: the box in voxels, w: words per row (ceil(x / 4))
  uvec4 bound;    // x: key bound of the live selection, y: words in the box
};

struct GrowPush {
  ivec4 boxMin;     // xyz: first voxel of the box in the volume
  ivec4 boxDims;    // xyz: box size in voxels, w: criterion (0 paper, 1 smoothed, 2 core)
  ivec4 brickDims;  // xyz: bricks over the box
  ivec4 seed;       // xyz: seed voxel in the volume, w: key bound
  vec4 spacing;     // xyz mm, w: seed value (u16 units, or 3x3x3 sum)
  vec4 tolerance;   // x: accept |value - seed value| < x; y: core tolerance (core criterion)
  uvec4 steps[2];   // path keys: step lengths by axis mask (1 x, 2 y, 4 z; growStepCosts), [0].x unused
};

// Deformation (shaders/deform_*.comp; CPU references sim/fine_interpolation.h, sim/tet_raster.h).
// Fine node kinds of deform_interpolate.comp (FineInterpolationData::Kind).
HS_CONST kFineRest = 0u;
HS_CONST kFineHandle = 1u;
HS_CONST kFineCorner = 2u;
HS_CONST kFineBoundary = 3u;
HS_CONST kFineInterior = 4u;
HS_CONST kDeformNoOwner = 0xffffffffu;
// Owner of a region voxel a rigidly drawn handle took (deform_resolve.comp): no tet, no strain.
HS_CONST kDeformRigidOwner = 0xfffffffeu;
// Bindings (one push-descriptor set each).
// deform_interpolate.comp
HS_CONST kBindDeformInterpolateParams = 0;
HS_CONST kBindDeformInterpolateNodes = 1;
HS_CONST kBindDeformInterpolateRest = 2;
HS_CONST kBindDeformInterpolateBlocks = 3;
HS_CONST kBindDeformInterpolateElements = 4;
HS_CONST kBindDeformInterpolateCoarseRest = 5;
HS_CONST kBindDeformInterpolateCoarsePos = 6;
HS_CONST kBindDeformInterpolateRotations = 7;
HS_CONST kBindDeformInterpolateHandles = 8;
HS_CONST kBindDeformInterpolateOut = 9;
HS_CONST kBindDeformInterpolatePrev = 10;
// deform_bounds.comp
HS_CONST kBindDeformBoundsParams = 0;
HS_CONST kBindDeformBoundsTets = 1;
HS_CONST kBindDeformBoundsPosNew = 2;
HS_CONST kBindDeformBoundsPosOld = 3;
HS_CONST kBindDeformBoundsBox = 4;
HS_CONST kBindDeformBoundsBrickMotion = 5;  // uint per brick: this frame's largest tet motion, float bits (brick mode)
// deform_bricks.comp
HS_CONST kBindDeformBricksParams = 0;
HS_CONST kBindDeformBricksBox = 1;
HS_CONST kBindDeformBricksFlags = 2;
HS_CONST kBindDeformBricksList = 3;  // the dirty bricks' indices, box.dirtyBrickCount of them
HS_CONST kBindDeformBricksLag = 4;   // float per brick: lag accumulated since it was last resampled
HS_CONST kBindDeformBricksRigid = 5; // RigidDraws: the rigid handles' boxes and motions
// deform_args.comp
HS_CONST kBindDeformArgsParams = 0;
HS_CONST kBindDeformArgsBox = 1;
HS_CONST kBindDeformArgsArgs = 2;
// deform_clear.comp
HS_CONST kBindDeformClearParams = 0;
HS_CONST kBindDeformClearBox = 1;
HS_CONST kBindDeformClearSource = 2;
HS_CONST kBindDeformClearSourceMask = 3;
HS_CONST kBindDeformClearOut = 4;
HS_CONST kBindDeformClearOutMask = 5;
HS_CONST kBindDeformClearOwner = 6;
HS_CONST kBindDeformClearBrickList = 7;
// deform_claim.comp
HS_CONST kBindDeformClaimParams = 0;
HS_CONST kBindDeformClaimTets = 1;
HS_CONST kBindDeformClaimPos = 2;
HS_CONST kBindDeformClaimBox = 3;
HS_CONST kBindDeformClaimOwner = 4;
HS_CONST kBindDeformClaimRestIdx = 5;
HS_CONST kBindDeformClaimAffine = 6;
HS_CONST kBindDeformClaimBrickFlags = 7;
// deform_resolve.comp
HS_CONST kBindDeformResolveParams = 0;
HS_CONST kBindDeformResolveAffine = 1;
HS_CONST kBindDeformResolveBox = 2;
HS_CONST kBindDeformResolveOwner = 3;
HS_CONST kBindDeformResolveSource = 4;
HS_CONST kBindDeformResolveSourceMask = 5;
HS_CONST kBindDeformResolveOut = 6;
HS_CONST kBindDeformResolveOutMask = 7;
HS_CONST kBindDeformResolveBrickList = 8;
HS_CONST kBindDeformResolveRigid = 9;  // RigidDraws: the handles drawn where their rigid poses put them
// deform_strain.comp
HS_CONST kBindDeformStrainParams = 0;
HS_CONST kBindDeformStrainTets = 1;
HS_CONST kBindDeformStrainRest = 2;
HS_CONST kBindDeformStrainPos = 3;
HS_CONST kBindDeformStrainOut = 4;
// deform_strain_raster.comp
HS_CONST kBindDeformStrainRasterParams = 0;
HS_CONST kBindDeformStrainRasterBox = 1;
HS_CONST kBindDeformStrainRasterOwner = 2;
HS_CONST kBindDeformStrainRasterStrain = 3;
HS_CONST kBindDeformStrainRasterOut = 4;
HS_CONST kBindDeformStrainRasterLimits = 5;    // float per fine tet: its tissue's strain limit (inf: none)
HS_CONST kBindDeformStrainRasterLimitOut = 6;  // r32f image: strain over limit (0: no limit, no tet)
HS_CONST kBindDeformStrainRasterBrickList = 7;

// Static per deformation setup (read-only storage buffer).
struct DeformParams {
  mat4 worldToIndex;
  mat4 indexToWorld;
  vec3 regionLo;          // the world box of the mesh at rest
  float background;       // the value outside the tissue (normalized)
  vec3 regionHi;
  float motionLagVoxels;  // the lag allowed during motion (voxels; DeformSetup::motionLagVoxels)
  ivec3 regionVoxLo;      // the voxel index box that can hold region voxels (inclusive)
  int fineNodeCount;
  ivec3 regionVoxHi;
  int fineTetCount;
  ivec3 volumeDims;       // voxel counts
  int handleCount;
  ivec3 ownerDims;        // regionVoxHi - regionVoxLo + 1 (the owner buffer)
  int coarseElementCount;
  uint maxTetVoxels;      // the most voxels a tet's range may hold (larger ones are skipped and counted)
  uint cornersPerElement; // 4 or 8
  uint writeOverLimit;    // 1: the strain raster also writes strain over each tet's limit (kBindDeformStrainRasterLimit*)
  uint unused0;
  ivec3 brickGrid;        // the dirty-brick grid over the region's voxel box (HANDSON_DEFORM_BRICK voxels a
                          // side, brick (0,0,0) at regionVoxLo, x fastest)
  int brickCount;
};

// A handle drawn rigidly by the resampling (a sliding handle: its voxels are where its pose puts
// them, not where the fine tets straddling its surface would): a voxel at index x whose rest voxel
// currentToRest * x (rounded) has the handle's id takes the source there (sim/tet_raster.h, RigidDraw).
// In brick mode the handle's voxels' index box at this frame's and the last frame's poses (their
// union) marks the bricks it meets with the largest motion of a point of the box (boxLo.w), as a
// moved tet does (deform_bricks.comp): the rim it draws may lie in bricks no moved node meets.
struct RigidDraw {
  mat4 currentToRest;  // index space -> index space
  uvec4 id;            // x: the handle's id in the mask
  vec4 boxLo;          // xyz: the union box, index space; w: its largest motion since the last frame (voxels, largest axis)
  vec4 boxHi;          // xyz
};

// The box redone this frame (storage buffer, written by deform_bounds.comp, clamped by
// deform_args.comp) and counters.
struct DeformBox {
  ivec3 lo;              // the voxel index box redone (inclusive)
  uint brickMode;        // 1: this frame redoes the dirty bricks listed (else the box)
  ivec3 hi;              // inclusive (lo > hi: nothing to redo)
  uint dirtyBrickCount;  // dirty bricks listed
  uint movedTets;
  uint coveredVoxels;
  uint skippedTets;      // tets skipped as too large (a torn state)
  uint allBricksDirty;   // 1: every brick is dirty (a moved tet spans more bricks than it may mark)
};

#ifdef __cplusplus
static_assert(sizeof(DeformParams) == 2 * 64 + 8 * 16, "DeformParams must match std140");
static_assert(offsetof(DeformParams, background) == 2 * 64 + 12 && offsetof(DeformParams, brickCount) == 2 * 64 + 7 * 16 + 12,
              "DeformParams' vec3 groups must pack as in GLSL");
static_assert(sizeof(DeformBox) == 48 && offsetof(DeformBox, dirtyBrickCount) == 28, "DeformBox must match std430");
static_assert(sizeof(RigidDraw) == 112, "RigidDraw must match std430");
static_assert(sizeof(LiveMaskPush) == 32, "LiveMaskPush must match std430");
static_assert(sizeof(GrowPush) <= 128, "push constants must fit lavapipe's 128 bytes");
static_assert(sizeof(MovingHandle) == 112, "MovingHandle must match std140");
static_assert(sizeof(RenderParams) == 3 * 64 + 12 * 16 + 8 * 112, "RenderParams must match std140");
// A vec3 or ivec3 followed by one scalar fills 16 bytes in GLSL: so must it here (no padding).
static_assert(offsetof(RenderParams, opacityStepMm) == 3 * 64 + 12 && offsetof(RenderParams, volumeDims) == 3 * 64 + 16 &&
                  offsetof(RenderParams, outputHeight) == 3 * 64 + 44 && offsetof(RenderParams, clipMin) == 3 * 64 + 9 * 16,
              "RenderParams' vec3 groups must pack as in GLSL");
static_assert(sizeof(PickResult) == 32, "PickResult must match std430");
}  // namespace handson::gpu
#endif
#undef HS_CONST
#endif
