#version 450
#extension GL_GOOGLE_include_directive : require
// GPU depth picking: for each requested screen point, the first sample along its viewing ray at
// which the accumulated opacity (same compositing as the raymarch) passes the pick threshold, or,
// on a ray that stays fainter than that but ends at least pickFaintAlpha opaque, its most visible
// sample; its handle id, or that of a handle just behind it (shared.h: kPickHandleReach).
#include "shared.h"
layout(local_size_x = HANDSON_PICK_GROUP_X) in;
#include "march_common.glsl"
layout(std430, set = 0, binding = kBindOutput) writeonly buffer Out { PickResult results[]; };
layout(std430, set = 0, binding = kBindPickInput) readonly buffer In { vec4 points[]; };

// The handle id just behind the surface point th (sample t: the one the surface was found at),
// within the pick's reach; 0 when none.
int handleBehind(vec3 o, vec3 d, float t, float th, float t1, float step) {
  float reach = min(th + max(HANDSON_PICK_HANDLE_REACH_MM, HANDSON_PICK_HANDLE_REACH_VOXELS / max(length(d), 1e-6)), t1);
  for (uint k = 1u; k < 4096u; ++k) {
    float u = t + float(k) * step;
    if (u >= reach) break;
    uint hid;
    float hv = materialAt(o + u * d, hid);
    if (hid != 0u && hv >= 0.0 && transferAt(o + u * d, hv).a > 0.0) return int(hid);
  }
  return 0;
}

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
    bool hit = false;
    float hitT = 0.0, hitTh = 0.0;  // the sample the surface is found at, and the surface point
    uint hitId = 0u;
    float bestShare = 0.0, bestT = 0.0;  // the most visible sample so far (faint rays)
    uint bestId = 0u;
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
      uint sid;
      float value = materialAt(idx, sid);
      if (value < 0.0) continue;
      vec4 s = transferAt(idx, value);
      if (s.a <= 0.0) continue;
      float before = alpha;
      float a = correctedAlpha(s.a, step);
      alpha += (1.0 - alpha) * a;
      if ((1.0 - before) * a > bestShare) {
        bestShare = (1.0 - before) * a;
        bestT = t;
        bestId = sid;
      }
      if (alpha >= P.pickAlpha) {
        // Accumulated opacity interpolated linearly between this sample and the previous one.
        float f = clamp((P.pickAlpha - before) / max(alpha - before, 1e-6), 0.0, 1.0);
        hit = true;
        hitT = t;
        hitTh = max(t - step + f * step, t0);
        hitId = sid;
        break;
      }
    }
    if (!hit && P.pickFaintAlpha > 0.0 && alpha >= P.pickFaintAlpha && bestShare > 0.0) {
      // Its opacity accrues over the step before it: the middle of that step.
      hit = true;
      hitT = bestT;
      hitTh = max(bestT - 0.5 * step, t0);
      hitId = bestId;
    }
    if (hit) {
      r.world = vec4(originW + hitTh * dirW, 1.0);
      r.voxel = ivec4(ivec3(floor(o + hitTh * d + 0.5)), int(hitId));
      if (hitId == 0u) r.voxel.w = handleBehind(o, d, hitT, hitTh, t1, step);
    }
  }
  results[id] = r;
}
