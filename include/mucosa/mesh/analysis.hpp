#pragma once
// What `mucosa mesh info` reports: counts, bounds, topology, defects, UV stretch.
#include <cstddef>
#include <optional>

#include <mucosa/mesh/mesh.hpp>

namespace mucosa::mesh {

// Ratio of UV area to surface area per triangle and its spread; the Jacobian of
// the map surface -> uv has singular values sigma1 >= sigma2 (Sander et al.
// 2001, "Texture mapping progressive meshes", stretch metric).
struct UvStretch {
    double uvPerSurfaceArea = 0;  // total UV area / total surface area (1/mm^2)
    // Per triangle, area ratio divided by the global ratio (1 = uniform density):
    double areaP05 = 0, areaP50 = 0, areaP95 = 0;
    // Per triangle, anisotropy sigma1/sigma2 (1 = square texels):
    double anisotropyP50 = 0, anisotropyP95 = 0;
    std::size_t zeroUvAreaTriangles = 0;  // UV area < 1e-12 of the mean
    std::size_t flippedTriangles = 0;     // UV winding opposite to the majority
};

struct MeshReport {
    std::size_t vertices = 0, triangles = 0;
    std::size_t uniquePositions = 0;    // topology is computed on these (seams welded)
    std::size_t components = 0;         // connected through shared positions
    std::size_t boundaryEdges = 0;      // used by one triangle
    std::size_t nonManifoldEdges = 0;   // used by three or more
    std::size_t inconsistentEdges = 0;  // two triangles traverse it the same way (winding flips)
    std::size_t degenerateTriangles = 0;
    std::size_t nonFiniteValues = 0;  // NaN/Inf floats in any attribute
    std::size_t unusedVertices = 0;
    Vec3 boundsMin{}, boundsMax{};
    double surfaceArea = 0;  // mm^2
    // mm^3; > 0: normals/winding face out of the enclosed volume. Open
    // surfaces are closed first: each boundary loop gets a fan to its centroid.
    double signedVolume = 0;
    std::size_t boundaryLoops = 0;  // loops of boundary edges capped for the volume
    bool hasNormals = false, hasUvs = false, hasTangents = false;
    std::size_t badNormals = 0;             // not unit length (|1 - |N|| > 1e-3) or non-finite
    std::size_t normalsAgainstWinding = 0;  // vertex normal opposite to its triangles' winding
    std::size_t badTangents = 0;            // not unit, not _|_ N, or |w| != 1
    std::optional<UvStretch> stretch;       // when UVs are present
    bool watertight() const noexcept { return boundaryEdges == 0 && nonManifoldEdges == 0; }
};

MeshReport analyze(const Mesh& mesh);

// Throws InputError if the mesh has no UVs or no triangle with area.
UvStretch measureUvStretch(const Mesh& mesh);

}  // namespace mucosa::mesh
