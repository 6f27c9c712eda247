#include <cmath>

#include <gtest/gtest.h>

#include <mucosa/core/error.hpp>
#include <mucosa/mesh/analysis.hpp>
#include <mucosa/mesh/centerline.hpp>
#include <mucosa/mesh/io.hpp>
#include <mucosa/mesh/phantom.hpp>

#include "mesh_test_util.hpp"

namespace mucosa::test {
namespace {

const mesh::Phantom& defaultPhantom() {
    static const mesh::Phantom p = mesh::makePhantom(mesh::PhantomParams{});
    return p;
}

TEST(Phantom, IsWatertightManifoldAndFacesTheLumen) {
    const auto& ph = defaultPhantom();
    const auto r = mesh::analyze(ph.mesh);
    std::printf("phantom: %zu vertices, %zu triangles, %.1f x %.1f x %.1f mm\n", r.vertices, r.triangles,
                r.boundsMax[0] - r.boundsMin[0], r.boundsMax[1] - r.boundsMin[1], r.boundsMax[2] - r.boundsMin[2]);
    EXPECT_EQ(r.boundaryEdges, 0u);
    EXPECT_EQ(r.nonManifoldEdges, 0u);
    EXPECT_EQ(r.inconsistentEdges, 0u);
    EXPECT_EQ(r.components, 1u);
    EXPECT_EQ(r.degenerateTriangles, 0u);
    EXPECT_EQ(r.nonFiniteValues, 0u);
    EXPECT_LT(r.signedVolume, 0) << "winding (and normals) face into the enclosed lumen";
    EXPECT_EQ(r.normalsAgainstWinding, 0u);
    EXPECT_EQ(r.badNormals, 0u);
    EXPECT_EQ(r.badTangents, 0u);
    ASSERT_TRUE(r.hasUvs && r.hasTangents);
}

TEST(Phantom, HasTheDocumentedDimensions) {
    const auto& ph = defaultPhantom();
    const auto r = mesh::analyze(ph.mesh);
    // The trachea's top cap reaches its radius above the origin.
    EXPECT_NEAR(r.boundsMax[1], 9.0, 0.6);
    // Trachea cross-section halfway down: about 18 mm across (rings make it
    // up to 4.5 % narrower, the flatter posterior wall 7 %).
    double maxR = 0, minR = 1e9;
    for (const auto& p : ph.mesh.positions)
        if (std::abs(p[1] + 55) < 0.5) {
            const double rr = std::hypot(p[0], p[2]);
            maxR = std::max(maxR, rr);
            minR = std::min(minR, rr);
        }
    EXPECT_NEAR(2 * maxR, 18.0, 0.6);
    EXPECT_GT(2 * minR, 15.0);
    // The centerline: trachea 110 mm down -Y, main bronchi about 12 mm across.
    const auto& c = ph.centerline;
    ASSERT_EQ(c.branches.size(), 15u);  // 1 + 2 + 4 + 8 for 3 generations
    EXPECT_EQ(c.branches[0].name, "trachea");
    EXPECT_NEAR(c.branches[0].points.back()[1], -110.0f, 1e-3f);
    EXPECT_NEAR(c.branches[0].radii.front(), 9.0f, 1e-4f);
    EXPECT_NEAR(c.branches[1].radii.front() + c.branches[2].radii.front(), 12.0f, 0.01f);
    for (std::size_t i = 1; i < c.branches.size(); ++i) {
        const auto& b = c.branches[i];
        ASSERT_GE(b.parent, 0);
        ASSERT_LT(b.parent, static_cast<int>(i));
        const auto& par = c.branches[std::size_t(b.parent)];
        EXPECT_EQ(b.generation, par.generation + 1);
        EXPECT_LT(b.radii.front(), par.radii.front()) << "daughters are narrower (Murray)";
        // Each child starts at its parent's end (within the lateral shift).
        const float dx = b.points.front()[0] - par.points.back()[0], dy = b.points.front()[1] - par.points.back()[1],
                    dz = b.points.front()[2] - par.points.back()[2];
        EXPECT_LT(std::sqrt(dx * dx + dy * dy + dz * dz), par.radii.front());
    }
}

TEST(Phantom, CenterlineUvsStayNearSquare) {
    const auto s = mesh::measureUvStretch(defaultPhantom().mesh);
    std::printf("phantom uv stretch: area ratio p5 %.2f p50 %.2f p95 %.2f; anisotropy p50 %.3f p95 %.2f; flipped %zu\n",
                s.areaP05, s.areaP50, s.areaP95, s.anisotropyP50, s.anisotropyP95, s.flippedTriangles);
    EXPECT_LT(s.anisotropyP50, 1.2);
    EXPECT_LT(s.anisotropyP95, 4.0);
    EXPECT_EQ(s.zeroUvAreaTriangles, 0u);
    EXPECT_LT(double(s.flippedTriangles), 0.03 * double(defaultPhantom().mesh.triangleCount()));
    // Triangles spanning more than a quarter turn of u: only at the poles of
    // the closed caps (112 of 595 480 at the defaults), never at the seam.
    const Mesh& m = defaultPhantom().mesh;
    std::size_t wide = 0, mirrored = 0;
    for (std::size_t t = 0; t < m.triangleCount(); ++t) {
        float lo = 1e9f, hi = -1e9f;
        for (int k = 0; k < 3; ++k)
            lo = std::min(lo, m.uvs[m.indices[3 * t + k]][0]), hi = std::max(hi, m.uvs[m.indices[3 * t + k]][0]);
        wide += hi - lo > 0.25f ? 1 : 0;
    }
    for (const Vec4& T : m.tangents) mirrored += T[3] < 0 ? 1 : 0;
    std::printf("phantom: %zu triangles span > 1/4 turn of u; %zu of %zu tangent frames mirrored\n", wide, mirrored,
                m.vertexCount());
    EXPECT_LT(double(wide), 5e-4 * double(m.triangleCount()));
    EXPECT_LT(double(mirrored), 0.03 * double(m.vertexCount())) << "UVs follow the winding: frames are right-handed";
}

TEST(Phantom, CenterlineJsonRoundTrips) {
    TempDir dir;
    const auto& c = defaultPhantom().centerline;
    mesh::writeCenterlineJson(c, dir / "c.json");
    const auto back = mesh::readCenterlineJson(dir / "c.json");
    ASSERT_EQ(back.branches.size(), c.branches.size());
    for (std::size_t i = 0; i < c.branches.size(); ++i) {
        EXPECT_EQ(back.branches[i].parent, c.branches[i].parent);
        EXPECT_EQ(back.branches[i].points, c.branches[i].points);
        EXPECT_EQ(back.branches[i].radii, c.branches[i].radii);
    }
    const auto path = mesh::pathToBranch(c, 14);
    EXPECT_EQ(path.front(), (Vec3{0, 0, 0}));
    EXPECT_EQ(path.back(), c.branches[14].points.back());
}

TEST(Phantom, SeedChangesTheTreeAndIsReproducible) {
    mesh::PhantomParams p;
    p.generations = 4;
    const auto a = mesh::phantomCenterline(p), b = mesh::phantomCenterline(p);
    p.seed = 2;
    const auto c = mesh::phantomCenterline(p);
    EXPECT_EQ(a.branches.back().points, b.branches.back().points);
    EXPECT_NE(a.branches.back().points, c.branches.back().points);
    EXPECT_EQ(a.branches.size(), 31u);
    // Main bronchi are anatomical, not jittered.
    EXPECT_EQ(a.branches[1].points, c.branches[1].points);
}

TEST(Phantom, CoarseAndSmallVariantsAreWatertight) {
    for (int gens : {0, 1, 5}) {
        mesh::PhantomParams p;
        p.generations = gens;
        p.resolution = 1.0;
        const auto ph = mesh::makePhantom(p);
        const auto r = mesh::analyze(ph.mesh);
        EXPECT_TRUE(r.watertight()) << gens;
        EXPECT_EQ(r.components, 1u) << gens;
        EXPECT_EQ(r.badTangents, 0u) << gens;
    }
}

TEST(Phantom, GlbWithThirtyTwoBitIndicesFollowsAccessorRules) {
    TempDir dir;
    const Mesh& m = defaultPhantom().mesh;
    ASSERT_GT(m.vertexCount(), 65535u);
    mesh::save(m, dir / "phantom.glb");
    const Glb g = parseGlb(readBytes(dir / "phantom.glb"));
    checkGltfRules(g, m.vertexCount());
    EXPECT_EQ(g.json["accessors"][g.json["meshes"][0]["primitives"][0]["indices"].get<int>()]["componentType"], 5125);
}

TEST(Phantom, RefusesAGridThatCannotFitBeforeAllocating) {
    mesh::PhantomParams p;
    p.generations = 7;
    p.resolution = 16;  // billions of samples
    EXPECT_THROW(mesh::makePhantom(p), ResourceError);
}

TEST(Phantom, RefusesParametersOutOfRange) {
    mesh::PhantomParams p;
    p.generations = 99;
    EXPECT_THROW(mesh::makePhantom(p), InputError);
    p = {};
    p.resolution = 1000;
    EXPECT_THROW(mesh::makePhantom(p), InputError);
    p = {};
    p.resolution = 0;
    EXPECT_THROW(mesh::makePhantom(p), InputError);
}

TEST(PhantomCli, WritesMeshAndCenterlineOrOneErrorLine) {
    TempDir dir;
    const auto ok = runCli("-q phantom -o '" + (dir / "a.glb").string() + "' --generations 1 --resolution 1");
    ASSERT_EQ(ok.exitCode, 0) << ok.err;
    EXPECT_TRUE(std::filesystem::exists(dir / "a.glb"));
    const auto c = mesh::readCenterlineJson(dir / "a.centerline.json");
    EXPECT_EQ(c.branches.size(), 3u);
    const Mesh m = mesh::load(dir / "a.glb");
    EXPECT_TRUE(mesh::analyze(m).watertight());

    const auto bad = runCli("phantom -o '" + (dir / "b.glb").string() + "' --generations 42");
    EXPECT_NE(bad.exitCode, 0);
    EXPECT_EQ(bad.err.rfind("error: ", 0), 0u) << bad.err;
    EXPECT_FALSE(std::filesystem::exists(dir / "b.glb"));
    EXPECT_FALSE(std::filesystem::exists(dir / "b.centerline.json"));
    const auto badDir = runCli("phantom -o '" + (dir / "nodir" / "b.glb").string() + "'");
    EXPECT_NE(badDir.exitCode, 0);
    EXPECT_EQ(badDir.err.rfind("error: ", 0), 0u) << badDir.err;
}

}  // namespace
}  // namespace mucosa::test
