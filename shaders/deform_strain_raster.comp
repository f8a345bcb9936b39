#version 450
#extension GL_GOOGLE_include_directive : require
// The strain volume: every voxel of this frame's box (or dirty bricks) takes the strain of the tet that claimed it
// (deform_claim.comp's owner, the same tet the deformed image was sampled through), 0 where no tet
// did (outside the region, uncovered) and where the strain is not finite. With per-tet strain limits
// (P.writeOverLimit = 1) the voxel also takes that tet's strain over its tissue's limit (0 where the
// tissue has none or either is not finite): the raymarch highlights voxels past 1; a limit below 0
// (a sliding handle's own tet, kRigidStrainLimit) shows no strain either. One invocation
// per voxel of the box, dispatched indirectly like deform_resolve.comp. CPU references:
// strainVolume (sim/strain.cpp) and strainOverLimitVolume (sim/tissue_limits.cpp) on
// rasterizeDeformed's tet map.
#include "shared.h"
layout(local_size_x = HANDSON_DEFORM_CLEAR_GROUP, local_size_y = HANDSON_DEFORM_CLEAR_GROUP, local_size_z = HANDSON_DEFORM_CLEAR_GROUP) in;
layout(std430, set = 0, binding = kBindDeformStrainRasterParams) readonly buffer Params { DeformParams P; };
layout(std430, set = 0, binding = kBindDeformStrainRasterBox) readonly buffer Box { DeformBox box; };
layout(std430, set = 0, binding = kBindDeformStrainRasterOwner) readonly buffer Owner { uint owner[]; };
layout(std430, set = 0, binding = kBindDeformStrainRasterStrain) readonly buffer Strain { float strain[]; };
layout(set = 0, binding = kBindDeformStrainRasterOut, r32f) uniform writeonly image3D uOut;
layout(std430, set = 0, binding = kBindDeformStrainRasterLimits) readonly buffer Limits { float limit[]; };
layout(set = 0, binding = kBindDeformStrainRasterLimitOut, r32f) uniform writeonly image3D uLimitOut;
layout(std430, set = 0, binding = kBindDeformStrainRasterBrickList) readonly buffer BrickList { uint brickList[]; };
#include "deform_voxel.glsl"

void main() {
  ivec3 v;
  if (!deformVoxel(v)) return;
  float s = 0.0, r = 0.0;
  ivec3 o = v - P.regionVoxLo;
  if (all(greaterThanEqual(o, ivec3(0))) && all(lessThan(o, P.ownerDims))) {
    uint own = owner[uint(o.x + P.ownerDims.x * (o.y + P.ownerDims.y * o.z))];
    if (own != 0u && own != kDeformNoOwner && own != kDeformRigidOwner) {  // a handle drawn rigidly: none
      float e = strain[own - 1u];
      s = isnan(e) || isinf(e) ? 0.0 : e;
      if (P.writeOverLimit != 0u) {
        float l = limit[own - 1u];
        if (l < 0.0) s = 0.0;  // a sliding handle's own tet: rigid, its apparent strain hidden
        r = s != 0.0 && l > 0.0 && !isinf(l) && !isnan(l) ? s / l : 0.0;
      }
    }
  }
  imageStore(uOut, v, vec4(s));
  if (P.writeOverLimit != 0u) imageStore(uLimitOut, v, vec4(r));
}
