#include <cmath>

#include <gtest/gtest.h>

#include <mucosa/mesh/analysis.hpp>
#include <mucosa/mesh/io.hpp>
#include <mucosa/mesh/repair.hpp>
#include <mucosa/mesh/tangents.hpp>
#include <mucosa/mesh/uv.hpp>

#include "mesh_test_util.hpp"

namespace mucosa::test {
namespace {

// An open cylinder of radius r along -Y, wound to face outward.
Mesh cylinder(float r, float len, int around, int along) {
    Mesh m;
    for (int j = 0; j <= along; ++j)
        for (int i = 0; i < around; ++i) {
            const float a = 2 * float(M_PI) * float(i) / float(around);
            m.positions.push_back({r * std::cos(a), -len * float(j) / float(along), r * std::sin(a)});
        }
    for (int j = 0; j < along; ++j)
        for (int i = 0; i < around; ++i) {
            const auto id = [&](int ii, int jj) { return static_cast<std::uint32_t>(jj * around + (ii % around)); };
            m.indices.insert(m.indices.end(), {id(i, j), id(i + 1, j + 1), id(i + 1, j)});
            m.indices.insert(m.indices.end(), {id(i, j), id(i, j + 1), id(i + 1, j + 1)});
        }
    mesh::recomputeNormals(m);
    return m;
}

// Triangles whose u spans more than `turns` of a turn. Away from poles
// (closed caps, where every direction meets) none should: seam vertices are
// duplicated instead of smearing a triangle across the wrap.
std::size_t trianglesSpanningU(const Mesh& m, double turns) {
    std::size_t count = 0;
    for (std::size_t t = 0; t < m.triangleCount(); ++t) {
        float lo = 1e9f, hi = -1e9f;
        for (int k = 0; k < 3; ++k) {
            const float u = m.uvs[m.indices[3 * t + k]][0];
            lo = std::min(lo, u), hi = std::max(hi, u);
        }
        count += hi - lo > turns ? 1 : 0;
    }
    return count;
}

TEST(CenterlineUv, CylinderGetsSquareTexelsAndASeamlessWrap) {
    Mesh m = cylinder(9, 100, 48, 60);
    const std::size_t before = m.vertexCount();
    const auto rep = mesh::computeCenterlineUvs(m);
    EXPECT_EQ(rep.pieces, 1u);
    ASSERT_EQ(rep.centerline.branches.size(), 1u);
    EXPECT_NEAR(rep.tileLength, 2 * M_PI * 9, 0.5);
    // One column of vertices is duplicated at the seam (u = 0 and u = 1).
    EXPECT_EQ(m.vertexCount(), before + 61);
    EXPECT_EQ(rep.seamVertices, 61u);
    const auto s = mesh::measureUvStretch(m);
    EXPECT_LT(s.anisotropyP95, 1.05);
    EXPECT_GT(s.areaP05, 0.95);
    EXPECT_LT(s.areaP95, 1.05);
    EXPECT_EQ(s.flippedTriangles, 0u);
    // u spans one turn, v runs 100 mm / L.
    float umin = 1e9f, umax = -1e9f, vmin = 1e9f, vmax = -1e9f;
    for (const Vec2& uv : m.uvs)
        umin = std::min(umin, uv[0]), umax = std::max(umax, uv[0]), vmin = std::min(vmin, uv[1]),
        vmax = std::max(vmax, uv[1]);
    EXPECT_NEAR(umax - umin, 1.0, 1e-3);
    EXPECT_NEAR(vmax - vmin, 100.0 / rep.tileLength, 0.02);
    EXPECT_EQ(trianglesSpanningU(m, 1.5 / 48), 0u);  // one column of the 48 around
    // The topology is unchanged (the seam is not a boundary).
    EXPECT_EQ(mesh::analyze(m).boundaryEdges, 2u * 48u);
    // UVs follow the winding: no mirrored tangent frames.
    const auto t = mesh::computeTangents(m);
    EXPECT_EQ(t.mirroredVertices, 0u);
}

// The seam duplicates vertices: each copy keeps its original's colour.
TEST(CenterlineUv, SeamCopiesCarryTheirColors) {
    Mesh m = cylinder(9, 100, 48, 60);
    auto tint = [](const Vec3& p) { return Vec3{0.5f + 0.05f * p[0], 0.5f + 0.05f * p[2], 0.01f * p[1]}; };
    for (const Vec3& p : m.positions) m.colors.push_back(tint(p));
    const std::size_t before = m.vertexCount();
    mesh::computeCenterlineUvs(m);
    ASSERT_GT(m.vertexCount(), before);
    ASSERT_TRUE(m.hasColors());
    for (std::size_t v = 0; v < m.vertexCount(); ++v) ASSERT_EQ(m.colors[v], tint(m.positions[v])) << v;
}

TEST(CenterlineUv, InsideOutCylinderKeepsTheWindingOrientation) {
    Mesh m = cylinder(5, 40, 32, 20);
    mesh::flipOrientation(m);
    mesh::computeCenterlineUvs(m);
    EXPECT_EQ(mesh::measureUvStretch(m).flippedTriangles, 0u);
    EXPECT_EQ(mesh::computeTangents(m).mirroredVertices, 0u);
}

TEST(CenterlineUv, ThinTubeWrapsOnceAndStaysSquare) {
    Mesh m = cylinder(2, 30, 24, 30);
    mesh::CenterlineUvOptions o;
    o.tileLength = 50;  // much longer than the circumference: one wrap anyway
    const auto rep = mesh::computeCenterlineUvs(m, o);
    EXPECT_EQ(rep.tileLength, 50.0f);
    EXPECT_LT(mesh::measureUvStretch(m).anisotropyP95, 1.05);
}

TEST(CenterlineUv, WorksOnTheCtAirway) {
    Mesh m = mesh::load(testdata("airway/vh_m_airway_lumen.obj"));
    mesh::flipOrientation(m);
    const auto rep = mesh::computeCenterlineUvs(m);
    mesh::computeTangents(m);
    const auto r = mesh::analyze(m);
    ASSERT_TRUE(r.stretch);
    const auto& s = *r.stretch;
    std::printf(
        "CT airway: %zu pieces, %zu branches, tile %.1f mm, %zu seam vertices; area ratio p5 %.2f p50 %.2f p95 "
        "%.2f; anisotropy p50 %.3f p95 %.2f; flipped %zu of %zu\n",
        rep.pieces, rep.centerline.branches.size(), rep.tileLength, rep.seamVertices, s.areaP05, s.areaP50, s.areaP95,
        s.anisotropyP50, s.anisotropyP95, s.flippedTriangles, r.triangles);
    // 28 triangles at the poles of the closed carina piece and the trachea's rim.
    EXPECT_LT(double(trianglesSpanningU(m, 0.25)), 0.005 * double(r.triangles));
    EXPECT_EQ(r.badTangents, 0u);
    EXPECT_EQ(r.nonFiniteValues, 0u);
    EXPECT_EQ(s.zeroUvAreaTriangles, 0u);
    // No fold (2 324 when the whole branch took one sense: the inner wall of
    // this thick shell faces its axis, the outer wall away from it).
    EXPECT_LT(double(s.flippedTriangles), 0.001 * double(r.triangles));
    EXPECT_LT(s.anisotropyP50, 1.3);
    EXPECT_EQ(r.nonManifoldEdges, 0u);
    EXPECT_EQ(r.boundaryEdges, 112u) << "UV seams add vertices, not boundaries";
}

}  // namespace
}  // namespace mucosa::test
