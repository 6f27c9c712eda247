#pragma once
// The triangle mesh every module shares (import, tangents, phantom, renderer,
// fitting). Plain arrays, no third-party types in the public interface.
//
// Conventions (docs/theory.md, "Conventions"):
//  - units: millimetres after import (the importer scales and reports);
//  - UVs: OpenGL's convention, origin at the image's bottom-left, +v up (the
//    glTF importer/exporter flips v; OBJ/PLY/Assimp's convention already is this);
//  - tangents: xyz = dP/du orthonormalised against N, w = +-1 with
//    B = w * cross(N, T) = dP/dv direction (glTF's TANGENT definition);
//  - triangles wind counter-clockwise seen from the side the normals face;
//  - colors: linear RGB in 0..1, a tint the renderer multiplies the albedo by
//    (1 = the albedo unchanged); glTF COLOR_0, PLY red/green/blue, OBJ `v x y z r g b`.
#include <array>
#include <cstdint>
#include <string>
#include <vector>

namespace mucosa::mesh {

using Vec2 = std::array<float, 2>;
using Vec3 = std::array<float, 3>;
using Vec4 = std::array<float, 4>;

struct Mesh {
    std::vector<Vec3> positions;
    std::vector<Vec3> normals;           // per vertex, unit; empty if absent
    std::vector<Vec2> uvs;               // per vertex; empty if absent
    std::vector<Vec4> tangents;          // per vertex, xyz unit, w = +-1; empty if absent
    std::vector<Vec3> colors;            // per vertex linear RGB tint multiplying the albedo; empty if absent
    std::vector<std::uint32_t> indices;  // 3 per triangle
    // Per triangle: the index of its material in the file it came from
    // (glTF's materials, mesh::GltfLook; kNoMaterial in <mucosa/mesh/gltf.hpp>
    // for none); empty = one material for the whole mesh. Every step that
    // drops or rebuilds triangles keeps it in step (validateIndices checks).
    std::vector<std::uint32_t> materials;

    std::size_t vertexCount() const noexcept { return positions.size(); }
    std::size_t triangleCount() const noexcept { return indices.size() / 3; }
    bool hasNormals() const noexcept { return !normals.empty() && normals.size() == positions.size(); }
    bool hasUvs() const noexcept { return !uvs.empty() && uvs.size() == positions.size(); }
    bool hasTangents() const noexcept { return !tangents.empty() && tangents.size() == positions.size(); }
    bool hasColors() const noexcept { return !colors.empty() && colors.size() == positions.size(); }
    bool hasMaterials() const noexcept { return !materials.empty() && materials.size() == triangleCount(); }
};

}  // namespace mucosa::mesh
