#version 450
#extension GL_GOOGLE_include_directive : require
// Active-brick compaction for region growing: flagged bricks go into the next list (whose header
// is the indirect dispatch's group count), and their flags are cleared. With `fromReached`, the
// bricks holding reached voxels are listed instead (resuming growth after the extent grew).
#include "shared.h"
layout(local_size_x = HANDSON_COMPACT_GROUP_X) in;
layout(std430, set = 0, binding = kBindRegionCompactFlags) buffer Flags { uint flags[]; };
layout(std430, set = 0, binding = kBindRegionCompactList) buffer List { uint list[]; };
layout(std430, set = 0, binding = kBindRegionCompactReached) readonly buffer Reached { uint reached[]; };
layout(push_constant) uniform Push { uint count; uint fromReached; } pc;

void main() {
  uint i = gl_GlobalInvocationID.x;
  if (i >= pc.count) return;
  bool listed = pc.fromReached != 0u ? reached[i] != 0u : flags[i] != 0u;
  if (pc.fromReached == 0u && flags[i] != 0u) flags[i] = 0u;
  if (!listed) return;
  uint slot = atomicAdd(list[0], 1u);
  list[kGrowListHeader + slot] = i;
}
