#version 450
#extension GL_GOOGLE_include_directive : require
// Region growing, one workgroup per active 8^3 brick of the box around the seed: keys relax to
// key(v) = f(min over 6-neighbours) for homogeneous voxels (paper: steps + 1; smoothed: max of the
// neighbour's key and v's own squared distance), bounded by the extent's key. The brick iterates
// locally in shared memory until it settles, then publishes its keys with atomicMin and flags the
// neighbouring bricks its faces changed. The fixed point is the CPU reference's
// (interaction/region_grow.cpp): the same keys, so the same voxel set.
#include "shared.h"
layout(local_size_x = HANDSON_GROW_BRICK, local_size_y = HANDSON_GROW_BRICK, local_size_z = HANDSON_GROW_BRICK) in;
layout(set = 0, binding = 0) uniform sampler3D uVolume;
layout(std430, set = 0, binding = 1) buffer Keys { uint keys[]; };
layout(std430, set = 0, binding = 2) buffer Accept { uint accept[]; };  // 0 unknown, 1 homogeneous, 2 not
layout(std430, set = 0, binding = 3) readonly buffer List { uint list[]; };
layout(std430, set = 0, binding = 4) buffer Flags { uint flags[]; };      // next-active bricks
layout(std430, set = 0, binding = 5) buffer Reached { uint reached[]; };  // bricks holding reached voxels
layout(push_constant) uniform Push { GrowPush pc; };

const int B = HANDSON_GROW_BRICK;
const int H = HANDSON_GROW_BRICK + 2;  // with a one-voxel halo
shared uint sk[H * H * H];
shared uint anyChanged;

uint volumeAt(ivec3 p) {
  p = clamp(p, ivec3(0), textureSize(uVolume, 0) - 1);
  return uint(round(texelFetch(uVolume, p, 0).r * 65535.0));
}

// The value compared with the seed's: the voxel's own (paper) or its 3x3x3 sum (smoothed).
float homogeneityValue(ivec3 p) {
  if (pc.boxDims.w == 0) return float(volumeAt(p));
  uint sum = 0u;
  for (int z = -1; z <= 1; ++z)
    for (int y = -1; y <= 1; ++y)
      for (int x = -1; x <= 1; ++x) sum += volumeAt(p + ivec3(x, y, z));
  return float(sum);
}

uint boxIndex(ivec3 v) { return uint(v.x + pc.boxDims.x * (v.y + pc.boxDims.y * v.z)); }
int haloIndex(ivec3 h) { return h.x + H * (h.y + H * h.z); }
uint brickIndex(ivec3 b) { return uint(b.x + pc.brickDims.x * (b.y + pc.brickDims.y * b.z)); }

void main() {
  uint brick = list[kGrowListHeader + gl_WorkGroupID.x];
  ivec3 b = ivec3(int(brick) % pc.brickDims.x, (int(brick) / pc.brickDims.x) % pc.brickDims.y, int(brick) / (pc.brickDims.x * pc.brickDims.y));
  ivec3 lv = ivec3(gl_LocalInvocationID);
  int lid = int(gl_LocalInvocationIndex);
  ivec3 v = b * B + lv;  // box coordinates
  bool inBox = all(lessThan(v, pc.boxDims.xyz));

  for (int i = lid; i < H * H * H; i += B * B * B) {
    ivec3 h = ivec3(i % H, (i / H) % H, i / (H * H));
    ivec3 g = b * B + h - 1;
    bool ok = all(greaterThanEqual(g, ivec3(0))) && all(lessThan(g, pc.boxDims.xyz));
    sk[i] = ok ? keys[boxIndex(g)] : kGrowUnreached;
  }

  ivec3 world = pc.boxMin.xyz + v;
  precise vec3 d = vec3(world - pc.seed.xyz) * pc.spacing.xyz;
  precise float d2 = (d.x * d.x + d.y * d.y) + d.z * d.z;
  uint myDist = floatBitsToUint(d2);
  uint bound = uint(pc.seed.w);
  int c = haloIndex(lv + 1);
  uint acc = 0u;
  bool everChanged = false;
  for (int it = 0; it < int(kGrowMaxLocalIterations); ++it) {
    if (lid == 0) anyChanged = 0u;
    barrier();
    uint myKey = inBox ? sk[c] : kGrowUnreached;
    uint best = kGrowUnreached;
    if (inBox) {
      const ivec3 off[6] = ivec3[6](ivec3(-1, 0, 0), ivec3(1, 0, 0), ivec3(0, -1, 0), ivec3(0, 1, 0), ivec3(0, 0, -1), ivec3(0, 0, 1));
      for (int n = 0; n < 6; ++n) {
        uint kn = sk[haloIndex(lv + 1 + off[n])];
        if (kn == kGrowUnreached) continue;
        uint cand = pc.boxDims.w == 0 ? kn + 1u : max(kn, myDist);
        best = min(best, cand);
      }
    }
    bool changed = false;
    if (best < myKey && best <= bound) {
      if (acc == 0u) {
        uint gi = boxIndex(v);
        acc = accept[gi];
        if (acc == 0u) {
          acc = abs(homogeneityValue(world) - pc.spacing.w) < pc.tolerance.x ? 1u : 2u;
          accept[gi] = acc;
        }
      }
      changed = acc == 1u;
    }
    barrier();  // every thread has read sk
    if (changed) {
      sk[c] = best;
      anyChanged = 1u;
      everChanged = true;
    }
    barrier();
    bool stop = anyChanged == 0u;
    barrier();  // everyone has read anyChanged before thread 0 resets it
    if (stop) break;
    if (it == int(kGrowMaxLocalIterations) - 1 && lid == 0) flags[brick] = 1u;  // not settled: again next round
  }
  if (!inBox) return;
  uint myKey = sk[c];
  if (myKey != kGrowUnreached) reached[brick] = 1u;
  if (!everChanged) return;
  atomicMin(keys[boxIndex(v)], myKey);
  // Faces that changed wake the neighbouring bricks.
  if (lv.x == 0 && b.x > 0) flags[brickIndex(b - ivec3(1, 0, 0))] = 1u;
  if (lv.x == B - 1 && b.x + 1 < pc.brickDims.x) flags[brickIndex(b + ivec3(1, 0, 0))] = 1u;
  if (lv.y == 0 && b.y > 0) flags[brickIndex(b - ivec3(0, 1, 0))] = 1u;
  if (lv.y == B - 1 && b.y + 1 < pc.brickDims.y) flags[brickIndex(b + ivec3(0, 1, 0))] = 1u;
  if (lv.z == 0 && b.z > 0) flags[brickIndex(b - ivec3(0, 0, 1))] = 1u;
  if (lv.z == B - 1 && b.z + 1 < pc.brickDims.z) flags[brickIndex(b + ivec3(0, 0, 1))] = 1u;
}
