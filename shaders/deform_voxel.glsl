// The voxel of one invocation of the per-voxel deformation passes (deform_clear.comp,
// deform_resolve.comp, deform_strain_raster.comp), dispatched indirectly by deform_args.comp.
// Box mode (box.brickMode == 0): box.lo plus the global invocation id. Brick mode: workgroup
// (x, y + 65535 z) covers octant x of the dirty brick listed at entry y + 65535 z (deform_bricks.comp).
// Needs P (DeformParams), box (DeformBox) and brickList[] declared before the include.
// False: the invocation has no voxel (beyond the box, the list or the region's voxel box).
bool deformVoxel(out ivec3 v) {
  if (box.brickMode == 0u) {
    v = box.lo + ivec3(gl_GlobalInvocationID);
    return all(lessThanEqual(v, box.hi));
  }
  const int per = HANDSON_DEFORM_BRICK / HANDSON_DEFORM_CLEAR_GROUP;  // workgroups a brick's side
  uint entry = gl_WorkGroupID.y + 65535u * gl_WorkGroupID.z;
  v = ivec3(0);
  if (entry >= box.dirtyBrickCount) return false;
  uint b = brickList[entry];
  uint bx = uint(P.brickGrid.x), by = uint(P.brickGrid.y);
  ivec3 bc = ivec3(int(b % bx), int((b / bx) % by), int(b / (bx * by)));
  int w = int(gl_WorkGroupID.x);
  ivec3 oct = ivec3(w % per, (w / per) % per, w / (per * per));
  v = P.regionVoxLo + bc * HANDSON_DEFORM_BRICK + oct * HANDSON_DEFORM_CLEAR_GROUP + ivec3(gl_LocalInvocationID);
  return all(lessThanEqual(v, P.regionVoxHi));
}

// The dirty-brick index of a region voxel (inside the region's voxel box).
uint deformBrickOf(ivec3 v) {
  ivec3 c = (v - P.regionVoxLo) / HANDSON_DEFORM_BRICK;
  return uint(c.x + P.brickGrid.x * (c.y + P.brickGrid.y * c.z));
}
