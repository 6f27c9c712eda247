#include <algorithm>
#include <cmath>

#include <gtest/gtest.h>

#include <mucosa/core/error.hpp>
#include <mucosa/mesh/analysis.hpp>
#include <mucosa/mesh/io.hpp>
#include <mucosa/mesh/tangents.hpp>

#include "mesh_test_util.hpp"

namespace mucosa::test {
namespace {

Vec3 xyz(const Vec4& t) {
    return {t[0], t[1], t[2]};
}
float dot3(const Vec3& a, const Vec3& b) {
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

// Every frame: finite, T unit and _|_ N, w = +-1.
void expectOrthonormal(const Mesh& m) {
    ASSERT_TRUE(m.hasTangents());
    for (std::size_t v = 0; v < m.vertexCount(); ++v) {
        const Vec4& T = m.tangents[v];
        for (float c : T) ASSERT_TRUE(std::isfinite(c)) << "vertex " << v;
        const Vec3 t = xyz(T);
        ASSERT_NEAR(std::sqrt(dot3(t, t)), 1.0f, 1e-5f) << "vertex " << v;
        ASSERT_NEAR(dot3(t, m.normals[v]), 0.0f, 1e-5f) << "vertex " << v;
        ASSERT_TRUE(T[3] == 1.0f || T[3] == -1.0f) << "vertex " << v;
    }
}

TEST(Tangents, AgreeWithMikkTSpaceOnMirrorTestModel) {
    // The Khronos sample ships MikkTSpace tangents (Blender's bake).
    const Mesh reference = mesh::load(testdata("gltf/NormalTangentMirrorTest.glb"));
    ASSERT_TRUE(reference.hasTangents());
    ASSERT_TRUE(reference.hasUvs());
    Mesh m = reference;
    m.tangents.clear();
    mesh::computeTangents(m);
    expectOrthonormal(m);

    std::vector<double> angles;
    std::size_t sameHandedness = 0, mirroredReference = 0;
    for (std::size_t v = 0; v < m.vertexCount(); ++v) {
        angles.push_back(angleDeg(xyz(m.tangents[v]), xyz(reference.tangents[v])));
        sameHandedness += m.tangents[v][3] == reference.tangents[v][3] ? 1 : 0;
        mirroredReference += reference.tangents[v][3] < 0 ? 1 : 0;
    }
    std::sort(angles.begin(), angles.end());
    auto pct = [&](double q) { return angles[static_cast<std::size_t>(q * double(angles.size() - 1))]; };
    const double within2 =
        double(std::upper_bound(angles.begin(), angles.end(), 2.0) - angles.begin()) / double(angles.size());
    std::printf(
        "MikkTSpace agreement on %zu vertices (%zu mirrored): angle p50 %.4f deg, p90 %.4f, p99 %.4f, max %.4f; "
        "%.2f%% within 2 deg; handedness equal on %zu\n",
        angles.size(), mirroredReference, pct(0.5), pct(0.9), pct(0.99), angles.back(), 100 * within2, sameHandedness);
    RecordProperty("angle_p50_deg", std::to_string(pct(0.5)));
    RecordProperty("angle_p99_deg", std::to_string(pct(0.99)));
    RecordProperty("within_2deg", std::to_string(within2));
    EXPECT_GT(mirroredReference, 0u) << "the model's mirrored half should have w = -1";
    EXPECT_EQ(sameHandedness, m.vertexCount());
    EXPECT_GE(within2, 0.99);
}

TEST(Tangents, OrthonormalAndRightHandedOnNormalTangentTest) {
    Mesh m = mesh::load(testdata("gltf/NormalTangentTest.glb"));
    ASSERT_FALSE(m.hasTangents()) << "this sample ships without tangents";
    const auto r = mesh::computeTangents(m);
    expectOrthonormal(m);
    // Its UVs are not mirrored anywhere: every frame is right-handed, and B
    // follows the texture's +v on every triangle.
    EXPECT_EQ(r.mirroredVertices, 0u);
    for (std::size_t t = 0; t < m.triangleCount(); ++t) {
        const auto a = m.indices[3 * t], b = m.indices[3 * t + 1], c = m.indices[3 * t + 2];
        const float s1 = m.uvs[b][0] - m.uvs[a][0], t1 = m.uvs[b][1] - m.uvs[a][1];
        const float s2 = m.uvs[c][0] - m.uvs[a][0], t2 = m.uvs[c][1] - m.uvs[a][1];
        EXPECT_GT(s1 * t2 - s2 * t1, 0.0f) << "triangle " << t << " has UVs wound clockwise";
    }
}

TEST(Tangents, FlatGridGivesAxisFrames) {
    Mesh m = grid(4);
    mesh::computeTangents(m);
    for (const Vec4& T : m.tangents) {
        EXPECT_NEAR(T[0], 1.0f, 1e-6f);
        EXPECT_NEAR(T[1], 0.0f, 1e-6f);
        EXPECT_EQ(T[3], 1.0f);
    }
}

TEST(Tangents, MirroredUvFlipsHandedness) {
    Mesh m = grid(4);
    for (Vec2& uv : m.uvs) uv[1] = 1.0f - uv[1];  // mirror v
    mesh::computeTangents(m);
    expectOrthonormal(m);
    for (const Vec4& T : m.tangents) {
        EXPECT_NEAR(T[0], 1.0f, 1e-6f);
        EXPECT_EQ(T[3], -1.0f);  // B = -cross(N, T) = -y: along +v, which now runs down
    }
    Mesh u = grid(4);
    for (Vec2& uv : u.uvs) uv[0] = 1.0f - uv[0];  // mirror u
    mesh::computeTangents(u);
    for (const Vec4& T : u.tangents) {
        EXPECT_NEAR(T[0], -1.0f, 1e-6f);
        EXPECT_EQ(T[3], -1.0f);
    }
}

TEST(Tangents, ZeroUvAreaTrianglesGiveNoNaN) {
    // All UVs equal: no triangle says anything about dP/du.
    Mesh m = grid(3);
    for (Vec2& uv : m.uvs) uv = {0.5f, 0.5f};
    const auto r = mesh::computeTangents(m);
    expectOrthonormal(m);
    EXPECT_EQ(r.degenerateUvTriangles, m.triangleCount());
    EXPECT_EQ(r.fallbackVertices, m.vertexCount());
    // UVs on a line (u varies, v does not): zero area too.
    Mesh line = grid(3);
    for (Vec2& uv : line.uvs) uv[1] = 0;
    mesh::computeTangents(line);
    expectOrthonormal(line);
}

TEST(Tangents, MixedDegenerateAndGoodTrianglesUseTheGoodOnes) {
    Mesh m = grid(2);
    // Collapse the UVs of the first triangle only.
    for (int k = 1; k < 3; ++k) m.uvs[m.indices[k]] = m.uvs[m.indices[0]];
    mesh::computeTangents(m);
    expectOrthonormal(m);
}

TEST(Tangents, SingleTriangleAndDegenerateGeometry) {
    Mesh m;
    m.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
    m.normals = {{0, 0, 1}, {0, 0, 1}, {0, 0, 1}};
    m.uvs = {{0, 0}, {1, 0}, {0, 1}};
    m.indices = {0, 1, 2};
    mesh::computeTangents(m);
    expectOrthonormal(m);
    EXPECT_NEAR(m.tangents[0][0], 1.0f, 1e-6f);

    // Zero-area triangle (all corners at one point) and an isolated vertex.
    Mesh d;
    d.positions = {{1, 1, 1}, {1, 1, 1}, {1, 1, 1}, {5, 5, 5}};
    d.normals = {{0, 1, 0}, {0, 1, 0}, {0, 1, 0}, {0, 0, -1}};
    d.uvs = {{0, 0}, {1, 0}, {0, 1}, {0, 0}};
    d.indices = {0, 1, 2};
    mesh::computeTangents(d);
    expectOrthonormal(d);
}

TEST(Tangents, NormalNotInTrianglePlaneStillOrthogonal) {
    Mesh m = grid(2);
    for (Vec3& N : m.normals) N = {0.6f, 0.0f, 0.8f};  // tilted normals
    mesh::computeTangents(m);
    expectOrthonormal(m);
}

TEST(Tangents, ResultDoesNotDependOnThreadCount) {
    Mesh a = mesh::load(testdata("gltf/NormalTangentTest.glb")), b = a;
    mesh::computeTangents(a, 1);
    mesh::computeTangents(b, 0);
    EXPECT_EQ(a.tangents, b.tangents);
}

TEST(Tangents, RefusesMeshWithoutUvs) {
    Mesh m = grid(2);
    m.uvs.clear();
    EXPECT_THROW(mesh::computeTangents(m), InputError);
}

}  // namespace
}  // namespace mucosa::test
