#version 450
#extension GL_GOOGLE_include_directive : require
// GPU depth picking: for each requested screen point, the first sample along its viewing ray at
// which the accumulated opacity (same compositing as the raymarch) passes the pick threshold; its
// handle id, or that of a handle just behind it (shared.h: kPickHandleReach).
#include "shared.h"
layout(local_size_x = HANDSON_PICK_GROUP_X) in;
#include "march_common.glsl"
layout(std430, set = 0, binding = kBindOutput) writeonly buffer Out { PickResult results[]; };
layout(std430, set = 0, binding = kBindPickInput) readonly buffer In { vec4 points[]; };

void main() {
  uint id = gl_GlobalInvocationID.x;
  if (id >= P.pickCount) return;
  PickResult r;
  r.world = vec4(0.0);
  r.voxel = ivec4(-1, -1, -1, 0);
  vec3 originW, dirW;
  float t0, t1;
  vec2 ndc = points[id].xy;
  if (!any(isnan(ndc)) && setupRay(ndc, originW, dirW, t0, t1)) {
    vec3 o = (P.worldToIndex * vec4(originW, 1.0)).xyz;
    vec3 d = mat3(P.worldToIndex) * dirW;
    float step = P.stepMm;
    float alpha = 0.0;
    uint n = 0u, taken = 0u;
    float occupiedUntil = -1.0;
    while (taken < P.maxSteps) {
      float t = t0 + (float(n) + 0.5) * step;
      if (t >= t1) break;
      vec3 idx = o + t * d;
      if (t >= occupiedUntil) {
        ivec3 brick;
        bool occupied = brickOccupied(idx, brick);
        float te = brickExit(o, d, brick);
        if (!occupied) {
          n = max(n + 1u, uint(ceil((te - t0) / step - 0.5)));
          ++taken;
          continue;
        }
        occupiedUntil = te;
      }
      ++taken;
      ++n;
      uint id;
      float value = materialAt(idx, id);
      if (value < 0.0) continue;
      vec4 s = transferAt(idx, value);
      if (s.a <= 0.0) continue;
      float before = alpha;
      alpha += (1.0 - alpha) * correctedAlpha(s.a, step);
      if (alpha >= P.pickAlpha) {
        // Accumulated opacity interpolated linearly between this sample and the previous one.
        float f = clamp((P.pickAlpha - before) / max(alpha - before, 1e-6), 0.0, 1.0);
        float th = max(t - step + f * step, t0);
        r.world = vec4(originW + th * dirW, 1.0);
        r.voxel = ivec4(ivec3(floor(o + th * d + 0.5)), int(id));
        if (id == 0u) {
          float reach = min(th + max(HANDSON_PICK_HANDLE_REACH_MM, HANDSON_PICK_HANDLE_REACH_VOXELS / max(length(d), 1e-6)), t1);
          for (uint k = 1u; k < 4096u; ++k) {
            float u = t + float(k) * step;
            if (u >= reach) break;
            uint hid;
            float hv = materialAt(o + u * d, hid);
            if (hid != 0u && hv >= 0.0 && transferAt(o + u * d, hv).a > 0.0) {
              r.voxel.w = int(hid);
              break;
            }
          }
        }
        break;
      }
    }
  }
  results[id] = r;
}
