#version 450
#extension GL_GOOGLE_include_directive : require
#extension GL_KHR_shader_subgroup_arithmetic : require
// Tetrahedral rasterization, step two: every claimed voxel of this frame's box (or dirty bricks) takes the source
// sampled trilinearly at its rest position in the owner tet (barycentric coordinates in the
// deformed tet applied to the rest positions: the affine map deform_claim.comp stored) and the
// handle id of the nearest rest voxel.
// One invocation per voxel of the box (uniform work, no atomics but one counter per subgroup),
// dispatched indirectly like deform_clear.comp. CPU reference: rasterizeDeformed in
// sim/tet_raster.cpp.
#include "shared.h"
layout(local_size_x = HANDSON_DEFORM_CLEAR_GROUP, local_size_y = HANDSON_DEFORM_CLEAR_GROUP, local_size_z = HANDSON_DEFORM_CLEAR_GROUP) in;
layout(std430, set = 0, binding = kBindDeformResolveParams) readonly buffer Params { DeformParams P; };
layout(std430, set = 0, binding = kBindDeformResolveAffine) readonly buffer Affine { vec4 affine[]; };
layout(std430, set = 0, binding = kBindDeformResolveBox) buffer Box { DeformBox box; };
layout(std430, set = 0, binding = kBindDeformResolveOwner) readonly buffer Owner { uint owner[]; };
layout(set = 0, binding = kBindDeformResolveSource) uniform sampler3D uSource;
layout(set = 0, binding = kBindDeformResolveSourceMask) uniform sampler3D uSourceMask;
layout(set = 0, binding = kBindDeformResolveOut, r16) uniform writeonly image3D uOut;
layout(set = 0, binding = kBindDeformResolveOutMask, r8) uniform writeonly image3D uOutMask;
layout(std430, set = 0, binding = kBindDeformResolveBrickList) readonly buffer BrickList { uint brickList[]; };
#include "deform_voxel.glsl"

// Trilinear interpolation from eight texel fetches with float weights (hardware filtering may use
// 8-bit weights), clamped at the edges like Volume::sampleLinear.
float sampleTrilinear(vec3 idx) {
  vec3 p = clamp(idx, vec3(0.0), vec3(P.dims.xyz - 1));
  ivec3 i0 = ivec3(floor(p));
  vec3 f = p - vec3(i0);
  ivec3 i1 = min(i0 + 1, P.dims.xyz - 1);
  float c000 = texelFetch(uSource, ivec3(i0.x, i0.y, i0.z), 0).r, c100 = texelFetch(uSource, ivec3(i1.x, i0.y, i0.z), 0).r;
  float c010 = texelFetch(uSource, ivec3(i0.x, i1.y, i0.z), 0).r, c110 = texelFetch(uSource, ivec3(i1.x, i1.y, i0.z), 0).r;
  float c001 = texelFetch(uSource, ivec3(i0.x, i0.y, i1.z), 0).r, c101 = texelFetch(uSource, ivec3(i1.x, i0.y, i1.z), 0).r;
  float c011 = texelFetch(uSource, ivec3(i0.x, i1.y, i1.z), 0).r, c111 = texelFetch(uSource, ivec3(i1.x, i1.y, i1.z), 0).r;
  float c00 = mix(c000, c100, f.x), c10 = mix(c010, c110, f.x), c01 = mix(c001, c101, f.x), c11 = mix(c011, c111, f.x);
  return mix(mix(c00, c10, f.y), mix(c01, c11, f.y), f.z);
}

void main() {
  ivec3 v;
  bool inBox = deformVoxel(v);
  bool claimed = false;
  ivec3 o = v - P.regionVoxLo.xyz;
  // A whole-volume redo covers voxels outside the region's owner grid: nothing to resolve there.
  if (inBox && all(greaterThanEqual(o, ivec3(0))) && all(lessThan(o, P.ownerDims.xyz))) {
    uint own = owner[uint(o.x + P.ownerDims.x * (o.y + P.ownerDims.y * o.z))];
    claimed = own != 0u && own != kDeformNoOwner;
    if (claimed) {
      uint a = 3u * (own - 1u);
      vec4 p = vec4(vec3(v), 1.0);
      vec3 r = vec3(dot(affine[a], p), dot(affine[a + 1u], p), dot(affine[a + 2u], p));
      imageStore(uOut, v, vec4(sampleTrilinear(r)));
      ivec3 m = clamp(ivec3(floor(r + 0.5)), ivec3(0), P.dims.xyz - 1);
      imageStore(uOutMask, v, texelFetch(uSourceMask, m, 0));
    }
  }
  uint covered = subgroupAdd(claimed ? 1u : 0u);
  if (subgroupElect() && covered > 0u) atomicAdd(box.stats.y, covered);
}
