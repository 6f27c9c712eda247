#pragma once
// Iso-surface of a sampled scalar field (private to the module).
#include <cstddef>
#include <vector>

#include <mucosa/mesh/mesh.hpp>

namespace mucosa::mesh::detail {

struct ScalarGrid {
    std::array<double, 3> origin{};  // position of sample (0, 0, 0), mm
    double spacing = 1;              // mm between samples
    std::size_t nx = 0, ny = 0, nz = 0;
    std::vector<float> values;  // x fastest; < 0 inside
    float at(std::size_t i, std::size_t j, std::size_t k) const noexcept { return values[i + nx * (j + ny * k)]; }
};

// The zero set of the grid's piecewise-linear interpolant on the Kuhn
// (Freudenthal) triangulation: every cube splits into the six tetrahedra
// around its main diagonal, the same way in every cube, so faces shared by
// neighbouring cubes are split identically. The result is a closed 2-manifold
// when every sample is non-zero and the grid's border is outside (> 0):
// no ambiguous cases, no lookup table (Doi & Koide 1991, marching tetrahedra).
// Triangles wind counter-clockwise seen from the inside (< 0) side. Vertices
// are shared between triangles (one per crossed grid edge). No normals.
Mesh marchingTetrahedra(const ScalarGrid& grid);

}  // namespace mucosa::mesh::detail
