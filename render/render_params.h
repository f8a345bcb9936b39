#pragma once
// Building the raymarch/pick uniform block (gpu::RenderParams) from a volume's geometry and a
// camera. Plain data: shared by the Vulkan passes and their CPU references.
#include <glm/glm.hpp>

#include <string>
#include <vector>

#include "shaders/shared.h"
#include "sim/rigid_transform.h"
#include "sim/volume.h"

namespace handson {

/// Clipping (world RAS mm): only what lies inside the box and on the kept side of the plane is drawn
/// or picked. The plane keeps n.x >= offset (n need not be unit length). The CLI (--clip-box,
/// --clip-plane), the session's actions and the clip gestures all go through the parsers below.
struct ClipRegion {
  bool box = false;
  glm::vec3 lo{0.0f}, hi{0.0f};
  bool plane = false;
  glm::vec3 normal{0.0f, 0.0f, 1.0f};
  float offset = 0.0f;
  bool operator==(const ClipRegion&) const = default;
};
/// "X0,Y0,Z0,X1,Y1,Z1" (finite, each low coordinate below the high one): sets the box and returns
/// "", else returns why not and leaves `clip` unchanged.
/// An Eigen matrix as glm's (column-major), in float.
glm::mat4 toGlm(const Eigen::Matrix4d& m);

std::string parseClipBox(const std::string& text, ClipRegion& clip);
/// "NX,NY,NZ,D" (finite, a non-zero normal): sets the plane and returns "", else returns why not.
std::string parseClipPlane(const std::string& text, ClipRegion& clip);
/// The text parseClipBox / parseClipPlane read back (round trip exact to float precision).
std::string formatClipBox(const ClipRegion& clip);
std::string formatClipPlane(const ClipRegion& clip);

struct RenderSettings {
  int width = 512, height = 512;
  /// Ray step as a fraction of the smallest voxel spacing.
  float stepFactor = 0.5f;
  bool emptySpaceSkipping = true;
  bool earlyTermination = true;
  bool shading = true;
  float terminationAlpha = 0.99f;
  /// Accumulated opacity at which a pick ray reports its surface.
  float pickThreshold = 0.5f;
  /// A ray that stays fainter than pickThreshold but ends at least this opaque (0.2: a fifth of its
  /// pixel's colour is the volume's) reports its most visible sample, the one whose share of the
  /// pixel's colour, (1 - alpha before it) * its opacity, is largest. 0 (the default): such rays miss.
  /// Not the app's default yet: a composed session's pinch then lands elsewhere (docs/frame.md).
  float pickFaintThreshold = 0.0f;
  glm::vec4 background{0.08f, 0.09f, 0.11f, 1.0f};
  glm::vec4 light{0.35f, 0.75f, 0.25f, 24.0f};  ///< ambient, diffuse, specular, shininess
  /// The strain overlay (while deforming): tissue coloured from strainFrom (none) to strainTo (full
  /// colour, yellow to red, weight strainWeight); strain as sim/strain.h defines it (0.3 = 30 %).
  bool strainOverlay = false;
  /// Tissue past its strain limit highlighted (while deforming with limits: DeformSetup::strainLimits),
  /// in HANDSON_LIMIT_COLOUR (shaders/shared.h).
  bool limitHighlight = false;
  /// Tissue tinted by its organ label (VolumeRenderer::setLabels; the palette in shaders/shared.h).
  bool labelTint = false;
  ClipRegion clip;
  float strainFrom = 0.0f, strainTo = 0.30f, strainWeight = 0.85f;
  /// The raymarch's sample step over the full-quality step (the frame budget, app/session/
  /// frame_budget.h; >= 1). Picking always takes the full-quality step.
  float raymarchStepScale = 1.0f;
  /// Each pixel's first raymarch sample offset by a blue-noise fraction of the step (render/
  /// blue_noise.h): no wood-grain bands where slices are thicker than the step. jitterPhase shifts
  /// the offsets (a still frame averages phases 0, 1, ...; picking is never jittered).
  bool jitter = true;
  int jitterPhase = 0;
};

/// Jitter phases a still frame sums (kFlagAccumulate): its noise falls as 1 / sqrt(phases).
inline constexpr int kStillJitterPhases = 8;

/// A still frame, one phase a frame: phase `before` added to the sum of the `before` earlier ones
/// (0 starts it; the jitter phase is `before`), the running mean shown; `before` >= `phases`: the
/// complete sum's mean shown, nothing marched. Needs kFlagJitter (otherwise every phase is alike).
void setStillPhase(gpu::RenderParams& params, int before, int phases = kStillJitterPhases);

/// view: world -> eye (right-handed, camera looks down -z); proj: eye -> Vulkan clip (z in [0,1],
/// NDC y down). eye: camera position in world (mm).
gpu::RenderParams makeRenderParams(const VolumeGeometry& geometry, const glm::mat4& view, const glm::mat4& proj,
                                   const glm::vec3& eye, const RenderSettings& settings, std::uint32_t pickCount = 0);

/// A handle drawn at a rigid pose: world_now = pose.apply(world_rest).
struct MovingHandlePose {
  std::uint32_t id = 0;
  RigidTransform pose;  ///< world_now = pose.apply(world_rest)
  Eigen::Vector3i restMin{0, 0, 0}, restMax{-1, -1, -1};  ///< the handle's voxel bounds at rest (index)
};

/// Fills params.moving and movingCount (at most gpu::kMaxMovingHandles; identity poses are skipped).
void setMovingHandles(gpu::RenderParams& params, const VolumeGeometry& geometry, const std::vector<MovingHandlePose>& handles);

/// Pixel centre (x, y) of a width x height image to NDC (x right, y down).
glm::vec2 pixelToNdc(float x, float y, int width, int height);

}  // namespace handson
