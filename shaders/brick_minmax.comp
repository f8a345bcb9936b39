#version 450
#extension GL_GOOGLE_include_directive : require
// Per-brick value range for empty-space skipping: min and max of the 16-bit normalized value over
// the brick and a one-voxel apron (all voxels a trilinear sample inside the brick touches).
// One invocation per brick. CPU reference: render/brick_grid.cpp.
#include "shared.h"
layout(local_size_x = HANDSON_BRICK_GROUP_X) in;
layout(set = 0, binding = kBindBrickMinmaxVolume) uniform sampler3D uVolume;
layout(std430, set = 0, binding = kBindBrickMinmaxOut) writeonly buffer Out { uvec2 range[]; };
layout(push_constant) uniform Push { ivec4 dims; ivec4 brickDims; } pc;

void main() {
  int id = int(gl_GlobalInvocationID.x);
  int count = pc.brickDims.x * pc.brickDims.y * pc.brickDims.z;
  if (id >= count) return;
  ivec3 b = ivec3(id % pc.brickDims.x, (id / pc.brickDims.x) % pc.brickDims.y, id / (pc.brickDims.x * pc.brickDims.y));
  ivec3 lo = max(b * int(kBrickSize) - 1, ivec3(0));
  ivec3 hi = min(b * int(kBrickSize) + int(kBrickSize), pc.dims.xyz - 1);
  uint mn = 65535u, mx = 0u;
  for (int z = lo.z; z <= hi.z; ++z)
    for (int y = lo.y; y <= hi.y; ++y)
      for (int x = lo.x; x <= hi.x; ++x) {
        uint v = uint(round(texelFetch(uVolume, ivec3(x, y, z), 0).r * 65535.0));
        mn = min(mn, v);
        mx = max(mx, v);
      }
  range[id] = uvec2(mn, mx);
}
