#pragma once
// Analytic meshes with exact normals, UVs and tangents (OpenGL UVs, +v up;
// tangent w with B = w cross(N, T) along +v): test scenes for the renderer and
// its parity test, and the fallback scene when no mesh is given.
#include <vector>

#include <mucosa/mesh/mesh.hpp>

namespace mucosa::mesh {

// A square of side `size` mm in the z = 0 plane centred at the origin, facing
// +z, split into n x n cells. mirrorU: u runs from +x to -x (mirrored UVs,
// tangent w = -1).
Mesh makeQuad(float size, int n, bool mirrorU = false);

// A UV sphere of radius r (mm) at the origin, normals outward; u around +z
// (longitude), v from the south pole (0) to the north pole (1).
Mesh makeSphere(float radius, int slices, int stacks);

// A gently curved tube (bronchus-like) viewed from inside: centerline from the
// origin along -z curving towards +x, radius r mm, length mm; normals face the
// lumen; u around, v along (1 unit per circumference). Coarse meshes show the
// per-vertex baselines' faceting.
Mesh makeTube(float radius, float length, int around, int along);

// The tube's centerline (for fly-throughs), `samples` points from start to end.
std::vector<Vec3> tubeCenterline(float length, int samples);

}  // namespace mucosa::mesh
