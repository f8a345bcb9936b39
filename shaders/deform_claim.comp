#version 450
#extension GL_GOOGLE_include_directive : require
// Tetrahedral rasterization of the deformed fine mesh (docs/gpu-deformation.md), step
// one: each fine tet claims the region voxels of this frame's box (or of its dirty bricks) whose
// centres it covers, for the
// lowest-numbered tet (atomicMin of tet + 1; the owner buffer holds 0 outside the region, so those
// voxels are never claimed). One invocation per tet. deform_resolve.comp then fills each claimed
// voxel from its owner through the affine map stored here. CPU reference: rasterizeDeformed in sim/tet_raster.cpp.
#include "shared.h"
layout(local_size_x = HANDSON_DEFORM_GROUP_X) in;
layout(std430, set = 0, binding = kBindDeformClaimParams) readonly buffer Params { DeformParams P; };
layout(std430, set = 0, binding = kBindDeformClaimTets) readonly buffer Tets { uvec4 tet[]; };
layout(std430, set = 0, binding = kBindDeformClaimPos) readonly buffer Pos { vec4 pos[]; };
layout(std430, set = 0, binding = kBindDeformClaimBox) buffer Box { DeformBox box; };
layout(std430, set = 0, binding = kBindDeformClaimOwner) buffer Owner { uint owner[]; };
layout(std430, set = 0, binding = kBindDeformClaimRestIdx) readonly buffer RestIdx { vec4 restIdx[]; };
// Per tet: the affine map from deformed to rest voxel index (rows of [M | b]), for the resolve.
layout(std430, set = 0, binding = kBindDeformClaimAffine) writeonly buffer Affine { vec4 affine[]; };
layout(std430, set = 0, binding = kBindDeformClaimBrickFlags) readonly buffer Flags { uint flags[]; };

// The dirty-brick index of a region voxel.
uint deformBrickOf(ivec3 v) {
  ivec3 c = (v - P.regionVoxLo) / HANDSON_DEFORM_BRICK;
  return uint(c.x + P.brickGrid.x * (c.y + P.brickGrid.y * c.z));
}

// Brick mode: whether a region voxel's brick is redone this frame.
bool brickDirty(ivec3 v) { return box.allBricksDirty != 0u || flags[deformBrickOf(v)] != 0u; }

// Brick mode: whether any brick the voxel range [lo, hi] (in the region) meets is redone.
bool anyBrickDirty(ivec3 lo, ivec3 hi) {
  if (box.allBricksDirty != 0u) return true;
  ivec3 blo = (lo - P.regionVoxLo) / HANDSON_DEFORM_BRICK, bhi = (hi - P.regionVoxLo) / HANDSON_DEFORM_BRICK;
  for (int z = blo.z; z <= bhi.z; ++z)
    for (int y = blo.y; y <= bhi.y; ++y)
      for (int x = blo.x; x <= bhi.x; ++x)
        if (flags[x + P.brickGrid.x * (y + P.brickGrid.y * z)] != 0u) return true;
  return false;
}

void main() {
  uint t = gl_GlobalInvocationID.x;
  if (t >= uint(P.fineTetCount)) return;
  uvec4 n = tet[t];
  vec3 v0 = pos[n.x].xyz, v1 = pos[n.y].xyz, v2 = pos[n.z].xyz, v3 = pos[n.w].xyz;
  vec3 bmin = min(min(v0, v1), min(v2, v3)), bmax = max(max(v0, v1), max(v2, v3));
  // The voxel range in the region, widened by kRasterBoxMargin (sim/tet_raster.h).
  ivec3 lo = max(ivec3(ceil(clamp(bmin, vec3(-1.0), vec3(P.volumeDims)) - 1e-4)), P.regionVoxLo);
  ivec3 hi = min(ivec3(floor(clamp(bmax, vec3(-1.0), vec3(P.volumeDims)) + 1e-4)), P.regionVoxHi);
  if (any(greaterThan(lo, hi))) return;
  // A tet stretched over more voxels than any sane state gives (a torn solve) is skipped, not
  // looped over for seconds: one invocation must stay short. (Judged on its range in the region,
  // not in this frame's box, so a moved-box frame equals a whole-region one.)
  uvec3 ext = uvec3(hi - lo + 1);
  if (ext.x * ext.y * ext.z > P.maxTetVoxels) {
    if (all(lessThanEqual(max(lo, box.lo), min(hi, box.hi)))) atomicAdd(box.skippedTets, 1u);
    return;
  }
  bool bricks = box.brickMode != 0u;
  if (bricks) {
    if (!anyBrickDirty(lo, hi)) return;
    // Within one brick (most tets), or with every brick redone: no test per voxel.
    bricks = box.allBricksDirty == 0u && deformBrickOf(lo) != deformBrickOf(hi);
  } else {
    lo = max(lo, box.lo);
    hi = min(hi, box.hi);
    if (any(greaterThan(lo, hi))) return;
  }
  mat3 D = mat3(v1 - v0, v2 - v0, v3 - v0);
  float det = determinant(D);
  if (!(abs(det) > 1e-12)) return;
  mat3 Dinv = inverse(D);
  // r = r0 + Rest (Dinv (x - v0)): the rest position of the point with the same barycentric
  // coordinates, as one affine map.
  vec3 r0 = restIdx[n.x].xyz;
  mat3 M = mat3(restIdx[n.y].xyz - r0, restIdx[n.z].xyz - r0, restIdx[n.w].xyz - r0) * Dinv;
  vec3 b = r0 - M * v0;
  affine[3u * t] = vec4(M[0].x, M[1].x, M[2].x, b.x);
  affine[3u * t + 1u] = vec4(M[0].y, M[1].y, M[2].y, b.y);
  affine[3u * t + 2u] = vec4(M[0].z, M[1].z, M[2].z, b.z);
  // Tolerance on the barycentric coordinates (kRasterTolerance in sim/tet_raster.h): voxel centres
  // on shared faces are claimed by both neighbours (the lower index wins), never by neither.
  const float eps = 1e-5;
  for (int z = lo.z; z <= hi.z; ++z)
    for (int y = lo.y; y <= hi.y; ++y)
      for (int x = lo.x; x <= hi.x; ++x) {
        vec3 l = Dinv * (vec3(x, y, z) - v0);
        float l0 = 1.0 - l.x - l.y - l.z;
        if (min(min(l.x, l.y), min(l.z, l0)) < -eps) continue;
        if (bricks && !brickDirty(ivec3(x, y, z))) continue;
        ivec3 o = ivec3(x, y, z) - P.regionVoxLo;
        atomicMin(owner[uint(o.x + P.ownerDims.x * (o.y + P.ownerDims.y * o.z))], t + 1u);
      }
}
