#version 450
#extension GL_GOOGLE_include_directive : require
#extension GL_KHR_shader_subgroup_arithmetic : require
#extension GL_KHR_shader_subgroup_ballot : require
// The box of voxels to redo this frame: the union of the old and new voxel bounding boxes of every
// fine tet with a node whose committed position changed (deform_interpolate.comp). One invocation
// per fine tet. In brick mode (box.brickMode) a moved tet also raises, in every brick its old and new
// boxes meet (widened by the allowed lag, P.motionLagVoxels: the image a brick keeps may come from up to
// that far away), this frame's largest node motion (voxels along the largest axis; float bits, so
// atomicMax orders them): deform_bricks.comp adds it to the lag each brick has accumulated since it
// was last resampled. A tet whose boxes span more than kMaxMarkedBricks bricks (a torn state)
// makes every brick dirty at once.
#include "shared.h"
layout(local_size_x = HANDSON_DEFORM_GROUP_X) in;
layout(std430, set = 0, binding = kBindDeformBoundsParams) readonly buffer Params { DeformParams P; };
layout(std430, set = 0, binding = kBindDeformBoundsTets) readonly buffer Tets { uvec4 tet[]; };
layout(std430, set = 0, binding = kBindDeformBoundsPosNew) readonly buffer PosNew { vec4 posNew[]; };
layout(std430, set = 0, binding = kBindDeformBoundsPosOld) readonly buffer PosOld { vec4 posOld[]; };  // before this frame's commits
layout(std430, set = 0, binding = kBindDeformBoundsBox) buffer Box { DeformBox box; };
layout(std430, set = 0, binding = kBindDeformBoundsBrickMotion) buffer Motion { uint frameMotion[]; };

const int kMaxMarkedBricks = 64;

// Called by the moved tets only (divergent). Lanes whose bricks are the same (neighbouring tets
// mostly have the same) mark them once with their largest motion: the subgroup is taken in groups
// of equal ranges, the first remaining lane's group each round.
void markBricks(vec3 lo, vec3 hi, float motion) {
  ivec3 ilo = max(ivec3(floor(clamp(lo, vec3(-1.0), vec3(P.volumeDims)))), P.regionVoxLo);
  ivec3 ihi = min(ivec3(ceil(clamp(hi, vec3(-1.0), vec3(P.volumeDims)))), P.regionVoxHi);
  bool none = any(greaterThan(ilo, ihi));  // outside the region: nothing to mark
  ivec3 blo = none ? ivec3(0) : (ilo - P.regionVoxLo) / HANDSON_DEFORM_BRICK;
  ivec3 bhi = none ? ivec3(-1) : (ihi - P.regionVoxLo) / HANDSON_DEFORM_BRICK;
  for (;;) {
    ivec3 flo = subgroupBroadcastFirst(blo), fhi = subgroupBroadcastFirst(bhi);
    if (all(equal(blo, flo)) && all(equal(bhi, fhi))) {
      motion = subgroupMax(motion);
      if (!subgroupElect()) return;
      break;
    }
  }
  if (any(greaterThan(blo, bhi))) return;
  ivec3 n = bhi - blo + 1;
  if (n.x * n.y * n.z > kMaxMarkedBricks) {
    atomicOr(box.allBricksDirty, 1u);
    return;
  }
  for (int z = blo.z; z <= bhi.z; ++z)
    for (int y = blo.y; y <= bhi.y; ++y)
      for (int x = blo.x; x <= bhi.x; ++x) atomicMax(frameMotion[x + P.brickGrid.x * (y + P.brickGrid.y * z)], floatBitsToUint(motion));
}

void main() {
  uint t = gl_GlobalInvocationID.x;
  if (t >= uint(P.fineTetCount)) return;
  uvec4 v = tet[t];
  bool moved = false;
  float motion = 0.0;
  vec3 lo = vec3(1e30), hi = vec3(-1e30);
  for (int c = 0; c < 4; ++c) {
    vec3 a = posNew[v[c]].xyz, b = posOld[v[c]].xyz;
    moved = moved || any(notEqual(a, b));
    vec3 d = abs(a - b);
    motion = max(motion, max(d.x, max(d.y, d.z)));
    lo = min(lo, min(a, b));
    hi = max(hi, max(a, b));
  }
  // Reduce over the subgroup first: one lane's atomics instead of one per moved tet.
  ivec3 ilo = ivec3(floor(clamp(lo, vec3(-1.0), vec3(P.volumeDims))));  // clamped before the int conversion
  ivec3 ihi = ivec3(ceil(clamp(hi, vec3(-1.0), vec3(P.volumeDims))));
  if (box.brickMode != 0u) {
    // Brick mode: the box is the region's (deform-reset); only the moved tets are counted.
    if (moved) markBricks(lo - P.motionLagVoxels, hi + P.motionLagVoxels, motion);
    uint count = subgroupAdd(moved ? 1u : 0u);
    if (subgroupElect() && count > 0u) atomicAdd(box.movedTets, count);
    return;
  }
  if (!moved) {
    ilo = ivec3(2147483647);
    ihi = ivec3(-2147483647);
  }
  uint movedCount = subgroupAdd(moved ? 1u : 0u);
  ilo = subgroupMin(ilo);
  ihi = subgroupMax(ihi);
  if (subgroupElect() && movedCount > 0u) {
    atomicAdd(box.movedTets, movedCount);
    atomicMin(box.lo.x, ilo.x);
    atomicMin(box.lo.y, ilo.y);
    atomicMin(box.lo.z, ilo.z);
    atomicMax(box.hi.x, ihi.x);
    atomicMax(box.hi.y, ihi.y);
    atomicMax(box.hi.z, ihi.z);
  }
}
