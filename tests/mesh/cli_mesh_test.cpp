#include <fstream>
#include <sstream>

#include <gtest/gtest.h>

#include <mucosa/mesh/analysis.hpp>
#include <mucosa/mesh/io.hpp>

#include "gltf_validator.hpp"
#include "mesh_test_util.hpp"

namespace mucosa::test {
namespace {

TEST(MeshCli, InfoReportsTheAirway) {
    const auto r = runCli("mesh info '" + testdata("airway/vh_m_airway_lumen.obj").string() + "'");
    ASSERT_EQ(r.exitCode, 0) << r.err;
    EXPECT_NE(r.out.find("x1000 to millimetres"), std::string::npos) << r.out;
    EXPECT_NE(r.out.find("triangles:     20696"), std::string::npos) << r.out;
    EXPECT_NE(r.out.find("boundary edges"), std::string::npos);
    EXPECT_NE(r.out.find("non-manifold"), std::string::npos);
}

TEST(MeshCli, ConvertsFlipsAndWritesTangents) {
    TempDir dir;
    const auto r = runCli("mesh '" + testdata("gltf/NormalTangentTest.glb").string() + "' -o '" +
                          (dir / "o.glb").string() + "' --flip --recompute-normals");
    ASSERT_EQ(r.exitCode, 0) << r.err;
    const Mesh m = mesh::load(dir / "o.glb");
    EXPECT_TRUE(m.hasTangents());
    EXPECT_EQ(mesh::analyze(m).badTangents, 0u);
    expectValidGltf(dir / "o.glb");
}

// The README's example: --orient lumen gives the same mesh whichever way the
// input faced (the CT airway as it comes, and --flip'ed), with the lumen's
// wall facing the lumen (this file already does: nothing turns).
TEST(MeshCli, OrientLumenGivesTheSameMeshFromEitherSide) {
    TempDir dir;
    const std::string ct = testdata("airway/vh_m_airway_lumen.obj").string();
    const auto flip = runCli("mesh '" + ct + "' -o '" + (dir / "flipped.ply").string() + "' --flip --no-tangents");
    ASSERT_EQ(flip.exitCode, 0) << flip.err;
    const auto a = runCli("mesh '" + ct + "' -o '" + (dir / "a.ply").string() + "' --orient lumen --uv centerline");
    ASSERT_EQ(a.exitCode, 0) << a.err;
    EXPECT_NE(a.out.find("oriented to the lumen: 0 of 2 patches turned"), std::string::npos) << a.out;
    const auto b = runCli("mesh '" + (dir / "flipped.ply").string() + "' -o '" + (dir / "b.ply").string() +
                          "' --orient lumen --uv centerline");
    ASSERT_EQ(b.exitCode, 0) << b.err;
    EXPECT_NE(b.out.find("oriented to the lumen: 2 of 2 patches turned (20696 triangles)"), std::string::npos) << b.out;
    const Mesh ma = mesh::load(dir / "a.ply"), mb = mesh::load(dir / "b.ply");
    EXPECT_EQ(ma.indices, mb.indices);
    EXPECT_EQ(ma.uvs, mb.uvs);
    ASSERT_EQ(ma.normals.size(), mb.normals.size());
    for (std::size_t v = 0; v < ma.normals.size(); ++v)  // renormalised on the way through the files
        for (int k = 0; k < 3; ++k)
            ASSERT_NEAR(ma.normals[v][std::size_t(k)], mb.normals[v][std::size_t(k)], 1e-6f) << v;
    // A mesh too small to have a ring: centerline UVs all at (0, 0), and
    // nothing to orient by (one error line).
    std::ofstream(dir / "quad.obj") << "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nf 1 2 3\nf 2 4 3\n";
    const auto quadUv =
        runCli("mesh '" + (dir / "quad.obj").string() + "' -o '" + (dir / "q.ply").string() + "' --uv centerline");
    EXPECT_EQ(quadUv.exitCode, 0) << quadUv.err;
    const auto quadOrient =
        runCli("mesh '" + (dir / "quad.obj").string() + "' -o '" + (dir / "c.ply").string() + "' --orient lumen");
    EXPECT_NE(quadOrient.exitCode, 0);
    expectOneErrorLine(quadOrient.err, "quad --orient lumen");
    EXPECT_NE(quadOrient.err.find("no centerline"), std::string::npos) << quadOrient.err;
    // Bad values and the contradiction: one error line each.
    for (const char* args : {"--orient inward", "--orient lumen --flip"}) {
        const auto r = runCli("mesh '" + ct + "' -o '" + (dir / "c.ply").string() + "' " + args);
        EXPECT_NE(r.exitCode, 0) << args;
        expectOneErrorLine(r.err, args);
        EXPECT_FALSE(std::filesystem::exists(dir / "c.ply")) << args;
    }
}

TEST(MeshCli, InfoCountsNonFiniteValuesAndUnitOverride) {
    TempDir dir;
    std::ofstream(dir / "nan.obj") << "v 0 0 0\nv 1 0 0\nv 0 1 0\nv inf 2 0\nf 1 2 3\nf 2 4 3\n";
    const auto r = runCli("mesh info '" + (dir / "nan.obj").string() + "'");
    ASSERT_EQ(r.exitCode, 0) << r.err;
    EXPECT_EQ(r.out.find("0 non-finite values"), std::string::npos) << r.out;
    EXPECT_NE(r.out.find("non-finite values"), std::string::npos) << r.out;
    const auto mm = runCli("mesh info --unit mm '" + testdata("airway/vh_m_airway_lumen.obj").string() + "'");
    ASSERT_EQ(mm.exitCode, 0) << mm.err;
    EXPECT_NE(mm.out.find("x1 to millimetres (as requested)"), std::string::npos) << mm.out;
}

TEST(MeshCli, BadInputsGiveOneErrorLineAndNoOutput) {
    TempDir dir;
    std::ofstream(dir / "nan.obj") << "v 0 0 0\nv nan 0 0\nv 0 1 0\nf 1 2 3\n";
    std::ofstream(dir / "empty.obj") << "";
    std::ofstream(dir / "range.obj") << "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 7\n";
    std::ofstream(dir / "lines.obj") << "v 0 0 0\nv 1 0 0\nl 1 2\n";
    std::ofstream(dir / "x.abcdef") << "v 0 0 0\n";
    const std::string out = (dir / "out.glb").string();
    for (const char* in : {"missing.obj", "nan.obj", "empty.obj", "range.obj", "lines.obj", "x.abcdef"}) {
        const auto r = runCli("mesh '" + (dir / in).string() + "' -o '" + out + "'");
        EXPECT_NE(r.exitCode, 0) << in;
        expectOneErrorLine(r.err, in);
        EXPECT_FALSE(std::filesystem::exists(out)) << in;
    }
    const auto bad =
        runCli("mesh '" + testdata("gltf/NormalTangentTest.glb").string() + "' -o '" + (dir / "o.fbx").string() + "'");
    EXPECT_NE(bad.exitCode, 0);
    expectOneErrorLine(bad.err, "fbx output");
    const auto missingInfo = runCli("mesh info '" + (dir / "missing.ply").string() + "'");
    EXPECT_NE(missingInfo.exitCode, 0);
    expectOneErrorLine(missingInfo.err, "info");
    // Nothing but the inputs is left in the directory (no temporaries).
    EXPECT_EQ(std::distance(std::filesystem::directory_iterator(dir.path()), {}), 5);
}

}  // namespace
}  // namespace mucosa::test
