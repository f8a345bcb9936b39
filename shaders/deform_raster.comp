#version 450
#extension GL_GOOGLE_include_directive : require
// Tetrahedral rasterization of the deformed fine mesh (../shared/spec/methods.md section 6), one
// invocation per fine tet, restricted to this frame's box. Phase 0 claims each covered region
// voxel for the lowest-numbered tet (atomicMin of tet + 1; the owner buffer holds 0 outside the
// region, so those voxels are never claimed); phase 1 lets the owner write the source sampled trilinearly at
// the rest position and the handle id of the nearest rest voxel. CPU reference:
// rasterizeDeformed in sim/tet_raster.cpp.
#include "shared.h"
layout(local_size_x = HANDSON_DEFORM_GROUP_X) in;
layout(std140, set = 0, binding = 0) uniform Params { DeformParams P; };
layout(std430, set = 0, binding = 1) readonly buffer Tets { uvec4 tet[]; };
layout(std430, set = 0, binding = 2) readonly buffer Pos { vec4 pos[]; };
layout(std430, set = 0, binding = 3) buffer Box { DeformBox box; };
layout(std430, set = 0, binding = 4) buffer Owner { uint owner[]; };
layout(std430, set = 0, binding = 5) readonly buffer RestIdx { vec4 restIdx[]; };
layout(set = 0, binding = 6) uniform sampler3D uSource;
layout(set = 0, binding = 7) uniform sampler3D uSourceMask;
layout(set = 0, binding = 8, r16) uniform writeonly image3D uOut;
layout(set = 0, binding = 9, r8) uniform writeonly image3D uOutMask;
layout(push_constant) uniform Push { uint phase; } pc;

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
  uint t = gl_GlobalInvocationID.x;
  if (t >= uint(P.regionVoxHi.w)) return;
  uvec4 n = tet[t];
  vec3 v0 = pos[n.x].xyz, v1 = pos[n.y].xyz, v2 = pos[n.z].xyz, v3 = pos[n.w].xyz;
  vec3 bmin = min(min(v0, v1), min(v2, v3)), bmax = max(max(v0, v1), max(v2, v3));
  ivec3 lo = max(ivec3(ceil(clamp(bmin, vec3(-1.0), vec3(P.dims.xyz)) - 1e-4)), max(box.lo.xyz, P.regionVoxLo.xyz));
  ivec3 hi = min(ivec3(floor(clamp(bmax, vec3(-1.0), vec3(P.dims.xyz)) + 1e-4)), min(box.hi.xyz, P.regionVoxHi.xyz));
  if (any(greaterThan(lo, hi))) return;
  mat3 D = mat3(v1 - v0, v2 - v0, v3 - v0);
  float det = determinant(D);
  if (!(abs(det) > 1e-12)) return;
  mat3 Dinv = inverse(D);
  if (pc.phase == 1u) atomicAdd(box.stats.z, 1u);
  // Relative tolerance on the barycentric coordinates: voxel centres on shared faces are claimed
  // by both neighbours (the lower index wins), never by neither.
  const float eps = 1e-5;
  for (int z = lo.z; z <= hi.z; ++z)
    for (int y = lo.y; y <= hi.y; ++y)
      for (int x = lo.x; x <= hi.x; ++x) {
        vec3 l = Dinv * (vec3(x, y, z) - v0);
        float l0 = 1.0 - l.x - l.y - l.z;
        if (min(min(l.x, l.y), min(l.z, l0)) < -eps) continue;
        ivec3 o = ivec3(x, y, z) - P.regionVoxLo.xyz;
        uint cell = uint(o.x + P.ownerDims.x * (o.y + P.ownerDims.y * o.z));
        if (pc.phase == 0u) {
          atomicMin(owner[cell], t + 1u);
        } else if (owner[cell] == t + 1u) {
          vec3 r = l0 * restIdx[n.x].xyz + l.x * restIdx[n.y].xyz + l.y * restIdx[n.z].xyz + l.z * restIdx[n.w].xyz;
          imageStore(uOut, ivec3(x, y, z), vec4(sampleTrilinear(r)));
          ivec3 m = clamp(ivec3(floor(r + 0.5)), ivec3(0), P.dims.xyz - 1);
          imageStore(uOutMask, ivec3(x, y, z), texelFetch(uSourceMask, m, 0));
          atomicAdd(box.stats.y, 1u);
        }
      }
}
