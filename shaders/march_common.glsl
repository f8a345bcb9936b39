// Ray setup, sampling, transfer function and empty-space skipping shared by raymarch.comp and
// pick.comp. The CPU reference in render/raymarch_reference.cpp implements the same steps.
// Needs: #include "shared.h" and the bindings declared below.

layout(std430, set = 0, binding = kBindParams) readonly buffer Params { RenderParams P; };
layout(set = 0, binding = kBindVolume) uniform sampler3D uVolume;
layout(std430, set = 0, binding = kBindTf) readonly buffer Tf { vec4 tf[]; };
layout(std430, set = 0, binding = kBindOccupancy) readonly buffer Occ { uint occupancy[]; };
layout(set = 0, binding = kBindMask) uniform sampler3D uMask;
layout(std430, set = 0, binding = kBindHandles) readonly buffer Handles { vec4 handleTint[]; };

// Handle id of the voxel nearest to a continuous index (0: none).
uint handleAt(vec3 idx) {
  ivec3 v = clamp(ivec3(floor(idx + 0.5)), ivec3(0), P.volumeDims - 1);
  return uint(round(texelFetch(uMask, v, 0).r * 255.0));
}



// Normalized value at a continuous voxel index (voxel centres at integers), clamped at the edges.
float sampleVolume(vec3 idx) {
  return textureLod(uVolume, (idx + 0.5) / vec3(P.volumeDims), 0.0).r;
}

bool isMoving(uint id) {
  for (uint m = 0u; m < P.movingCount; ++m)
    if (P.moving[m].id.x == id) return true;
  return false;
}

// The material at a sample, with handles moved rigidly: a moved handle's own place is empty, and
// where its material now is, the value comes from its rest position. Returns the value and sets id.
float materialAt(vec3 idx, out uint id) {
  id = handleAt(idx);
  float v = sampleVolume(idx);
  if (P.movingCount == 0u) return v;
  if (id != 0u && isMoving(id)) {
    id = 0u;
    v = -1.0;  // nothing here any more (transparent below)
  }
  for (uint m = 0u; m < P.movingCount; ++m) {
    vec3 rest = (P.moving[m].currentToRest * vec4(idx, 1.0)).xyz;
    if (handleAt(rest) == P.moving[m].id.x) {
      id = P.moving[m].id.x;
      v = sampleVolume(rest);
    }
  }
  return v;
}

// Transfer function over value: linear interpolation between the entries of row `row`.
vec4 transferRow(uint row, float v) {
  float x = clamp(v, 0.0, 1.0) * float(kTfEntries - 1);
  int i0 = int(floor(x));
  int i1 = min(i0 + 1, int(kTfEntries) - 1);
  uint base = row * kTfEntries;
  return mix(tf[base + uint(i0)], tf[base + uint(i1)], x - float(i0));
}

// Transfer function over value alone (the first row).
vec4 transfer(float v) { return transferRow(0u, v); }

// Over value and gradient magnitude g (normalized value per mm; P.tfRowGradient > 0): bilinear
// between the rows around g / P.tfRowGradient * (kTfGradientRows - 1).
vec4 transfer2(float v, float g) {
  float y = clamp(g / P.tfRowGradient, 0.0, 1.0) * float(kTfGradientRows - 1);
  uint r0 = uint(floor(y));
  uint r1 = min(r0 + 1u, kTfGradientRows - 1u);
  return mix(transferRow(r0, v), transferRow(r1, v), y - float(r0));
}

// Central differences of the value at a continuous index (normalized value per voxel step).
vec3 gradientIndex(vec3 idx) {
  return 0.5 * vec3(sampleVolume(idx + vec3(1, 0, 0)) - sampleVolume(idx - vec3(1, 0, 0)),
                    sampleVolume(idx + vec3(0, 1, 0)) - sampleVolume(idx - vec3(0, 1, 0)),
                    sampleVolume(idx + vec3(0, 0, 1)) - sampleVolume(idx - vec3(0, 0, 1)));
}

// The gradient in world units (normalized value per mm): the index gradient through the transpose
// of worldToIndex's linear part.
vec3 worldGradient(vec3 idx) { return transpose(mat3(P.worldToIndex)) * gradientIndex(idx); }

// Whether a sample of this value is transparent whatever its gradient: the envelope row (the rows'
// largest entries) is. Exact: bilinear weights are >= 0, so every row is transparent there too.
bool transparentAtAnyGradient(float v) { return transferRow(kTfGradientRows, v).a <= 0.0; }

// The transfer function at a sample of known value: over value and the gradient's magnitude there
// when the table has that axis (the volume as it is at idx: a moved handle's gradient is taken
// where it is drawn, as the shading takes it), else over value.
vec4 transferAt(vec3 idx, float value) {
  if (P.tfRowGradient <= 0.0) return transfer(value);
  if (transparentAtAnyGradient(value)) return vec4(0.0);
  return transfer2(value, length(worldGradient(idx)));
}

// Clipping (kFlagClipBox, kFlagClipPlane): the ray's [t0, t1] narrowed to the world box and to the
// half-space n.x >= D, so the first sample and the first visible point lie behind the cut, for the
// raymarch and picking alike. CPU reference: clipRay in render/raymarch_reference.cpp.
void clipRay(vec3 originW, vec3 dirW, inout float t0, inout float t1) {
  uint flags = P.flags;
  if ((flags & kFlagClipBox) != 0u) {
    vec3 inv = 1.0 / dirW;
    vec3 ca = (P.clipMin.xyz - originW) * inv, cb = (P.clipMax.xyz - originW) * inv;
    vec3 cmin = min(ca, cb), cmax = max(ca, cb);
    t0 = max(t0, max(max(cmin.x, cmin.y), cmin.z));
    t1 = min(t1, min(min(cmax.x, cmax.y), cmax.z));
  }
  if ((flags & kFlagClipPlane) != 0u) {
    float nd = dot(P.clipPlane.xyz, dirW), no = dot(P.clipPlane.xyz, originW);
    if (nd > 1e-12) t0 = max(t0, (P.clipPlane.w - no) / nd);
    else if (nd < -1e-12) t1 = min(t1, (P.clipPlane.w - no) / nd);
    else if (no < P.clipPlane.w) t1 = t0;  // parallel to the plane, on the cut side
  }
}

// Ray through a point in NDC (x right, y down, both in [-1, 1]); returns false if it misses the
// volume box. Box in index space: [-0.5, dims - 0.5]. t is the distance along the world ray (mm).
bool setupRay(vec2 ndc, out vec3 originW, out vec3 dirW, out float t0, out float t1) {
  vec4 nearH = P.invViewProj * vec4(ndc, 0.0, 1.0);
  vec4 farH = P.invViewProj * vec4(ndc, 1.0, 1.0);
  originW = P.eye;
  dirW = normalize(farH.xyz / farH.w - nearH.xyz / nearH.w);
  vec3 o = (P.worldToIndex * vec4(originW, 1.0)).xyz;
  vec3 d = mat3(P.worldToIndex) * dirW;
  vec3 lo = vec3(-0.5), hi = vec3(P.volumeDims) - 0.5;
  vec3 inv = 1.0 / d;  // IEEE: +-inf for axis-parallel rays, handled by min/max below
  vec3 ta = (lo - o) * inv, tb = (hi - o) * inv;
  vec3 tmin = min(ta, tb), tmax = max(ta, tb);
  t0 = max(max(max(tmin.x, tmin.y), tmin.z), 0.0);
  t1 = min(min(tmax.x, tmax.y), tmax.z);
  clipRay(originW, dirW, t0, t1);
  return t1 > t0;
}

// Brick of a continuous index, and whether it may contain visible samples: by the transfer
// function's occupancy, or because a moved handle's material is now there.
bool brickOccupied(vec3 idx, out ivec3 brick) {
  brick = clamp(ivec3(floor((idx + 0.5) / float(kBrickSize))), ivec3(0), P.brickCount - 1);
  if (occupancy[(brick.z * P.brickCount.y + brick.y) * P.brickCount.x + brick.x] != 0u) return true;
  vec3 lo = vec3(brick) * float(kBrickSize) - 0.5, hi = lo + float(kBrickSize);
  for (uint m = 0u; m < P.movingCount; ++m)
    if (all(lessThanEqual(P.moving[m].boxMin.xyz, hi)) && all(greaterThanEqual(P.moving[m].boxMax.xyz, lo))) return true;
  return false;
}

// Distance along the ray at which it leaves a brick's box (index space).
float brickExit(vec3 o, vec3 d, ivec3 brick) {
  vec3 lo = vec3(brick) * float(kBrickSize) - 0.5;
  vec3 hi = lo + float(kBrickSize);
  vec3 inv = 1.0 / d;
  vec3 tmax = max((lo - o) * inv, (hi - o) * inv);
  return min(min(tmax.x, tmax.y), tmax.z);
}

// Opacity of one sample, corrected from the reference step to the actual step (the raymarch's,
// P.stepMm * P.stepScale; picking's, P.stepMm).
float correctedAlpha(float a, float step) {
  return 1.0 - pow(max(1.0 - a, 0.0), step / P.opacityStepMm);
}
