#version 450
#extension GL_GOOGLE_include_directive : require
#extension GL_KHR_shader_subgroup_arithmetic : require
// Tetrahedral rasterization, step two: every claimed voxel of this frame's box (or dirty bricks) takes the source
// sampled trilinearly at its rest position in the owner tet (barycentric coordinates in the
// deformed tet applied to the rest positions: the affine map deform_claim.comp stored) and the
// handle id of the nearest rest voxel. A handle drawn rigidly (RigidDraw, a sliding one) takes
// first every voxel whose rest voxel under its pose is its own (owner set to kDeformRigidOwner); a
// voxel the tets map onto such a handle's rest voxels elsewhere is tissue that slid there: it takes
// the value of the nearest voxel outside the handles drawn rigidly, mask 0.
// One invocation per voxel of the box (uniform work, no atomics but one counter per subgroup),
// dispatched indirectly like deform_clear.comp. CPU reference: rasterizeDeformed in
// sim/tet_raster.cpp.
#include "shared.h"
layout(local_size_x = HANDSON_DEFORM_CLEAR_GROUP, local_size_y = HANDSON_DEFORM_CLEAR_GROUP, local_size_z = HANDSON_DEFORM_CLEAR_GROUP) in;
layout(std430, set = 0, binding = kBindDeformResolveParams) readonly buffer Params { DeformParams P; };
layout(std430, set = 0, binding = kBindDeformResolveAffine) readonly buffer Affine { vec4 affine[]; };
layout(std430, set = 0, binding = kBindDeformResolveBox) buffer Box { DeformBox box; };
layout(std430, set = 0, binding = kBindDeformResolveOwner) buffer Owner { uint owner[]; };
layout(set = 0, binding = kBindDeformResolveSource) uniform sampler3D uSource;
layout(set = 0, binding = kBindDeformResolveSourceMask) uniform sampler3D uSourceMask;
layout(set = 0, binding = kBindDeformResolveOut, r16) uniform writeonly image3D uOut;
layout(set = 0, binding = kBindDeformResolveOutMask, r8) uniform writeonly image3D uOutMask;
layout(std430, set = 0, binding = kBindDeformResolveBrickList) readonly buffer BrickList { uint brickList[]; };
layout(std430, set = 0, binding = kBindDeformResolveRigid) readonly buffer Rigid { uvec4 rigidCount; RigidDraw rigid[]; };
#include "deform_voxel.glsl"

uint maskAt(ivec3 i) { return uint(texelFetch(uSourceMask, clamp(i, ivec3(0), P.volumeDims - 1), 0).r * 255.0 + 0.5); }
ivec3 nearestVoxel(vec3 r) { return clamp(ivec3(floor(r + 0.5)), ivec3(0), P.volumeDims - 1); }

bool drawnRigidly(uint id) {
  for (uint m = 0u; m < rigidCount.x; ++m)
    if (rigid[m].id.x == id) return true;
  return false;
}

// Trilinear interpolation from eight texel fetches with float weights (hardware filtering may use
// 8-bit weights), clamped at the edges like Volume::sampleLinear.
float sampleTrilinear(vec3 idx) {
  vec3 p = clamp(idx, vec3(0.0), vec3(P.volumeDims - 1));
  ivec3 i0 = ivec3(floor(p));
  vec3 f = p - vec3(i0);
  ivec3 i1 = min(i0 + 1, P.volumeDims - 1);
  float c000 = texelFetch(uSource, ivec3(i0.x, i0.y, i0.z), 0).r, c100 = texelFetch(uSource, ivec3(i1.x, i0.y, i0.z), 0).r;
  float c010 = texelFetch(uSource, ivec3(i0.x, i1.y, i0.z), 0).r, c110 = texelFetch(uSource, ivec3(i1.x, i1.y, i0.z), 0).r;
  float c001 = texelFetch(uSource, ivec3(i0.x, i0.y, i1.z), 0).r, c101 = texelFetch(uSource, ivec3(i1.x, i0.y, i1.z), 0).r;
  float c011 = texelFetch(uSource, ivec3(i0.x, i1.y, i1.z), 0).r, c111 = texelFetch(uSource, ivec3(i1.x, i1.y, i1.z), 0).r;
  float c00 = mix(c000, c100, f.x), c10 = mix(c010, c110, f.x), c01 = mix(c001, c101, f.x), c11 = mix(c011, c111, f.x);
  return mix(mix(c00, c10, f.y), mix(c01, c11, f.y), f.z);
}

// The value of the voxel nearest to idx (within 2 voxels along each axis of its nearest voxel)
// outside the handles drawn rigidly: the tissue beside the rest position, which lies on a handle's
// rim; the plain trilinear when there is none. CPU reference: VoxelSource::nearestTissue.
float nearestTissue(vec3 idx) {
  ivec3 n = nearestVoxel(idx);
  float best = 1e30, value = sampleTrilinear(idx);
  for (int dz = -2; dz <= 2; ++dz)
    for (int dy = -2; dy <= 2; ++dy)
      for (int dx = -2; dx <= 2; ++dx) {
        ivec3 i = n + ivec3(dx, dy, dz);
        if (any(lessThan(i, ivec3(0))) || any(greaterThanEqual(i, P.volumeDims))) continue;
        vec3 e = vec3(i) - idx;
        float d2 = dot(e, e);
        if (d2 >= best || drawnRigidly(maskAt(i))) continue;
        best = d2;
        value = texelFetch(uSource, i, 0).r;
      }
  return value;
}

// The first handle drawn rigidly whose own voxel is where v's rest position under its pose lies.
bool rigidAt(ivec3 v, out vec3 r, out uint id) {
  for (uint m = 0u; m < rigidCount.x; ++m) {
    r = (rigid[m].currentToRest * vec4(vec3(v), 1.0)).xyz;
    if (any(lessThan(r, vec3(-0.5))) || any(greaterThanEqual(r, vec3(P.volumeDims) - 0.5))) continue;
    if (maskAt(nearestVoxel(r)) == rigid[m].id.x) {
      id = rigid[m].id.x;
      return true;
    }
  }
  return false;
}

void main() {
  ivec3 v;
  bool inBox = deformVoxel(v);
  bool claimed = false;
  ivec3 o = v - P.regionVoxLo;
  // A whole-volume redo covers voxels outside the region's owner grid: nothing to resolve there.
  if (inBox && all(greaterThanEqual(o, ivec3(0))) && all(lessThan(o, P.ownerDims))) {
    uint own = owner[uint(o.x + P.ownerDims.x * (o.y + P.ownerDims.y * o.z))];
    claimed = own != 0u && own != kDeformNoOwner;
    vec3 r;
    uint id;
    if (claimed && rigidAt(v, r, id)) {
      owner[uint(o.x + P.ownerDims.x * (o.y + P.ownerDims.y * o.z))] = kDeformRigidOwner;
      imageStore(uOut, v, vec4(sampleTrilinear(r)));
      imageStore(uOutMask, v, vec4(float(id) / 255.0));
    } else if (claimed) {
      uint a = 3u * (own - 1u);
      vec4 p = vec4(vec3(v), 1.0);
      r = vec3(dot(affine[a], p), dot(affine[a + 1u], p), dot(affine[a + 2u], p));
      ivec3 m = nearestVoxel(r);
      bool slid = rigidCount.x > 0u && drawnRigidly(maskAt(m));
      imageStore(uOut, v, vec4(slid ? nearestTissue(r) : sampleTrilinear(r)));
      imageStore(uOutMask, v, slid ? vec4(0.0) : texelFetch(uSourceMask, m, 0));
    }
  }
  uint covered = subgroupAdd(claimed ? 1u : 0u);
  if (subgroupElect() && covered > 0u) atomicAdd(box.coveredVoxels, covered);
}
