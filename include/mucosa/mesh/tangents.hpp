#pragma once
// Per-vertex tangent frames for normal/reflectance mapping (the paper's eq. 5,
// Lengyel 2001), robust to mirrored UVs, seams and zero-UV-area triangles.
#include <cstddef>

#include <mucosa/mesh/mesh.hpp>

namespace mucosa::mesh {

struct TangentReport {
    std::size_t degenerateUvTriangles = 0;  // |s1 t2 - s2 t1| ~ 0: contribute nothing
    std::size_t fallbackVertices = 0;       // no usable dP/du: T from dP/dv or any unit vector _|_ N
    std::size_t mirroredVertices = 0;       // w = -1
    std::size_t splitVertices = 0;          // copies added where one vertex needs two handedness groups
};

// Fills mesh.tangents (xyz unit, orthogonal to the normal, w = +-1 with
// B = w cross(N, T) along +v). Per triangle T and B as Lengyel 2001 (eq. 5 of
// the paper); per vertex the triangles' directions, projected on the vertex's
// tangent plane and normalised, are summed weighted by the corner angle
// between the edges projected on that plane, then Gram-Schmidt against N --
// MikkTSpace's frames (Mikkelsen 2008). As MikkTSpace does, the triangles
// around a vertex are grouped by UV orientation (edge-connected fans of one
// orientation): a vertex with more than one group (a fold, or a mirrored
// chart meeting an unmirrored one without a seam) is split, one copy per
// further group with all its attributes, so the mesh can gain vertices
// (TangentReport::splitVertices; triangle order and count are unchanged);
// w is the group's orientation. The frames then match MikkTSpace's per
// corner (tests/mesh/mikktspace_test.cpp measures it).
// Never yields NaN or zero vectors. Needs normals and UVs (InputError otherwise).
// threads: 0 = all hardware threads; the result does not depend on it.
TangentReport computeTangents(Mesh& mesh, int threads = 0);

// A unit tangent perpendicular to the unit normal n (w = +1), for meshes with
// no texture coordinates: any orthonormal frame will do for shading that does
// not read the map (object-space procedural noise, vertex lighting). Duff et
// al. 2017, "Building an orthonormal basis, revisited" (JCGT 6(1)).
Vec4 fallbackTangent(const Vec3& n) noexcept;

}  // namespace mucosa::mesh
