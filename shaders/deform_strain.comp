#version 450
#extension GL_GOOGLE_include_directive : require
// Strain per fine tet (docs/simulation-outputs.md, "Strain"): the largest principal stretch minus one,
// sigma_max(F) - 1, of the deformation gradient F = D_s D_m^-1 (3 x 3) in world millimetres. D_m:
// the rest edge matrix (columns X_i - X_0, world); D_s: the current one, from the fine positions in
// voxel index space taken to world by the linear part A of indexToWorld (D_s = A [p_i - p_0]).
// sigma_max^2 is the largest eigenvalue of the symmetric C = F^T F, in closed form (the
// trigonometric solution of its characteristic cubic). One invocation per fine tet. CPU reference:
// tetStrain in sim/strain.cpp (double precision, an SVD); a degenerate rest tet or a non-finite
// position gives NaN there and here.
#include "shared.h"
layout(local_size_x = HANDSON_DEFORM_GROUP_X) in;
layout(std430, set = 0, binding = kBindDeformStrainParams) readonly buffer Params { DeformParams P; };
layout(std430, set = 0, binding = kBindDeformStrainTets) readonly buffer Tets { uvec4 tet[]; };
layout(std430, set = 0, binding = kBindDeformStrainRest) readonly buffer Rest { vec4 rest[]; };  // world mm
layout(std430, set = 0, binding = kBindDeformStrainPos) readonly buffer Pos { vec4 pos[]; };    // voxel index space
layout(std430, set = 0, binding = kBindDeformStrainOut) writeonly buffer Out { float strain[]; };

// Largest eigenvalue of a symmetric 3 x 3 matrix.
float largestEigenvalue(mat3 C) {
  float q = (C[0][0] + C[1][1] + C[2][2]) / 3.0;
  float off = C[0][1] * C[0][1] + C[0][2] * C[0][2] + C[1][2] * C[1][2];
  float p2 = (C[0][0] - q) * (C[0][0] - q) + (C[1][1] - q) * (C[1][1] - q) + (C[2][2] - q) * (C[2][2] - q) + 2.0 * off;
  if (p2 <= 0.0) return q;  // a multiple of the identity
  float p = sqrt(p2 / 6.0);
  mat3 B = (C - q * mat3(1.0)) / p;
  float r = clamp(determinant(B) / 2.0, -1.0, 1.0);
  return q + 2.0 * p * cos(acos(r) / 3.0);
}

void main() {
  uint t = gl_GlobalInvocationID.x;
  if (t >= uint(P.fineTetCount)) return;
  uvec4 v = tet[t];
  vec3 X0 = rest[v.x].xyz;
  mat3 Dm = mat3(rest[v.y].xyz - X0, rest[v.z].xyz - X0, rest[v.w].xyz - X0);
  vec3 p0 = pos[v.x].xyz;
  mat3 Ds = mat3(P.indexToWorld) * mat3(pos[v.y].xyz - p0, pos[v.z].xyz - p0, pos[v.w].xyz - p0);
  float det = determinant(Dm);
  float norm = sqrt(dot(Dm[0], Dm[0]) + dot(Dm[1], Dm[1]) + dot(Dm[2], Dm[2]));  // Frobenius
  bool finiteDs = !any(isnan(Ds[0])) && !any(isnan(Ds[1])) && !any(isnan(Ds[2])) && !any(isinf(Ds[0])) && !any(isinf(Ds[1])) && !any(isinf(Ds[2]));
  // Degenerate: the CPU's test (1e-12 there) at what single precision resolves.
  if (!(abs(det) > 1e-6 * norm * norm * norm) || !finiteDs) {
    strain[t] = uintBitsToFloat(0x7fc00000u);  // NaN
    return;
  }
  mat3 F = Ds * inverse(Dm);
  strain[t] = sqrt(max(largestEigenvalue(transpose(F) * F), 0.0)) - 1.0;
}
