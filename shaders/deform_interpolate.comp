#version 450
#extension GL_GOOGLE_include_directive : require
// Fine node positions from the coarse state (docs/simulation-model.md): one invocation
// per fine node, output in voxel index space. CPU reference: interpolateFineReference in
// sim/fine_interpolation.cpp (same float expressions, same order).
// A node's position is committed (and its tets redone) only when it moved by more than
// pc.commit voxels from the committed one, so the image is never more than that behind the
// simulation and slow drifts still accumulate into a commit. prev[] keeps the position it had.
#include "shared.h"
layout(local_size_x = HANDSON_DEFORM_GROUP_X) in;
layout(std430, set = 0, binding = kBindDeformInterpolateParams) readonly buffer Params { DeformParams P; };
layout(std430, set = 0, binding = kBindDeformInterpolateNodes) readonly buffer Nodes { uvec4 node[]; };
layout(std430, set = 0, binding = kBindDeformInterpolateRest) readonly buffer Rest { vec4 rest[]; };
layout(std430, set = 0, binding = kBindDeformInterpolateBlocks) readonly buffer Blocks { vec4 blk[]; };
layout(std430, set = 0, binding = kBindDeformInterpolateElements) readonly buffer Elements { uvec4 corners[]; };  // two per element
layout(std430, set = 0, binding = kBindDeformInterpolateCoarseRest) readonly buffer CoarseRest { vec4 crest[]; };
layout(std430, set = 0, binding = kBindDeformInterpolateCoarsePos) readonly buffer CoarsePos { vec4 cpos[]; };
layout(std430, set = 0, binding = kBindDeformInterpolateRotations) readonly buffer Rotations { vec4 rot[]; };
layout(std430, set = 0, binding = kBindDeformInterpolateHandles) readonly buffer Handles { mat4 handle[]; };
layout(std430, set = 0, binding = kBindDeformInterpolateOut) buffer Out { vec4 pos[]; };
layout(std430, set = 0, binding = kBindDeformInterpolatePrev) writeonly buffer Prev { vec4 prev[]; };
layout(push_constant) uniform Push { float commit; } pc;  // voxels; negative: commit every node

mat3 quatToMat3(vec4 q) {
  float n = dot(q, q);
  float s = n > 0.0 ? 2.0 / n : 0.0;
  float x = q.x, y = q.y, z = q.z, w = q.w;
  // Columns (GLSL is column-major); rows as in quaternionMatrix().
  return mat3(vec3(1.0 - s * (y * y + z * z), s * (x * y + w * z), s * (x * z - w * y)),
              vec3(s * (x * y - w * z), 1.0 - s * (x * x + z * z), s * (y * z + w * x)),
              vec3(s * (x * z + w * y), s * (y * z - w * x), 1.0 - s * (x * x + y * y)));
}

mat3 block3(uint o) { return mat3(blk[o].xyz, blk[o + 1].xyz, blk[o + 2].xyz); }

void main() {
  uint f = gl_GlobalInvocationID.x;
  if (f >= uint(P.fineNodeCount)) return;
  uvec4 n = node[f];
  vec3 X = rest[f].xyz;
  vec3 p = X;
  if (n.x == kFineHandle) {
    mat4 T = handle[n.y];
    p = mat3(T) * X + T[3].xyz;
  } else if (n.x == kFineCorner) {
    p = cpos[n.y].xyz;
  } else if (n.x == kFineBoundary) {
    // Corners in groups of four (one uvec4 of indices, one vec4 of weights): constant lane indices.
    p = vec3(0.0);
    for (uint h = 0u; h < P.cornersPerElement / 4u; ++h) {
      uvec4 cs = corners[2u * n.y + h];
      vec4 N = blk[n.z + h];
      for (int k = 0; k < 4; ++k) p += N[k] * cpos[cs[k]].xyz;
    }
  } else if (n.x == kFineInterior) {
    mat3 R = quatToMat3(rot[n.y]);
    mat3 Rt = transpose(R);
    vec3 q = X;
    uint o = n.z;
    for (uint h = 0u; h < P.cornersPerElement / 4u; ++h) {
      uvec4 cs = corners[2u * n.y + h];
      for (int k = 0; k < 4; ++k, o += 3u) q += block3(o) * (Rt * cpos[cs[k]].xyz - crest[cs[k]].xyz);
    }
    for (uint g = 0u; g < n.w; ++g) {
      mat4 T = blk[o].x < 0.0 ? mat4(1.0) : handle[uint(blk[o].x)];  // -1: the anchored skeleton (identity)
      ++o;
      mat3 M = Rt * mat3(T) - mat3(1.0);
      for (int j = 0; j < 3; ++j, o += 3u) q += block3(o) * M[j];
      q += block3(o) * (Rt * T[3].xyz);
      o += 3u;
    }
    p = R * q;
  }
  vec4 now = vec4(mat3(P.worldToIndex) * p + P.worldToIndex[3].xyz, 1.0);
  vec4 old = pos[f];
  prev[f] = old;
  if (pc.commit < 0.0 || any(greaterThan(abs(now.xyz - old.xyz), vec3(pc.commit)))) pos[f] = now;
}
