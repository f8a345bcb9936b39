#version 450
#extension GL_GOOGLE_include_directive : require
#extension GL_KHR_shader_subgroup_arithmetic : require
// The box of voxels to redo this frame: the union of the old and new voxel bounding boxes of every
// fine tet with a node whose committed position changed (deform_interpolate.comp). One invocation
// per fine tet.
#include "shared.h"
layout(local_size_x = HANDSON_DEFORM_GROUP_X) in;
layout(std430, set = 0, binding = kBindDeformBoundsParams) readonly buffer Params { DeformParams P; };
layout(std430, set = 0, binding = kBindDeformBoundsTets) readonly buffer Tets { uvec4 tet[]; };
layout(std430, set = 0, binding = kBindDeformBoundsPosNew) readonly buffer PosNew { vec4 posNew[]; };
layout(std430, set = 0, binding = kBindDeformBoundsPosOld) readonly buffer PosOld { vec4 posOld[]; };  // before this frame's commits
layout(std430, set = 0, binding = kBindDeformBoundsBox) buffer Box { DeformBox box; };

void main() {
  uint t = gl_GlobalInvocationID.x;
  if (t >= uint(P.regionVoxHi.w)) return;
  uvec4 v = tet[t];
  bool moved = false;
  vec3 lo = vec3(1e30), hi = vec3(-1e30);
  for (int c = 0; c < 4; ++c) {
    vec3 a = posNew[v[c]].xyz, b = posOld[v[c]].xyz;
    moved = moved || any(notEqual(a, b));
    lo = min(lo, min(a, b));
    hi = max(hi, max(a, b));
  }
  // Reduce over the subgroup first: one lane's atomics instead of one per moved tet.
  ivec3 ilo = ivec3(floor(clamp(lo, vec3(-1.0), vec3(P.dims.xyz))));  // clamped before the int conversion
  ivec3 ihi = ivec3(ceil(clamp(hi, vec3(-1.0), vec3(P.dims.xyz))));
  if (!moved) {
    ilo = ivec3(2147483647);
    ihi = ivec3(-2147483647);
  }
  uint movedCount = subgroupAdd(moved ? 1u : 0u);
  ilo = subgroupMin(ilo);
  ihi = subgroupMax(ihi);
  if (subgroupElect() && movedCount > 0u) {
    atomicAdd(box.stats.x, movedCount);
    atomicMin(box.lo.x, ilo.x);
    atomicMin(box.lo.y, ilo.y);
    atomicMin(box.lo.z, ilo.z);
    atomicMax(box.hi.x, ihi.x);
    atomicMax(box.hi.y, ihi.y);
    atomicMax(box.hi.z, ihi.z);
  }
}
