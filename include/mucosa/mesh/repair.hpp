#pragma once
// Repairs a user asks for (`mucosa mesh --weld --recompute-normals --flip`).
#include <cstddef>

#include <mucosa/mesh/mesh.hpp>

namespace mucosa::mesh {

// Merges vertices with the same position and the same UV (when present): UV
// seams stay split. tolerance = 0 merges bit-identical positions; > 0 merges
// positions that round to the same cell of a grid of `tolerance` mm (two
// points closer than that can still straddle a cell border). Normals of
// merged vertices are averaged and renormalised; tangents are dropped
// (recompute them). Returns the number of vertices removed.
std::size_t weld(Mesh& mesh, float tolerance = 0.0f);

// Drops triangles with a repeated index or (near) zero area; returns how many.
std::size_t removeDegenerateTriangles(Mesh& mesh);

// Drops vertices no triangle uses; returns how many.
std::size_t removeUnusedVertices(Mesh& mesh);

// Smooth normals weighted by the corner angle (Thürmer & Wüthrich 1998), in the
// direction the triangles' counter-clockwise winding faces. Vertices without a
// usable triangle get +Z. threads: 0 = all.
void recomputeNormals(Mesh& mesh, int threads = 0);

// Turns the surface inside out: reverses the winding, negates normals and the
// tangents' handedness w (T = dP/du is unchanged, B = w cross(N, T) must be too).
void flipOrientation(Mesh& mesh) noexcept;

}  // namespace mucosa::mesh
