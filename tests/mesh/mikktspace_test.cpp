// Mucosa's tangent frames against a real MikkTSpace (the npm `mikktspace`
// package, a WebAssembly build of a port of Mikkelsen's reference C code, in
// tools/node/node_modules): per triangle corner, the angle between the two
// tangents (both projected on the corner's tangent plane) and the sign w.
// MikkTSpace is what Blender, Unity and Unreal regenerate on import, so a
// normal or reflectance map baked against one frame reads right in the other
// only where they agree. Also the centerline UVs' folded triangles, where no
// per-vertex frame can agree. Fails (never skips) without node or the package.
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>

#include <gtest/gtest.h>

#include <mucosa/mesh/analysis.hpp>
#include <mucosa/mesh/io.hpp>
#include <mucosa/mesh/phantom.hpp>
#include <mucosa/mesh/repair.hpp>
#include <mucosa/mesh/tangents.hpp>
#include <mucosa/mesh/uv.hpp>

#include "mesh_test_util.hpp"

namespace mucosa::test {
namespace {

namespace fs = std::filesystem;

struct Agreement {
    std::size_t corners = 0;
    double within2 = 0;     // fraction of corners whose tangents are within 2 degrees
    double maxDeg = 0;      // the largest angle
    double handedness = 0;  // fraction of corners with the same w
};

std::string nodeBinary() {
    for (const char* p : {"/usr/bin/node", "/usr/local/bin/node"})
        if (fs::exists(p)) return p;
    return {};
}

// MikkTSpace's tangents for m's triangles (unindexed: 3 corners each) next to
// Mucosa's (m.tangents), compared per corner.
Agreement compareWithMikkTSpace(const Mesh& m, const std::string& label) {
    const fs::path modules = fs::path(MUCOSA_SOURCE_DIR) / "tools/node/node_modules";
    const std::string node = nodeBinary();
    if (node.empty() || !fs::exists(modules / "mikktspace/package.json")) {
        ADD_FAILURE() << "MikkTSpace reference missing (node: " << (node.empty() ? "not found" : node) << ", "
                      << (modules / "mikktspace").string() << "): run scripts/install-deps";
        return {};
    }
    EXPECT_TRUE(m.hasTangents() && m.hasNormals() && m.hasUvs());
    TempDir dir;
    const std::size_t c = m.indices.size();
    {
        std::vector<float> data;
        data.reserve(8 * c);
        for (std::uint32_t i : m.indices) data.insert(data.end(), m.positions[i].begin(), m.positions[i].end());
        for (std::uint32_t i : m.indices) data.insert(data.end(), m.normals[i].begin(), m.normals[i].end());
        for (std::uint32_t i : m.indices) data.insert(data.end(), m.uvs[i].begin(), m.uvs[i].end());
        std::ofstream out(dir / "in.bin", std::ios::binary);
        const auto count = static_cast<std::uint32_t>(c);
        out.write(reinterpret_cast<const char*>(&count), 4);
        out.write(reinterpret_cast<const char*>(data.data()), static_cast<std::streamsize>(4 * data.size()));
    }
    const std::string cmd = "'" + node + "' '" + std::string(MUCOSA_SOURCE_DIR) +
                            "/tests/mesh/mikktspace_tangents.cjs' '" + modules.string() + "' '" +
                            (dir / "in.bin").string() + "' '" + (dir / "out.bin").string() + "'";
    const int status = std::system(cmd.c_str());
    if (status != 0) {
        ADD_FAILURE() << "mikktspace_tangents.cjs failed (" << status << "): " << cmd;
        return {};
    }
    const std::string bytes = readBytes(dir / "out.bin");
    if (bytes.size() != 16 * c) {
        ADD_FAILURE() << "mikktspace_tangents.cjs wrote " << bytes.size() << " bytes for " << c << " corners";
        return {};
    }
    std::vector<float> ref(4 * c);
    std::memcpy(ref.data(), bytes.data(), bytes.size());
    Agreement a;
    a.corners = c;
    std::size_t within = 0, same = 0;
    for (std::size_t k = 0; k < c; ++k) {
        const std::uint32_t v = m.indices[k];
        const Vec3& N = m.normals[v];
        auto project = [&](Vec3 t) {
            const float d = t[0] * N[0] + t[1] * N[1] + t[2] * N[2];
            for (int j = 0; j < 3; ++j) t[size_t(j)] -= d * N[size_t(j)];
            return t;
        };
        const Vec3 mine = project({m.tangents[v][0], m.tangents[v][1], m.tangents[v][2]});
        const Vec3 theirs = project({ref[4 * k], ref[4 * k + 1], ref[4 * k + 2]});
        const double angle = angleDeg(mine, theirs);
        within += angle <= 2.0 ? 1 : 0;
        a.maxDeg = std::max(a.maxDeg, std::isfinite(angle) ? angle : 180.0);
        same += (m.tangents[v][3] < 0) == (ref[4 * k + 3] < 0) ? 1 : 0;
    }
    a.within2 = double(within) / double(c);
    a.handedness = double(same) / double(c);
    std::printf("%s: %zu corners, %.4f%% within 2 deg of MikkTSpace, max %.2f deg, handedness equal on %.4f%%\n",
                label.c_str(), c, 100 * a.within2, a.maxDeg, 100 * a.handedness);
    ::testing::Test::RecordProperty(label + "_within_2deg", std::to_string(a.within2));
    ::testing::Test::RecordProperty(label + "_max_deg", std::to_string(a.maxDeg));
    ::testing::Test::RecordProperty(label + "_handedness", std::to_string(a.handedness));
    return a;
}

double foldedFraction(const Mesh& m) {
    const mesh::UvStretch s = mesh::measureUvStretch(m);
    std::printf("folded (flipped) triangles: %zu of %zu\n", s.flippedTriangles, m.triangleCount());
    return double(s.flippedTriangles) / double(m.triangleCount());
}

// A fold without a seam: u = |x - 4| / 8 mirrors the left half of a flat
// grid onto the right, sharing the middle column. Those 9 vertices need a
// frame per side (T = +x on the right, -x on the left); MikkTSpace gives each
// side its own, and so must the split.
TEST(MikkTSpace, FoldWithoutASeamSplitsTheSharedVertices) {
    Mesh m = grid(8);
    for (std::size_t v = 0; v < m.vertexCount(); ++v) m.uvs[v][0] = std::abs(m.positions[v][0] - 4.0f) / 8.0f;
    const std::size_t before = m.vertexCount();
    const mesh::TangentReport r = mesh::computeTangents(m);
    EXPECT_EQ(r.splitVertices, 9u);
    EXPECT_EQ(m.vertexCount(), before + 9);
    EXPECT_EQ(m.triangleCount(), 128u);
    const Agreement a = compareWithMikkTSpace(m, "fold");
    EXPECT_EQ(a.within2, 1.0);
    EXPECT_EQ(a.handedness, 1.0);
    // The left half is mirrored: w = -1 there, and T points to -x.
    for (std::size_t t = 0; t < m.triangleCount(); ++t) {
        const std::uint32_t v = m.indices[3 * t];
        const float cx = (m.positions[m.indices[3 * t]][0] + m.positions[m.indices[3 * t + 1]][0] +
                          m.positions[m.indices[3 * t + 2]][0]) /
                         3.0f;
        EXPECT_EQ(m.tangents[v][3], cx < 4.0f ? -1.0f : 1.0f) << t;
        EXPECT_NEAR(m.tangents[v][0], cx < 4.0f ? -1.0f : 1.0f, 1e-5f) << t;
    }
}

// The default phantom (its centerline UVs and tangents as mucosa phantom
// writes them). Before the centerline charts and MikkTSpace's groups: 9 432
// of 567 936 triangles folded, 98.53 % of corners within 2 degrees, 99.40 %
// of the same handedness, up to 180 degrees apart.
TEST(MikkTSpace, PhantomFramesAgreePerCorner) {
    const mesh::Phantom ph = mesh::makePhantom(mesh::PhantomParams{});
    EXPECT_LT(foldedFraction(ph.mesh), 0.001);
    const Agreement a = compareWithMikkTSpace(ph.mesh, "phantom");
    EXPECT_GE(a.within2, 0.999);
    EXPECT_EQ(a.handedness, 1.0);
}

// The CT airway (tests/data/airway), as it is and turned inside out:
// `mucosa mesh --uv centerline` then tangents. Before: 2 324 of 20 696
// triangles folded, 97.41 % of corners within 2 degrees, 98.99 % of the same
// handedness.
TEST(MikkTSpace, CtAirwayFramesAgreePerCorner) {
    for (const bool flipped : {false, true}) {
        Mesh m = mesh::load(testdata("airway/vh_m_airway_lumen.obj"));
        if (flipped) mesh::flipOrientation(m);
        mesh::computeCenterlineUvs(m);
        mesh::computeTangents(m);
        EXPECT_LT(foldedFraction(m), 0.001) << "flipped " << flipped;
        const Agreement a = compareWithMikkTSpace(m, flipped ? "ct_flipped" : "ct");
        EXPECT_GE(a.within2, 0.999) << "flipped " << flipped;
        EXPECT_EQ(a.handedness, 1.0) << "flipped " << flipped;
    }
}

}  // namespace
}  // namespace mucosa::test
