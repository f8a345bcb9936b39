#version 450
#extension GL_GOOGLE_include_directive : require
// The live selection of a pinch painted into a box of the handle-id mask, on the GPU: each voxel of
// the box takes the live selection's id where its region-growing key is within the bound, else the
// box's handle id as the CPU last painted it ("base"). Ids are bytes, four to a word, rows padded
// to whole words; the renderer copies the words into the R8 mask image (a buffer-to-image copy, so
// the mask needs no storage-image format). CPU reference: render/live_selection.h, paintLiveBox.
// Keys of voxels still growing only fall, so a voxel shown within the bound stays in the selection.
#include "shared.h"
layout(local_size_x = HANDSON_LIVE_MASK_GROUP_X) in;
layout(std430, set = 0, binding = kBindLiveMaskKeys) readonly buffer Keys { uint keys[]; };
layout(std430, set = 0, binding = kBindLiveMaskBase) readonly buffer Base { uint base[]; };
layout(std430, set = 0, binding = kBindLiveMaskOut) writeonly buffer Out { uint ids[]; };
layout(push_constant) uniform Push { LiveMaskPush pc; };

void paintWord(uint w) {
  uint rowWords = uint(pc.boxDims.w);
  uint row = w / rowWords;              // y + dims.y * z
  uint x0 = (w - row * rowWords) * 4u;  // first voxel of this word in its row
  uint first = row * uint(pc.boxDims.x) + x0;
  uint b = base[w], word = 0u;
  for (uint i = 0u; i < 4u; ++i) {
    uint id = (b >> (8u * i)) & 0xffu;
    if (x0 + i < uint(pc.boxDims.x) && keys[first + i] <= pc.bound.x) id = kLiveMaskId;
    word |= id << (8u * i);
  }
  ids[w] = word;
}

// A grid-stride loop: the dispatch stays within the device's group count (65535 on many devices)
// whatever the box's size.
void main() {
  uint stride = gl_NumWorkGroups.x * gl_WorkGroupSize.x;
  for (uint w = gl_GlobalInvocationID.x; w < pc.bound.y; w += stride) paintWord(w);
}
