#version 450
#extension GL_GOOGLE_include_directive : require
// Resets the voxels of this frame's box or dirty bricks: region voxels to the background (mask 0),
// the others to the source; no owner. Dispatched indirectly (deform_args.comp, deform_voxel.glsl).
#include "shared.h"
layout(local_size_x = HANDSON_DEFORM_CLEAR_GROUP, local_size_y = HANDSON_DEFORM_CLEAR_GROUP, local_size_z = HANDSON_DEFORM_CLEAR_GROUP) in;
layout(std430, set = 0, binding = kBindDeformClearParams) readonly buffer Params { DeformParams P; };
layout(std430, set = 0, binding = kBindDeformClearBox) readonly buffer Box { DeformBox box; };
layout(set = 0, binding = kBindDeformClearSource) uniform sampler3D uSource;
layout(set = 0, binding = kBindDeformClearSourceMask) uniform sampler3D uSourceMask;
layout(set = 0, binding = kBindDeformClearOut, r16) uniform writeonly image3D uOut;
layout(set = 0, binding = kBindDeformClearOutMask, r8) uniform writeonly image3D uOutMask;
layout(std430, set = 0, binding = kBindDeformClearOwner) writeonly buffer Owner { uint owner[]; };
layout(std430, set = 0, binding = kBindDeformClearBrickList) readonly buffer BrickList { uint brickList[]; };
#include "deform_voxel.glsl"

void main() {
  ivec3 v;
  if (!deformVoxel(v)) return;
  vec3 w = (P.indexToWorld * vec4(vec3(v), 1.0)).xyz;
  bool inside = all(greaterThanEqual(w - P.regionLo, vec3(-1e-3))) && all(greaterThanEqual(P.regionHi - w, vec3(-1e-3)));
  ivec3 o = v - P.regionVoxLo;
  if (all(greaterThanEqual(o, ivec3(0))) && all(lessThan(o, P.ownerDims)))
    owner[o.x + P.ownerDims.x * (o.y + P.ownerDims.y * o.z)] = inside ? kDeformNoOwner : 0u;
  imageStore(uOut, v, inside ? vec4(P.background) : texelFetch(uSource, v, 0));
  imageStore(uOutMask, v, inside ? vec4(0.0) : texelFetch(uSourceMask, v, 0));
}
