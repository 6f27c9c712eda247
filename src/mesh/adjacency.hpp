#pragma once
// Connectivity the module's algorithms share (private).
#include <cstdint>
#include <vector>

#include <mucosa/mesh/mesh.hpp>

namespace mucosa::mesh::detail {

// Vertex -> corners (3 * triangle + k) in compressed rows: the corners of
// vertex v are corners[offsets[v] .. offsets[v + 1]). Gathering through it
// lets per-vertex sums run in parallel without atomics, in a fixed order.
struct VertexCorners {
    std::vector<std::uint32_t> offsets;  // vertexCount + 1
    std::vector<std::uint32_t> corners;
};
VertexCorners vertexCorners(const Mesh& mesh);

// For each vertex, the smallest index of a vertex with bit-identical position
// (seams and UV splits welded for topology). Returns the number of distinct positions.
std::size_t positionIds(const Mesh& mesh, std::vector<std::uint32_t>& ids);

// Undirected edges between position ids, each with the number of triangles
// using it and how many of them traverse it a -> b (a < b).
struct EdgeUse {
    std::uint32_t a, b;
    std::uint32_t count, forward;
};
std::vector<EdgeUse> edgeUses(const Mesh& mesh, const std::vector<std::uint32_t>& ids);

}  // namespace mucosa::mesh::detail
