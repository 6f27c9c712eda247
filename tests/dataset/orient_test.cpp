// mucosa mesh --orient lumen: the surface faces the lumen, decided from the
// centerline -- measured the way a camera inside sees it: cameras along the
// airway looking ahead (a 100-degree cone of rays around the direction of the
// airway), the share of first hits whose triangle turns its front to the
// camera, and whose interpolated vertex normal faces it too. On the CT airway
// (a thick-walled shell) and the phantom, as they come and turned inside out
// (the same result either way).
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <numbers>

#include <gtest/gtest.h>

#include <mucosa/dataset/orient.hpp>
#include <mucosa/dataset/raycast.hpp>
#include <mucosa/mesh/io.hpp>
#include <mucosa/mesh/phantom.hpp>
#include <mucosa/mesh/primitives.hpp>
#include <mucosa/mesh/repair.hpp>
#include <mucosa/mesh/uv.hpp>

#include "test_support.hpp"

namespace mucosa::test {
namespace {

using frames::Vec3d;

Vec3d sub(const Vec3d& a, const Vec3d& b) {
    return {a[0] - b[0], a[1] - b[1], a[2] - b[2]};
}
double dot(const Vec3d& a, const Vec3d& b) {
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}
Vec3d cross(const Vec3d& a, const Vec3d& b) {
    return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}
Vec3d unit(const Vec3d& a) {
    const double l = std::sqrt(dot(a, a));
    return {a[0] / l, a[1] / l, a[2] / l};
}
Vec3d toD(const mesh::Vec3& v) {
    return {v[0], v[1], v[2]};
}

struct CameraView {
    std::size_t hits = 0, frontWinding = 0, frontNormal = 0;
    double winding() const { return double(frontWinding) / double(hits); }
    double normal() const { return double(frontNormal) / double(hits); }
};

// Cameras at `eyes`, each looking along its `ahead`: rays within 50 degrees of
// it (a 100-degree field of view), 400 per camera.
CameraView viewFromCameras(const mesh::Mesh& m, const std::vector<Vec3d>& eyes, const std::vector<Vec3d>& ahead) {
    const dataset::RayCaster caster(m);
    CameraView v;
    const double golden = std::numbers::pi * (3.0 - std::sqrt(5.0));
    const double cosMax = std::cos(50.0 * std::numbers::pi / 180.0);
    for (std::size_t c = 0; c < eyes.size(); ++c) {
        const Vec3d w = unit(ahead[c]);
        const Vec3d a = std::abs(w[0]) < 0.9 ? Vec3d{1, 0, 0} : Vec3d{0, 1, 0};
        const Vec3d x = unit(cross(a, w)), y = cross(w, x);
        for (int i = 0; i < 400; ++i) {
            const double z = 1.0 - (1.0 - cosMax) * (i + 0.5) / 400.0, r = std::sqrt(1.0 - z * z);
            const double ph = golden * i;
            const Vec3d d{w[0] * z + r * (std::cos(ph) * x[0] + std::sin(ph) * y[0]),
                          w[1] * z + r * (std::cos(ph) * x[1] + std::sin(ph) * y[1]),
                          w[2] * z + r * (std::cos(ph) * x[2] + std::sin(ph) * y[2])};
            const auto hit = caster.firstHit(eyes[c], d, 0.1);
            if (!hit) continue;
            const std::size_t t = std::size_t(hit->triangle);
            const mesh::Vec3 &p0 = m.positions[m.indices[3 * t]], &p1 = m.positions[m.indices[3 * t + 1]],
                             &p2 = m.positions[m.indices[3 * t + 2]];
            const Vec3d n = cross(sub(toD(p1), toD(p0)), sub(toD(p2), toD(p0)));
            const double b0 = 1 - hit->b1 - hit->b2;
            Vec3d N{0, 0, 0};
            for (int k = 0; k < 3; ++k)
                N[std::size_t(k)] = b0 * m.normals[m.indices[3 * t]][std::size_t(k)] +
                                    hit->b1 * m.normals[m.indices[3 * t + 1]][std::size_t(k)] +
                                    hit->b2 * m.normals[m.indices[3 * t + 2]][std::size_t(k)];
            ++v.hits;
            v.frontWinding += dot(n, d) < 0 ? 1 : 0;
            v.frontNormal += dot(N, d) < 0 ? 1 : 0;
        }
    }
    return v;
}

// The centerline the shape gives (the one mucosa mesh --orient lumen uses).
mesh::Centerline shapeCenterline(const mesh::Mesh& m) {
    mesh::Mesh shape;
    shape.positions = m.positions;
    shape.indices = m.indices;
    return mesh::computeCenterlineUvs(shape).centerline;
}

// Centroid of the vertices within a slab of the airway's long (y) axis.
Vec3d slabCentroid(const mesh::Mesh& m, double y0, double y1) {
    Vec3d s{0, 0, 0};
    int n = 0;
    for (const auto& p : m.positions)
        if (p[1] >= y0 && p[1] <= y1) s = {s[0] + p[0], s[1] + p[1], s[2] + p[2]}, ++n;
    return {s[0] / n, s[1] / n, s[2] / n};
}

void expectSameMesh(const mesh::Mesh& a, const mesh::Mesh& b) {
    EXPECT_EQ(a.indices, b.indices);
    EXPECT_EQ(a.normals, b.normals);
}

TEST(OrientLumen, CtAirwayFacesTheCamerasInsideAsItComesAndInsideOut) {
    const mesh::Mesh raw = mesh::load(testdata("airway/vh_m_airway_lumen.obj"));
    // Cameras down the trachea (it runs along -y from 660 to 504 mm): every
    // 10 mm from 640 to 560 mm, looking at the next slab's centre.
    std::vector<Vec3d> eyes, ahead;
    for (double y = 640; y >= 560; y -= 10) {
        const Vec3d e = slabCentroid(raw, y - 2, y + 2), next = slabCentroid(raw, y - 12, y - 8);
        eyes.push_back(e);
        ahead.push_back(sub(next, e));
    }
    mesh::Mesh inside = raw;
    mesh::flipOrientation(inside);
    const CameraView rawView = viewFromCameras(raw, eyes, ahead), insideView = viewFromCameras(inside, eyes, ahead);
    std::printf("CT airway, cameras in the trachea: front faces seen %.1f %% as it comes, %.1f %% inside out\n",
                100 * rawView.winding(), 100 * insideView.winding());
    EXPECT_LT(insideView.winding(), 0.05) << "--flip turns the lumen's wall away from the camera";

    mesh::Mesh a = raw, b = inside;
    const mesh::Centerline ca = shapeCenterline(a), cb = shapeCenterline(b);
    const dataset::LumenOrientReport ra = dataset::orientToLumen(a, ca), rb = dataset::orientToLumen(b, cb);
    std::printf(
        "orient lumen: %zu patches; as it comes %zu turned (%zu triangles), inside out %zu turned (%zu triangles); "
        "centerline rays' first hits on the front %.1f %% -> %.1f %% and %.1f %% -> %.1f %%\n",
        ra.patches, ra.turnedPatches, ra.turnedTriangles, rb.turnedPatches, rb.turnedTriangles,
        100 * ra.before.frontFraction(), 100 * ra.after.frontFraction(), 100 * rb.before.frontFraction(),
        100 * rb.after.frontFraction());
    EXPECT_EQ(ra.turnedPatches, 0u) << "this file's wall already faces its lumen";
    EXPECT_EQ(rb.turnedPatches, rb.patches);
    expectSameMesh(a, b);
    EXPECT_EQ(a.indices, raw.indices);
    for (const mesh::Mesh* m : {&a, &b}) {
        const CameraView v = viewFromCameras(*m, eyes, ahead);
        std::printf("after --orient lumen: %zu first hits, %.2f %% face the camera (winding), %.2f %% (normals)\n",
                    v.hits, 100 * v.winding(), 100 * v.normal());
        EXPECT_GE(v.winding(), 0.95);
        EXPECT_GE(v.normal(), 0.95);
    }
}

TEST(OrientLumen, PhantomKeepsItsLumenSideAndComesBackFromInsideOut) {
    mesh::PhantomParams pp;
    pp.generations = 2;
    const mesh::Phantom ph = mesh::makePhantom(pp);
    // Cameras along every branch of the phantom's own (analytic) centerline,
    // looking down it.
    std::vector<Vec3d> eyes, ahead;
    for (const mesh::CenterlineBranch& br : ph.centerline.branches)
        for (std::size_t i = 0; i + 1 < br.points.size(); i += 4) {
            eyes.push_back(toD(br.points[i]));
            ahead.push_back(sub(toD(br.points[i + 1]), toD(br.points[i])));
        }
    mesh::Mesh a = ph.mesh, b = ph.mesh;
    a.tangents.clear();
    b.tangents.clear();
    mesh::flipOrientation(b);
    const dataset::LumenOrientReport ra = dataset::orientToLumen(a, shapeCenterline(a));
    const dataset::LumenOrientReport rb = dataset::orientToLumen(b, shapeCenterline(b));
    std::printf("phantom: %zu patch(es); as it comes %zu turned, inside out %zu turned (%zu triangles)\n", ra.patches,
                ra.turnedPatches, rb.turnedPatches, rb.turnedTriangles);
    EXPECT_EQ(ra.turnedPatches, 0u) << "the phantom already faces its lumen";
    EXPECT_EQ(ra.normalsTurned, 0u);
    EXPECT_EQ(rb.turnedTriangles, b.triangleCount());
    expectSameMesh(a, b);
    EXPECT_EQ(a.indices, ph.mesh.indices);
    EXPECT_EQ(a.normals, ph.mesh.normals);
    const CameraView v = viewFromCameras(b, eyes, ahead);
    std::printf("phantom after --orient lumen: %zu first hits, %.2f %% face the camera (winding), %.2f %% (normals)\n",
                v.hits, 100 * v.winding(), 100 * v.normal());
    EXPECT_GE(v.winding(), 0.95);
    EXPECT_GE(v.normal(), 0.95);
}

TEST(OrientLumen, EachTriangleKeepsItsMaterialWhenItIsTurned) {
    // A tube inside out, with per-triangle materials (a glTF model's primitives):
    // turning it re-winds triangles in place, so each keeps its material.
    mesh::Mesh m = mesh::makeTube(5, 40, 24, 20);
    mesh::flipOrientation(m);
    for (std::size_t t = 0; t < m.triangleCount(); ++t) m.materials.push_back(std::uint32_t(t % 5 == 0 ? 2 : t % 2));
    auto corners = [](const mesh::Mesh& x, std::size_t t) {
        std::array<std::uint32_t, 3> c{x.indices[3 * t], x.indices[3 * t + 1], x.indices[3 * t + 2]};
        std::sort(c.begin(), c.end());
        return c;
    };
    const mesh::Mesh before = m;
    const dataset::LumenOrientReport r = dataset::orientToLumen(m, shapeCenterline(m));
    EXPECT_EQ(r.turnedTriangles, m.triangleCount());
    ASSERT_EQ(m.materials.size(), m.triangleCount());
    ASSERT_EQ(m.positions.size(), before.positions.size());  // no vertex was split or merged
    for (std::size_t t = 0; t < m.triangleCount(); ++t) {
        EXPECT_EQ(corners(m, t), corners(before, t)) << t;
        EXPECT_EQ(m.materials[t], before.materials[t]) << t;
    }
}

}  // namespace
}  // namespace mucosa::test
