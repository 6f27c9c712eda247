#include <cmath>
#include <fstream>

#include <gtest/gtest.h>

#include <mucosa/core/error.hpp>
#include <mucosa/mesh/analysis.hpp>
#include <mucosa/mesh/io.hpp>
#include <mucosa/mesh/tangents.hpp>

#include "mesh_test_util.hpp"

namespace mucosa::test {
namespace {

Mesh texturedAirway() {
    Mesh m = mesh::load(testdata("gltf/NormalTangentMirrorTest.glb"));
    return m;
}

TEST(MeshIo, GlbOutputFollowsAccessorRules) {
    TempDir dir;
    const Mesh m = texturedAirway();
    mesh::save(m, dir / "out.glb");
    const Glb g = parseGlb(readBytes(dir / "out.glb"));
    checkGltfRules(g, m.vertexCount());
}

TEST(MeshIo, GltfEmbedsBufferAndFollowsRules) {
    TempDir dir;
    Mesh m = mesh::load(testdata("gltf/NormalTangentTest.glb"));
    mesh::computeTangents(m);
    mesh::save(m, dir / "out.gltf");
    Glb g;
    g.json = nlohmann::json::parse(readBytes(dir / "out.gltf"));
    const std::string uri = g.json["buffers"][0]["uri"];
    const std::string prefix = "data:application/octet-stream;base64,";
    ASSERT_EQ(uri.rfind(prefix, 0), 0u);
    // Decode base64.
    std::string b64 = uri.substr(prefix.size());
    auto val = [](char c) -> int {
        if (c >= 'A' && c <= 'Z') return c - 'A';
        if (c >= 'a' && c <= 'z') return c - 'a' + 26;
        if (c >= '0' && c <= '9') return c - '0' + 52;
        return c == '+' ? 62 : 63;
    };
    for (std::size_t i = 0; i + 3 < b64.size(); i += 4) {
        const int a = val(b64[i]), b = val(b64[i + 1]);
        g.bin += static_cast<char>(a << 2 | b >> 4);
        if (b64[i + 2] != '=') g.bin += static_cast<char>((b & 15) << 4 | val(b64[i + 2]) >> 2);
        if (b64[i + 3] != '=') g.bin += static_cast<char>((val(b64[i + 2]) & 3) << 6 | val(b64[i + 3]));
    }
    checkGltfRules(g, m.vertexCount());
    // And it reads back.
    const Mesh back = mesh::load(dir / "out.gltf");
    EXPECT_EQ(back.triangleCount(), m.triangleCount());
}

// Write -> read back keeps every corner's attributes (glTF: through metres and
// the v flip; PLY/OBJ: millimetres).
void expectRoundTrip(const Mesh& a, const Mesh& b, bool tangents) {
    ASSERT_EQ(a.triangleCount(), b.triangleCount());
    for (std::size_t c = 0; c < a.indices.size(); ++c) {
        const auto i = a.indices[c], j = b.indices[c];
        for (int k = 0; k < 3; ++k)
            ASSERT_NEAR(a.positions[i][k], b.positions[j][k], 1e-4f * (1 + std::abs(a.positions[i][k])));
        for (int k = 0; k < 3; ++k) ASSERT_NEAR(a.normals[i][k], b.normals[j][k], 1e-5f);
        for (int k = 0; k < 2; ++k) ASSERT_NEAR(a.uvs[i][k], b.uvs[j][k], 1e-6f) << "corner " << c;
        if (tangents) {
            for (int k = 0; k < 4; ++k) ASSERT_NEAR(a.tangents[i][k], b.tangents[j][k], 1e-5f) << "corner " << c;
        }
    }
}

TEST(MeshIo, RoundTripsGlbPlyObj) {
    TempDir dir;
    const Mesh m = texturedAirway();
    for (const char* name : {"rt.glb", "rt.gltf", "rt.ply", "rt.obj"}) {
        mesh::save(m, dir / name);
        mesh::LoadOptions o;
        o.unit = mesh::Unit::Auto;
        const Mesh back = mesh::load(dir / name, o);
        SCOPED_TRACE(name);
        expectRoundTrip(m, back, std::string(name).find(".gl") != std::string::npos);
    }
}

// A tint that differs at every vertex (and is not a function of the position
// alone: a reordering or a mix-up of vertices shows).
Mesh withColors(Mesh m) {
    m.colors.resize(m.vertexCount());
    for (std::size_t v = 0; v < m.vertexCount(); ++v) {
        const float t = static_cast<float>(v) / static_cast<float>(m.vertexCount());
        m.colors[v] = {0.25f + 0.75f * t, 1.0f - 0.5f * t, 0.125f + 0.5f * float((v * 7) % 13) / 13.0f};
    }
    return m;
}

// Vertex colours survive every writer and the importer: glTF COLOR_0 (float
// VEC3), PLY float red/green/blue, OBJ `v x y z r g b`; bit-exact (all three
// keep floats exactly), on every corner.
TEST(MeshIo, ColorsRoundTripGlbPlyObj) {
    TempDir dir;
    const Mesh m = withColors(texturedAirway());
    for (const char* name : {"c.glb", "c.gltf", "c.ply", "c.obj"}) {
        SCOPED_TRACE(name);
        mesh::save(m, dir / name);
        mesh::LoadOptions o;
        o.unit = mesh::Unit::Auto;
        mesh::LoadInfo info;
        const Mesh back = mesh::load(dir / name, o, &info);
        EXPECT_TRUE(info.fileHadColors);
        ASSERT_TRUE(back.hasColors());
        ASSERT_EQ(back.triangleCount(), m.triangleCount());
        for (std::size_t c = 0; c < m.indices.size(); ++c)
            for (int k = 0; k < 3; ++k)
                ASSERT_EQ(m.colors[m.indices[c]][k], back.colors[back.indices[c]][k]) << "corner " << c;
        expectRoundTrip(m, back, std::string(name).find(".gl") != std::string::npos);
    }
    // Without colours nothing is invented.
    mesh::save(texturedAirway(), dir / "plain.ply");
    mesh::LoadInfo info;
    EXPECT_FALSE(mesh::load(dir / "plain.ply", {}, &info).hasColors());
    EXPECT_FALSE(info.fileHadColors);
    const Glb g = parseGlb(readBytes(dir / "c.glb"));
    const auto& accessor =
        g.json["accessors"][g.json["meshes"][0]["primitives"][0]["attributes"]["COLOR_0"].get<int>()];
    EXPECT_EQ(accessor["type"], "VEC3");
    EXPECT_EQ(accessor["componentType"], 5126);  // FLOAT
}

// Colours from other tools: a PLY with uchar red/green/blue reads as /255; out
// of range values in an OBJ are clamped to 0..1 with a warning.
TEST(MeshIo, ColorsFromOtherToolsAreNormalisedAndClamped) {
    TempDir dir;
    std::string ply =
        "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
        "property uchar red\nproperty uchar green\nproperty uchar blue\nelement face 1\n"
        "property list uchar int vertex_indices\nend_header\n0 0 0 255 0 51\n10 0 0 0 255 102\n0 10 0 255 255 255\n"
        "3 0 1 2\n";
    std::ofstream(dir / "u8.ply", std::ios::binary) << ply;
    const Mesh a = mesh::load(dir / "u8.ply");
    ASSERT_TRUE(a.hasColors());
    EXPECT_NEAR(a.colors[0][0], 1.0f, 1e-6f);
    EXPECT_NEAR(a.colors[0][2], 0.2f, 1e-6f);
    EXPECT_NEAR(a.colors[1][2], 0.4f, 1e-6f);
    std::ofstream(dir / "hot.obj", std::ios::binary)
        << "v 0 0 0 2 0.5 -1\nv 10 0 0 0.1 0.2 0.3\nv 0 10 0 1 1 1\nf 1 2 3\n";
    mesh::LoadInfo info;
    const Mesh b = mesh::load(dir / "hot.obj", {}, &info);
    ASSERT_TRUE(b.hasColors());
    bool warned = false;
    for (const std::string& w : info.warnings) warned = warned || w.find("clamped at 1 of 3") != std::string::npos;
    EXPECT_TRUE(warned);
    for (const Vec3& c : b.colors)
        for (float x : c) EXPECT_TRUE(x >= 0.0f && x <= 1.0f);
    // The in-range vertex keeps its colour.
    bool found = false;
    for (const Vec3& c : b.colors) found = found || (std::abs(c[0] - 0.1f) < 1e-6f && std::abs(c[2] - 0.3f) < 1e-6f);
    EXPECT_TRUE(found);
}

TEST(MeshIo, AirwayLoadsInMillimetres) {
    mesh::LoadInfo info;
    const Mesh m = mesh::load(testdata("airway/vh_m_airway_lumen.obj"), {}, &info);
    EXPECT_EQ(info.scaleToMillimetres, 1000.0);
    const auto r = mesh::analyze(m);
    // Trachea + main bronchi: about 156 mm tall (the stats file: 0.1563 m).
    EXPECT_NEAR(r.boundsMax[1] - r.boundsMin[1], 156.3, 0.1);
    EXPECT_TRUE(m.hasNormals());
    EXPECT_EQ(r.badNormals, 0u);
    EXPECT_EQ(r.nonManifoldEdges, 0u);
    EXPECT_GT(r.signedVolume, 0) << "normals point out of the lumen in this file";
}

void writeText(const std::filesystem::path& p, const std::string& s) {
    std::ofstream(p, std::ios::binary) << s;
}

TEST(MeshIo, BadInputsThrowTypedErrors) {
    TempDir dir;
    EXPECT_THROW(mesh::load(dir / "missing.obj"), IoError);
    writeText(dir / "x.xyzzy", "hello");
    EXPECT_THROW(mesh::load(dir / "x.xyzzy"), InputError);
    writeText(dir / "empty.obj", "");
    EXPECT_THROW(mesh::load(dir / "empty.obj"), InputError);
    writeText(dir / "points.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\n");
    EXPECT_THROW(mesh::load(dir / "points.obj"), InputError);
    writeText(dir / "nan.obj", "v 0 0 0\nv nan 0 0\nv 0 1 0\nf 1 2 3\n");
    EXPECT_THROW(mesh::load(dir / "nan.obj"), InputError);
    writeText(dir / "range.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n");
    EXPECT_THROW(mesh::load(dir / "range.obj"), InputError);
    // A PLY header that promises four billion vertices: refused before allocating.
    writeText(dir / "huge.ply",
              "ply\nformat binary_little_endian 1.0\nelement vertex 4000000000\nproperty float x\nproperty float y\n"
              "property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n");
    EXPECT_THROW(mesh::load(dir / "huge.ply"), InputError);
    // A binary STL whose count disagrees with its size.
    std::string stl(84, '\0');
    const std::uint32_t count = 1000000000;
    std::memcpy(stl.data() + 80, &count, 4);
    writeText(dir / "huge.stl", stl);
    EXPECT_THROW(mesh::load(dir / "huge.stl"), InputError);
}

TEST(MeshIo, WriterRefusesBadMeshesAndLeavesNoFile) {
    TempDir dir;
    Mesh m = grid(2);
    m.indices.push_back(99);
    m.indices.push_back(0);
    m.indices.push_back(1);
    EXPECT_THROW(mesh::save(m, dir / "bad.glb"), InputError);
    EXPECT_FALSE(std::filesystem::exists(dir / "bad.glb"));
    EXPECT_THROW(mesh::save(grid(2), dir / "bad.fbx"), InputError);
    EXPECT_THROW(mesh::save(grid(2), dir / "no" / "dir.glb"), IoError);
    EXPECT_EQ(std::distance(std::filesystem::directory_iterator(dir.path()), {}), 0);
}

TEST(MeshIo, StlAndPlyImportGetNormals) {
    TempDir dir;
    writeText(dir / "tri.stl",
              "solid t\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 10 0 0\nvertex 0 10 0\nendloop\nendfacet\n"
              "endsolid t\n");
    const Mesh m = mesh::load(dir / "tri.stl");
    ASSERT_EQ(m.triangleCount(), 1u);
    ASSERT_TRUE(m.hasNormals());
    EXPECT_NEAR(m.normals[0][2], 1.0f, 1e-6f);
}

}  // namespace
}  // namespace mucosa::test
