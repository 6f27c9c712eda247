#include <gtest/gtest.h>

#include <mucosa/mesh/analysis.hpp>
#include <mucosa/mesh/io.hpp>
#include <mucosa/mesh/repair.hpp>
#include <mucosa/mesh/tangents.hpp>

#include "mesh_test_util.hpp"

namespace mucosa::test {
namespace {

// A unit cube of 12 triangles with every triangle's corners separate (as STL).
Mesh soupCube() {
    const Vec3 c[8] = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}, {0, 0, 1}, {1, 0, 1}, {1, 1, 1}, {0, 1, 1}};
    const int f[12][3] = {{0, 2, 1}, {0, 3, 2}, {4, 5, 6}, {4, 6, 7}, {0, 1, 5}, {0, 5, 4},
                          {2, 3, 7}, {2, 7, 6}, {1, 2, 6}, {1, 6, 5}, {0, 4, 7}, {0, 7, 3}};
    Mesh m;
    for (const auto& t : f)
        for (int k = 0; k < 3; ++k) {
            m.positions.push_back(c[t[k]]);
            m.indices.push_back(static_cast<std::uint32_t>(m.indices.size()));
        }
    return m;
}

TEST(Repair, WeldMakesSoupWatertightAndNormalsPointOut) {
    Mesh m = soupCube();
    EXPECT_EQ(mesh::weld(m), 36u - 8u);
    mesh::recomputeNormals(m);
    const auto r = mesh::analyze(m);
    EXPECT_TRUE(r.watertight());
    EXPECT_EQ(r.inconsistentEdges, 0u);
    EXPECT_NEAR(r.signedVolume, 1.0, 1e-6);
    EXPECT_EQ(r.normalsAgainstWinding, 0u);
    for (std::size_t v = 0; v < m.vertexCount(); ++v) {
        // Corner normals point away from the centre.
        const Vec3 d{m.positions[v][0] - 0.5f, m.positions[v][1] - 0.5f, m.positions[v][2] - 0.5f};
        EXPECT_GT(d[0] * m.normals[v][0] + d[1] * m.normals[v][1] + d[2] * m.normals[v][2], 0.0f);
    }
}

TEST(Repair, FlipReversesWindingNormalsAndHandedness) {
    Mesh m = grid(3);
    mesh::computeTangents(m);
    Mesh f = m;
    mesh::flipOrientation(f);
    mesh::Mesh recomputed = f;
    mesh::computeTangents(recomputed);
    for (std::size_t v = 0; v < m.vertexCount(); ++v) {
        EXPECT_EQ(f.normals[v][2], -1.0f);
        EXPECT_EQ(f.tangents[v][3], -m.tangents[v][3]);
        // Flipping keeps the frame the tangent algorithm would compute.
        for (int k = 0; k < 4; ++k) EXPECT_NEAR(f.tangents[v][k], recomputed.tangents[v][k], 1e-6f);
    }
    EXPECT_LT(mesh::analyze(f).normalsAgainstWinding, 1u);
}

TEST(Repair, DropsDegenerateTrianglesAndUnusedVertices) {
    Mesh m = grid(2);
    m.positions.push_back({9, 9, 9});
    m.normals.push_back({0, 0, 1});
    m.uvs.push_back({0, 0});
    const std::size_t good = m.triangleCount();
    m.indices.insert(m.indices.end(), {0, 0, 1});  // repeated index
    m.indices.insert(m.indices.end(), {0, 1, 2});  // collinear: zero area
    EXPECT_EQ(mesh::analyze(m).degenerateTriangles, 2u);
    EXPECT_EQ(mesh::removeDegenerateTriangles(m), 2u);
    EXPECT_EQ(m.triangleCount(), good);
    EXPECT_EQ(mesh::removeUnusedVertices(m), 1u);
    EXPECT_EQ(mesh::analyze(m).unusedVertices, 0u);
}

TEST(Repair, NonManifoldFanIsReported) {
    // Three triangles sharing one edge.
    Mesh m;
    m.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}};
    m.indices = {0, 1, 2, 1, 0, 3, 0, 1, 4};
    mesh::recomputeNormals(m);
    const auto r = mesh::analyze(m);
    EXPECT_EQ(r.nonManifoldEdges, 1u);
    EXPECT_FALSE(r.watertight());
}

TEST(Repair, WeldKeepsUvSeams) {
    Mesh m = grid(1);  // 4 vertices
    // Duplicate vertex 3 (on the diagonal) with a different UV for the second triangle.
    ASSERT_EQ(m.indices[4], 3u);
    m.positions.push_back(m.positions[3]);
    m.normals.push_back(m.normals[3]);
    m.uvs.push_back({0.9f, 0.9f});
    m.indices[4] = 4;
    EXPECT_EQ(mesh::weld(m), 0u);
    EXPECT_EQ(m.vertexCount(), 5u);
    EXPECT_EQ(mesh::analyze(m).boundaryEdges, 4u) << "a UV seam is not a boundary";
}

// Welding carries each kept vertex's colour; two corners at one position with
// different colours stay apart (a sharp tint edge), like a UV seam.
TEST(Repair, WeldCarriesColorsAndKeepsColorEdges) {
    Mesh m = soupCube();
    m.colors.resize(m.vertexCount());
    for (std::size_t v = 0; v < m.vertexCount(); ++v)
        m.colors[v] = {m.positions[v][0], 0.5f * m.positions[v][1], 0.25f + 0.5f * m.positions[v][2]};
    EXPECT_EQ(mesh::weld(m), 36u - 8u);
    ASSERT_TRUE(m.hasColors());
    for (std::size_t v = 0; v < m.vertexCount(); ++v) {
        EXPECT_EQ(m.colors[v][0], m.positions[v][0]);
        EXPECT_EQ(m.colors[v][1], 0.5f * m.positions[v][1]);
        EXPECT_EQ(m.colors[v][2], 0.25f + 0.5f * m.positions[v][2]);
    }
    Mesh edge = soupCube();
    edge.colors.assign(edge.vertexCount(), Vec3{1, 1, 1});
    for (std::size_t c = 0; c < 6; ++c) edge.colors[c] = {1, 0, 0};  // the two z = 0 triangles are red
    EXPECT_EQ(mesh::weld(edge), 36u - 8u - 4u) << "the bottom face's 4 corners stay separate";
    // Dropping unused vertices keeps colours aligned with positions.
    Mesh g = grid(2);
    g.colors.resize(g.vertexCount());
    for (std::size_t v = 0; v < g.vertexCount(); ++v) g.colors[v] = {float(v) / 10.0f, 0, 0};
    g.positions.insert(g.positions.begin(), Vec3{9, 9, 9});
    g.normals.insert(g.normals.begin(), Vec3{0, 0, 1});
    g.uvs.insert(g.uvs.begin(), Vec2{0, 0});
    g.colors.insert(g.colors.begin(), Vec3{1, 1, 1});
    for (auto& i : g.indices) ++i;
    EXPECT_EQ(mesh::removeUnusedVertices(g), 1u);
    ASSERT_TRUE(g.hasColors());
    for (std::size_t v = 0; v < g.vertexCount(); ++v) EXPECT_EQ(g.colors[v][0], float(v) / 10.0f);
}

TEST(Repair, OpenSurfaceVolumeCapsItsEndsSoFarFromTheOriginItKeepsItsSign) {
    // The cube without its top: an open box (one boundary loop). Capped, its
    // volume is the cube's, wherever it is; uncapped, the sum would depend on
    // the origin and change sign when the box moves.
    Mesh box = soupCube();
    box.positions.erase(box.positions.begin() + 2 * 3, box.positions.begin() + 4 * 3);  // triangles 2, 3: z = 1
    box.indices.resize(box.positions.size());
    box.normals.clear();
    mesh::weld(box);
    for (float shift : {0.0f, 500.0f, -2000.0f}) {
        Mesh moved = box;
        for (auto& p : moved.positions) p = {p[0] + shift, p[1] - shift, p[2] + 2 * shift};
        const auto r = mesh::analyze(moved);
        EXPECT_EQ(r.boundaryLoops, 1u);
        EXPECT_NEAR(r.signedVolume, 1.0, 1e-6) << shift;
    }
}

}  // namespace
}  // namespace mucosa::test
