#version 450
#extension GL_GOOGLE_include_directive : require
// Clamps the box (to the region's voxels, or to the volume for a whole-volume redo) and writes the
// indirect dispatch of deform_clear.comp.
#include "shared.h"
layout(local_size_x = 1) in;
layout(std430, set = 0, binding = kBindDeformArgsParams) readonly buffer Params { DeformParams P; };
layout(std430, set = 0, binding = kBindDeformArgsBox) buffer Box { DeformBox box; };
layout(std430, set = 0, binding = kBindDeformArgsArgs) writeonly buffer Args { uvec4 args; };
layout(push_constant) uniform Push { uint wholeVolume; } pc;

void main() {
  ivec3 lo = max(box.lo.xyz, pc.wholeVolume != 0u ? ivec3(0) : P.regionVoxLo.xyz);
  ivec3 hi = min(box.hi.xyz, pc.wholeVolume != 0u ? P.dims.xyz - 1 : P.regionVoxHi.xyz);
  box.lo.xyz = lo;
  box.hi.xyz = hi;
  uvec3 groups = uvec3(0u);
  if (all(lessThanEqual(lo, hi))) groups = uvec3((hi - lo + HANDSON_DEFORM_CLEAR_GROUP) / HANDSON_DEFORM_CLEAR_GROUP);
  args = uvec4(groups, 0u);
}
