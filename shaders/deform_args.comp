#version 450
#extension GL_GOOGLE_include_directive : require
// Clamps the box (to the region's voxels, or to the volume for a whole-volume redo) and writes the
// indirect dispatch of the per-voxel passes (deform_clear.comp): over the box, or in brick mode
// (box.brickMode) 8 workgroups for each listed dirty brick (deform_voxel.glsl).
#include "shared.h"
layout(local_size_x = 1) in;
layout(std430, set = 0, binding = kBindDeformArgsParams) readonly buffer Params { DeformParams P; };
layout(std430, set = 0, binding = kBindDeformArgsBox) buffer Box { DeformBox box; };
layout(std430, set = 0, binding = kBindDeformArgsArgs) writeonly buffer Args { uvec4 args; };
layout(push_constant) uniform Push { uint wholeVolume; } pc;

void main() {
  ivec3 lo = max(box.lo, pc.wholeVolume != 0u ? ivec3(0) : P.regionVoxLo);
  ivec3 hi = min(box.hi, pc.wholeVolume != 0u ? P.volumeDims - 1 : P.regionVoxHi);
  box.lo = lo;
  box.hi = hi;
  uvec3 groups = uvec3(0u);
  if (box.brickMode != 0u) {
    const uint per = uint(HANDSON_DEFORM_BRICK / HANDSON_DEFORM_CLEAR_GROUP);
    uint n = box.dirtyBrickCount;
    if (n > 0u) groups = uvec3(per * per * per, min(n, 65535u), (n + 65534u) / 65535u);
  } else if (all(lessThanEqual(lo, hi))) {
    groups = uvec3((hi - lo + HANDSON_DEFORM_CLEAR_GROUP) / HANDSON_DEFORM_CLEAR_GROUP);
  }
  args = uvec4(groups, 0u);
}
