#version 450
#extension GL_GOOGLE_include_directive : require
// Which bricks to redo this frame. Each brick keeps the lag it has accumulated since it was last
// resampled: the sum, over the frames since, of the largest motion of a tet meeting it
// (deform_bounds.comp; voxels along the largest axis). By the triangle inequality the voxels it
// holds are at most that far from where the exact image has them. A brick is redone once its lag
// exceeds pc.lag (during motion), or is above 0 at all (pc.settle: the exact state), or when a moved
// tet spanned too many bricks to mark (all are redone); a redone brick's lag starts again from 0.
// A handle drawn rigidly (RigidDraw) moves the voxels of its box by at most its motion: a brick
// its box meets (widened by the allowed lag) takes that motion too.
// The redone ones are listed (for the per-voxel passes' indirect dispatch, deform_voxel.glsl) and
// flagged 1 in place of their frame motion (for deform_claim.comp), the others flagged 0. One
// invocation per brick; the list's order does not matter (every voxel is computed on its own).
#include "shared.h"
layout(local_size_x = HANDSON_DEFORM_GROUP_X) in;
layout(std430, set = 0, binding = kBindDeformBricksParams) readonly buffer Params { DeformParams P; };
layout(std430, set = 0, binding = kBindDeformBricksBox) buffer Box { DeformBox box; };
layout(std430, set = 0, binding = kBindDeformBricksFlags) buffer Flags { uint flags[]; };  // in: frame motion (float bits); out: 1 = redo
layout(std430, set = 0, binding = kBindDeformBricksList) writeonly buffer List { uint list[]; };
layout(std430, set = 0, binding = kBindDeformBricksLag) buffer Lag { float lag[]; };
layout(std430, set = 0, binding = kBindDeformBricksRigid) readonly buffer Rigid { uvec4 rigidCount; RigidDraw rigid[]; };
layout(push_constant) uniform Push { float lag; uint settle; } pc;

void main() {
  uint b = gl_GlobalInvocationID.x;
  if (b >= uint(P.brickCount)) return;
  float motion = uintBitsToFloat(flags[b]);
  ivec3 bc = ivec3(int(b % uint(P.brickGrid.x)), int((b / uint(P.brickGrid.x)) % uint(P.brickGrid.y)), int(b / uint(P.brickGrid.x * P.brickGrid.y)));
  vec3 lo = vec3(P.regionVoxLo + bc * HANDSON_DEFORM_BRICK), hi = lo + vec3(HANDSON_DEFORM_BRICK - 1);
  for (uint m = 0u; m < rigidCount.x; ++m) {
    vec4 blo = rigid[m].boxLo, bhi = rigid[m].boxHi;
    if (blo.w > 0.0 && all(lessThanEqual(blo.xyz - P.motionLagVoxels, hi)) && all(greaterThanEqual(bhi.xyz + P.motionLagVoxels, lo))) motion = max(motion, blo.w);
  }
  float acc = lag[b] + motion;
  bool redo = box.allBricksDirty != 0u || (pc.settle != 0u ? acc > 0.0 : acc > pc.lag);
  lag[b] = redo ? 0.0 : acc;
  flags[b] = redo ? 1u : 0u;
  if (redo) list[atomicAdd(box.dirtyBrickCount, 1u)] = b;
}
