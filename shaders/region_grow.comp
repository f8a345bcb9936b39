#version 450
#extension GL_GOOGLE_include_directive : require
// Region growing, one workgroup per active 8^3 brick of the box around the seed: keys relax to
// key(v) = f(min over 6-neighbours) for homogeneous voxels (paper: steps + 1; smoothed and core:
// max of the neighbour's key and v's own squared distance, or with path keys the neighbour's key
// plus the step's length), bounded by the extent's key. Under the
// core criterion only core neighbours (and the seed, key 0) pass their key on. The brick iterates
// locally in shared memory until it settles, then publishes its keys with atomicMin and flags the
// neighbouring bricks its faces changed. The fixed point is the CPU reference's
// (interaction/region_grow.cpp): the same keys, so the same voxel set.
#include "shared.h"
layout(local_size_x = HANDSON_GROW_BRICK, local_size_y = HANDSON_GROW_BRICK, local_size_z = HANDSON_GROW_BRICK) in;
layout(set = 0, binding = kBindRegionGrowVolume) uniform sampler3D uVolume;
layout(std430, set = 0, binding = kBindRegionGrowKeys) buffer Keys { uint keys[]; };
layout(std430, set = 0, binding = kBindRegionGrowAccept) buffer Accept { uint accept[]; };  // the tests' answers: kKnown... bits, 0 = none yet
layout(std430, set = 0, binding = kBindRegionGrowList) readonly buffer List { uint list[]; };
layout(std430, set = 0, binding = kBindRegionGrowFlags) buffer Flags { uint flags[]; };      // next-active bricks
layout(std430, set = 0, binding = kBindRegionGrowReached) buffer Reached { uint reached[]; };  // bricks holding reached voxels
layout(push_constant) uniform Push { GrowPush pc; };
// The criterion (0 paper, 1 smoothed, 2 core) as a specialization constant: each pipeline carries
// only its own criterion's code (the core's extra tests cost the others nothing).
layout(constant_id = 0) const uint kCriterion = 1u;
// Smoothed and core: 1 for path keys (GrowBound::Path: over the 26 neighbours, the neighbour's key
// plus the step's length in 1/256 mm, a step across an edge or corner only where face steps through
// voxels that pass growth on join the two too), 0 for the ball's (6 neighbours: the larger of the
// neighbour's key and the voxel's squared distance).
layout(constant_id = 1) const uint kPathKeys = 0u;

const int B = HANDSON_GROW_BRICK;
const int H = HANDSON_GROW_BRICK + 2;  // with a one-voxel halo
shared uint sk[H * H * H];
shared uint sc[H * H * H];  // the Accept bits of reached voxels (core criterion only)
const uint kKnown = 1u, kHomogeneous = 2u, kTight = 4u, kCoreKnown = 8u, kCore = 16u;
const ivec3 kOff[6] = ivec3[6](ivec3(-1, 0, 0), ivec3(1, 0, 0), ivec3(0, -1, 0), ivec3(0, 1, 0), ivec3(0, 0, -1), ivec3(0, 0, 1));
shared uint anyChanged;

uint volumeAt(ivec3 p) {
  p = clamp(p, ivec3(0), textureSize(uVolume, 0) - 1);
  return uint(round(texelFetch(uVolume, p, 0).r * 65535.0));
}

// The value compared with the seed's: the voxel's own (paper) or its 3x3x3 sum (smoothed, core).
float homogeneityValue(ivec3 p) {
  if (kCriterion == 0u) return float(volumeAt(p));
  uint sum = 0u;
  for (int z = -1; z <= 1; ++z)
    for (int y = -1; y <= 1; ++y)
      for (int x = -1; x <= 1; ++x) sum += volumeAt(p + ivec3(x, y, z));
  return float(sum);
}

uint boxIndex(ivec3 v) { return uint(v.x + pc.boxDims.x * (v.y + pc.boxDims.y * v.z)); }
// The tests on one voxel (volume coordinates): kKnown | kHomogeneous (within the tolerance) |
// kTight (within the core tolerance), computed once and kept in Accept where it lies in the box.
uint testsAt(ivec3 w) {
  ivec3 v = w - pc.boxMin.xyz;
  bool inBox = all(greaterThanEqual(v, ivec3(0))) && all(lessThan(v, pc.boxDims.xyz));
  if (inBox) {
    uint a = accept[boxIndex(v)];
    if ((a & kKnown) != 0u) return a;
  }
  float deviation = abs(homogeneityValue(w) - pc.spacing.w);
  uint a = kKnown | (deviation < pc.tolerance.x ? kHomogeneous : 0u) | (deviation < pc.tolerance.y ? kTight : 0u);
  if (inBox) atomicOr(accept[boxIndex(v)], a);
  return a;
}

// The Accept bits of a box voxel; under the core criterion also whether it is core (homogeneous,
// tight, and all six neighbours, clamped to the volume, homogeneous). Every workgroup computes the
// same answers, and bits only ever accumulate (atomicOr), so racing writers agree.
uint classOf(ivec3 v) {
  uint gi = boxIndex(v);
  uint a = accept[gi];
  if ((a & (kCriterion == 2u ? kCoreKnown : kKnown)) != 0u) return a;
  ivec3 w = pc.boxMin.xyz + v;
  a = testsAt(w);
  if (kCriterion == 2u) {
    bool core = (a & (kHomogeneous | kTight)) == (kHomogeneous | kTight);
    ivec3 top = textureSize(uVolume, 0) - 1;
    for (int n = 0; n < 6 && core; ++n) core = (testsAt(clamp(w + kOff[n], ivec3(0), top)) & kHomogeneous) != 0u;
    a |= core ? kCoreKnown | kCore : kCoreKnown;
    atomicOr(accept[gi], a);
  }
  return a;
}

int haloIndex(ivec3 h) { return h.x + H * (h.y + H * h.z); }
// Path keys: a step's length by its axis mask (1 x, 2 y, 4 z).
uint stepCost(uint mask) { return pc.steps[mask >> 2][mask & 3u]; }

// Path keys: does a halo voxel pass growth on? Reached, and under the core criterion core (or the
// seed, key 0). A voxel not yet reached reads as not passing; once it is reached its brick flags
// this one, which runs again: the fixed point is the CPU reference's (a step's intermediate voxels
// lie within the bound whenever the step does, so they are reached by then).
bool passesAt(int h) {
  uint k = sk[h];
  if (k == kGrowUnreached) return false;
  return kCriterion != 2u || k == 0u || (sc[h] & kCore) != 0u;
}

// Path keys: the best key over the 20 edge and corner neighbours of halo voxel c (a step's length
// from pc.steps by its axis mask). A step from n to c needs face steps from n through passing
// voxels to c: an edge step one of its two intermediates, a corner step both of one of six orders.
uint edgeAndCornerSteps(ivec3 c) {
  uint best = kGrowUnreached;
  for (int dz = -1; dz <= 1; ++dz)
    for (int dy = -1; dy <= 1; ++dy)
      for (int dx = -1; dx <= 1; ++dx) {
        ivec3 s = ivec3(dx, dy, dz);  // from c to the neighbour n; the step runs from n to c
        int axes = int(dx != 0) + int(dy != 0) + int(dz != 0);
        if (axes < 2) continue;
        int hn = haloIndex(c + s);
        uint kn = sk[hn];
        if (kn == kGrowUnreached || !passesAt(hn)) continue;
        bool joined = false;
        if (axes == 2) {
          for (int a = 0; a < 3 && !joined; ++a) {  // intermediates: n moved along one of its axes toward c
            if (s[a] == 0) continue;
            ivec3 w = c + s;
            w[a] -= s[a];
            joined = passesAt(haloIndex(w));
          }
        } else {
          for (int a = 0; a < 3 && !joined; ++a)
            for (int b = 0; b < 3 && !joined; ++b) {
              if (a == b) continue;
              ivec3 w1 = c + s;
              w1[a] -= s[a];
              ivec3 w2 = w1;
              w2[b] -= s[b];
              joined = passesAt(haloIndex(w1)) && passesAt(haloIndex(w2));
            }
        }
        if (!joined) continue;
        uint mask = uint(dx != 0) | (uint(dy != 0) << 1) | (uint(dz != 0) << 2);
        best = min(best, kn + stepCost(mask));
      }
  return best;
}
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
    // A reached voxel's class, stored by the workgroup that reached it. Not yet visible in this
    // dispatch, it reads as "not core"; that workgroup flags this brick, which runs again next
    // round and sees it: the fixed point is the same.
    if (kCriterion == 2u) sc[i] = ok ? accept[boxIndex(g)] : 0u;
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
      for (int n = 0; n < 6; ++n) {
        int hn = haloIndex(lv + 1 + kOff[n]);
        uint kn = sk[hn];
        if (kn == kGrowUnreached) continue;
        if (kCriterion == 2u && kn != 0u && (sc[hn] & kCore) == 0u) continue;  // joined, passes nothing on
        uint cand = kCriterion == 0u ? kn + 1u : (kPathKeys != 0u ? kn + stepCost(1u << uint(n / 2)) : max(kn, myDist));
        best = min(best, cand);
      }
      if (kPathKeys != 0u) best = min(best, edgeAndCornerSteps(lv + 1));
    }
    bool changed = false;
    if (best < myKey && best <= bound) {
      if (acc == 0u) acc = classOf(v);
      changed = (acc & kHomogeneous) != 0u;
    }
    barrier();  // every thread has read sk
    if (changed) {
      sk[c] = best;
      if (kCriterion == 2u) sc[c] = acc;
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
  if (kPathKeys != 0u) {
    // Path keys step across edges and corners too: every brick this voxel borders wakes.
    for (int dz = -1; dz <= 1; ++dz)
      for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx) {
          ivec3 o = ivec3(dx, dy, dz);
          bool borders = o != ivec3(0);
          for (int a = 0; a < 3; ++a) borders = borders && (o[a] == 0 || (o[a] < 0 ? lv[a] == 0 : lv[a] == B - 1));
          ivec3 nb = b + o;
          if (borders && all(greaterThanEqual(nb, ivec3(0))) && all(lessThan(nb, pc.brickDims.xyz))) flags[brickIndex(nb)] = 1u;
        }
    return;
  }
  // Faces that changed wake the neighbouring bricks.
  if (lv.x == 0 && b.x > 0) flags[brickIndex(b - ivec3(1, 0, 0))] = 1u;
  if (lv.x == B - 1 && b.x + 1 < pc.brickDims.x) flags[brickIndex(b + ivec3(1, 0, 0))] = 1u;
  if (lv.y == 0 && b.y > 0) flags[brickIndex(b - ivec3(0, 1, 0))] = 1u;
  if (lv.y == B - 1 && b.y + 1 < pc.brickDims.y) flags[brickIndex(b + ivec3(0, 1, 0))] = 1u;
  if (lv.z == 0 && b.z > 0) flags[brickIndex(b - ivec3(0, 0, 1))] = 1u;
  if (lv.z == B - 1 && b.z + 1 < pc.brickDims.z) flags[brickIndex(b + ivec3(0, 0, 1))] = 1u;
}
