#version 450
#extension GL_GOOGLE_include_directive : require
// Direct volume rendering: front-to-back compositing along perspective rays, with gradient
// shading, early ray termination and empty-space skipping (both switchable for benchmarks).
#include "shared.h"
layout(local_size_x = HANDSON_RAYMARCH_GROUP_X, local_size_y = HANDSON_RAYMARCH_GROUP_Y) in;
#include "march_common.glsl"
layout(set = 0, binding = kBindOutput, rgba8) uniform writeonly image2D uOutput;
layout(set = 0, binding = kBindStrain) uniform sampler3D uStrain;
layout(set = 0, binding = kBindLabels) uniform sampler3D uLabels;
layout(set = 0, binding = kBindStrainLimit) uniform sampler3D uStrainLimit;
layout(std430, set = 0, binding = kBindJitter) readonly buffer Jitter { uint jitterRank[]; };
layout(set = 0, binding = kBindAccum, rgba32f) uniform image2D uAccum;

// Where, as a fraction of the step, a pixel's first sample lies: the middle of the first step, or
// with kFlagJitter the pixel's blue-noise rank shifted by the jitter phase (integer arithmetic, so
// the CPU reference finds the same offset). CPU reference: sampleOffset in render/raymarch_reference.cpp.
float sampleOffset(ivec2 px) {
  if ((P.flags & kFlagJitter) == 0u) return 0.5;
  uint tile = uint(kJitterTile);
  uint rank = jitterRank[(uint(px.y) % tile) * tile + uint(px.x) % tile];
  uint shifted = (rank + uint(P.jitterPhase) * uint(kJitterPhaseStep)) % (tile * tile);
  return (float(shifted) + 0.5) / float(tile * tile);
}

// The label tint (kFlagLabelTint): the nearest voxel's organ label in a fixed palette (label % 12),
// background (0) untouched. CPU reference: labelTint in render/raymarch_reference.cpp.
const float kLabelPalette[3 * kLabelPaletteSize] = float[](HANDSON_LABEL_PALETTE);
vec3 labelTint(vec3 c, vec3 idx) {
  ivec3 v = clamp(ivec3(floor(idx + 0.5)), ivec3(0), P.volumeDims - 1);
  uint l = uint(round(texelFetch(uLabels, v, 0).r * 65535.0));
  if (l == 0u) return c;
  uint k = 3u * (l % kLabelPaletteSize);
  return mix(c, vec3(kLabelPalette[k], kLabelPalette[k + 1u], kLabelPalette[k + 2u]), HANDSON_LABEL_TINT_WEIGHT);
}

// The strain overlay (kFlagStrainOverlay): the strain of the nearest voxel, from P.strainFrom (no
// colour) to P.strainTo (full colour, weight P.strainWeight), yellow to red. CPU reference:
// strainTint in render/raymarch_reference.cpp.
vec3 strainTint(vec3 c, vec3 idx) {
  ivec3 v = clamp(ivec3(floor(idx + 0.5)), ivec3(0), P.volumeDims - 1);
  float e = texelFetch(uStrain, v, 0).r;
  if (!(e > P.strainFrom)) return c;
  float w = clamp((e - P.strainFrom) / max(P.strainTo - P.strainFrom, 1e-6), 0.0, 1.0);
  vec3 ramp = mix(vec3(1.0, 0.85, 0.1), vec3(0.9, 0.05, 0.05), w);
  return mix(c, ramp, P.strainWeight * (0.25 + 0.75 * w));
}

// The limit highlight (kFlagLimitHighlight): where the nearest voxel's strain is past its tissue's
// limit (strain over limit > 1), HANDSON_LIMIT_COLOUR at HANDSON_LIMIT_WEIGHT. CPU reference:
// limitTint in render/raymarch_reference.cpp.
vec3 limitTint(vec3 c, vec3 idx) {
  ivec3 v = clamp(ivec3(floor(idx + 0.5)), ivec3(0), P.volumeDims - 1);
  if (!(texelFetch(uStrainLimit, v, 0).r > 1.0)) return c;
  return mix(c, vec3(HANDSON_LIMIT_COLOUR), HANDSON_LIMIT_WEIGHT);
}

void main() {
  ivec2 px = ivec2(gl_GlobalInvocationID.xy);
  int width = P.outputWidth, height = P.outputHeight;
  if (px.x >= width || px.y >= height) return;
  bool accumulate = (P.flags & kFlagAccumulate) != 0u;
  if (accumulate && (P.flags & kFlagShowSum) != 0u) {  // the still frame is complete: show its mean
    imageStore(uOutput, px, vec4(clamp(imageLoad(uAccum, px).rgb / float(P.summedFrames), 0.0, 1.0), 1.0));
    return;
  }
  vec2 ndc = (vec2(px) + 0.5) / vec2(width, height) * 2.0 - 1.0;
  uint flags = P.flags;
  vec3 color = vec3(0.0);
  float alpha = 0.0;
  vec3 originW, dirW;
  float t0, t1;
  if (setupRay(ndc, originW, dirW, t0, t1)) {
    vec3 o = (P.worldToIndex * vec4(originW, 1.0)).xyz;
    vec3 d = mat3(P.worldToIndex) * dirW;
    // The frame budget's step (1: the full-quality step; unset, 0, is taken as 1).
    float step = P.stepScale > 0.0 ? P.stepMm * P.stepScale : P.stepMm;
    uint maxSteps = P.maxSteps;
    // Samples sit at t0 + (n + offset) * step, whatever skipping does, so that skipping changes
    // nothing but the work done.
    float offset = sampleOffset(px);
    uint n = 0u;
    uint taken = 0u;
    float occupiedUntil = -1.0;  // ray distance up to which the current brick is known occupied
    while (taken < maxSteps) {
      float t = t0 + (float(n) + offset) * step;
      if (t >= t1) break;
      vec3 idx = o + t * d;
      if ((flags & kFlagEmptySpaceSkipping) != 0u && t >= occupiedUntil) {
        ivec3 brick;
        bool occupied = brickOccupied(idx, brick);
        float te = brickExit(o, d, brick);
        if (!occupied) {
          n = max(n + 1u, uint(ceil((te - t0) / step - offset)));
          ++taken;
          continue;
        }
        occupiedUntil = te;
      }
      ++taken;
      ++n;
      uint id;
      float value = materialAt(idx, id);
      if (value < 0.0) continue;  // the place a moved handle left
      // The gradient, when the transfer function or the shading needs it (once for both).
      bool overGradient = P.tfRowGradient > 0.0;
      if (overGradient && transparentAtAnyGradient(value)) continue;
      vec3 g = overGradient ? worldGradient(idx) : vec3(0.0);
      vec4 s = overGradient ? transfer2(value, length(g)) : transfer(value);
      if (s.a <= 0.0) continue;
      float a = correctedAlpha(s.a, step);
      vec3 c = s.rgb;
      if ((flags & kFlagLabelTint) != 0u && !isMoving(id)) c = labelTint(c, idx);
      if (id != 0u) c = mix(c, handleTint[id].rgb, handleTint[id].a);
      if ((flags & kFlagStrainOverlay) != 0u) c = strainTint(c, idx);
      if ((flags & kFlagLimitHighlight) != 0u) c = limitTint(c, idx);
      if ((flags & kFlagShading) != 0u) {
        if (!overGradient) g = worldGradient(idx);
        float gl = length(g);
        if (gl > 1e-6) {
          vec3 nrm = g / gl;
          float ndl = abs(dot(nrm, dirW));
          c = c * (P.ambient + P.diffuse * ndl) + vec3(P.specular * pow(ndl, P.shininess));
        } else {
          c = c * (P.ambient + P.diffuse);
        }
      }
      color += (1.0 - alpha) * a * c;
      alpha += (1.0 - alpha) * a;
      if ((flags & kFlagEarlyTermination) != 0u && alpha >= P.earlyStopAlpha) break;
    }
  }
  vec3 outc = clamp(color + (1.0 - alpha) * P.background.rgb * P.background.a, 0.0, 1.0);
  // A still frame: this phase added to the sum of the earlier ones, their mean shown (CPU
  // reference: raymarchReference's accumulation in render/raymarch_reference.cpp).
  if (accumulate) {
    vec3 sum = P.summedFrames > 0u ? imageLoad(uAccum, px).rgb + outc : outc;
    imageStore(uAccum, px, vec4(sum, 1.0));
    outc = sum / (float(P.summedFrames) + 1.0);
  }
  imageStore(uOutput, px, vec4(clamp(outc, 0.0, 1.0), 1.0));
}
