// The ray caster (dataset::RayCaster): the tree's first hit is brute force's
// on random rays over meshes with seams and slivers, exact on analytic
// surfaces, and no ray slips between triangles sharing an edge.
#include <mucosa/dataset/raycast.hpp>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <random>

#include <gtest/gtest.h>

#include <mucosa/mesh/phantom.hpp>
#include <mucosa/mesh/primitives.hpp>

namespace mucosa {
namespace {

using frames::Vec3d;

// The nearest hit over every triangle, ties to the lower index.
std::optional<dataset::Hit> bruteForce(const mesh::Mesh& m, const Vec3d& o, const Vec3d& d, double tMin) {
    std::optional<dataset::Hit> best;
    for (std::size_t t = 0; t < m.triangleCount(); ++t)
        if (const auto h = dataset::intersectTriangle(m, static_cast<std::int32_t>(t), o, d, tMin))
            if (!best || h->t < best->t) best = h;
    return best;
}

Vec3d randomUnit(std::mt19937_64& rng) {
    std::normal_distribution<double> n;
    for (;;) {
        const Vec3d d{n(rng), n(rng), n(rng)};
        const double l = std::sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
        if (l > 1e-6) return {d[0] / l, d[1] / l, d[2] / l};
    }
}

// Rays from random points in the box lo..hi; at least `minHits` of them meet the mesh.
void expectSameAsBruteForce(const mesh::Mesh& m, const Vec3d& lo, const Vec3d& hi, int rays, std::uint64_t seed,
                            int minHits) {
    const dataset::RayCaster caster(m);
    std::mt19937_64 rng(seed);
    std::uniform_real_distribution<double> u(0, 1);
    int hits = 0;
    for (int r = 0; r < rays; ++r) {
        Vec3d o;
        for (int k = 0; k < 3; ++k) o[k] = lo[k] + u(rng) * (hi[k] - lo[k]);
        const Vec3d d = randomUnit(rng);
        const double tMin = r % 4 == 0 ? 0.0 : 2.0 * u(rng);
        const auto a = caster.firstHit(o, d, tMin);
        const auto b = bruteForce(m, o, d, tMin);
        ASSERT_EQ(a.has_value(), b.has_value()) << "ray " << r;
        if (!a) continue;
        ++hits;
        EXPECT_EQ(a->triangle, b->triangle) << "ray " << r;
        EXPECT_EQ(a->t, b->t) << "ray " << r;
        EXPECT_EQ(a->b1, b->b1) << "ray " << r;
        EXPECT_EQ(a->b2, b->b2) << "ray " << r;
        EXPECT_GE(a->t, tMin);
    }
    EXPECT_GE(hits, minHits);
}

TEST(RayCaster, FirstHitIsBruteForcesOnThePhantom) {
    mesh::PhantomParams p;
    p.generations = 1;
    p.resolution = 0.5;
    const mesh::Mesh m = mesh::makePhantom(p).mesh;
    ASSERT_GT(m.triangleCount(), 1000u);
    // Rays from inside the trachea and around the carina, in every direction.
    expectSameAsBruteForce(m, {-4, -120, -4}, {4, -5, 4}, 600, 1, 500);
}

TEST(RayCaster, FirstHitIsBruteForcesOnATubeAndASphere) {
    // The tube is open at both ends and the boxes reach outside the tube and
    // the sphere: many rays leave without a hit (from outside the sphere, most).
    expectSameAsBruteForce(mesh::makeTube(5.0f, 40.0f, 24, 40), {-3, -3, -35}, {3, 3, -2}, 1500, 2, 300);
    expectSameAsBruteForce(mesh::makeSphere(10.0f, 32, 16), {-15, -15, -15}, {15, 15, 15}, 1500, 3, 300);
}

TEST(RayCaster, APlaneIsHitExactlyWhereTheRayMeetsIt) {
    const mesh::Mesh quad = mesh::makeQuad(100.0f, 7);  // z = 0, cells of 100/7 mm: edges everywhere
    const dataset::RayCaster caster(quad);
    std::mt19937_64 rng(4);
    std::uniform_real_distribution<double> u(-1, 1);
    for (int r = 0; r < 5000; ++r) {
        const Vec3d o{10 * u(rng), 10 * u(rng), 5 + 5 * u(rng) + 1e-3};
        const Vec3d target{45 * u(rng), 45 * u(rng), 0};
        const Vec3d d{target[0] - o[0], target[1] - o[1], target[2] - o[2]};
        const auto h = caster.firstHit(o, d);
        ASSERT_TRUE(h.has_value()) << "ray " << r;  // watertight: never between two cells
        EXPECT_NEAR(h->t, 1.0, 1e-12);              // d reaches the plane at t = 1
        // The barycentrics put the hit on the target.
        const std::uint32_t* v = &quad.indices[3 * static_cast<std::size_t>(h->triangle)];
        const double b0 = 1 - h->b1 - h->b2;
        for (int k = 0; k < 2; ++k) {
            const double p =
                b0 * quad.positions[v[0]][k] + h->b1 * quad.positions[v[1]][k] + h->b2 * quad.positions[v[2]][k];
            EXPECT_NEAR(p, target[k], 1e-11);
        }
        EXPECT_GE(std::min({b0, h->b1, h->b2}), -1e-12);
    }
    // Behind the origin, beyond tMax, or parallel: nothing.
    EXPECT_FALSE(caster.firstHit({0, 0, 5}, {0, 0, 1}).has_value());
    EXPECT_FALSE(caster.firstHit({0, 0, 5}, {0, 0, -1}, 0, 4.9).has_value());
    EXPECT_FALSE(caster.firstHit({0, 0, 5}, {1, 0, 0}).has_value());
    EXPECT_FALSE(caster.firstHit({0, 0, 5}, {0, 0, 0}).has_value());
}

TEST(RayCaster, RaysThroughSharedEdgesAndVerticesNeverSlipThrough) {
    // Exactly through the quad's grid vertices and along its edges, where
    // non-watertight tests miss both triangles.
    const mesh::Mesh quad = mesh::makeQuad(8.0f, 8);  // vertices at whole millimetres
    const dataset::RayCaster caster(quad);
    for (int i = -3; i <= 3; ++i)
        for (int j = -3; j <= 3; ++j)
            for (const double dx : {0.0, 0.5}) {
                const Vec3d o{0.25, -0.5, 3};
                const Vec3d d{i + dx - o[0], j - o[1], -o[2]};
                EXPECT_TRUE(caster.firstHit(o, d).has_value()) << i + dx << "," << j;
            }
}

TEST(RayCaster, ASphereIsHitAtItsAnalyticDistance) {
    // From inside and from outside a finely tessellated sphere: the distance
    // lies between the inscribed and the circumscribed sphere's.
    const double R = 20;
    const int slices = 256, stacks = 128;
    const mesh::Mesh sphere = mesh::makeSphere(static_cast<float>(R), slices, stacks);
    const dataset::RayCaster caster(sphere);
    // The chord's sagitta bounds how far inside the facets lie.
    const double sagitta = R * (1 - std::cos(M_PI / stacks)) + R * (1 - std::cos(M_PI / slices)) + 1e-5;
    std::mt19937_64 rng(5);
    for (int r = 0; r < 2000; ++r) {
        const Vec3d d = randomUnit(rng);
        // Inside: from a point off the centre.
        const Vec3d o{3, -2, 1};
        const double od = o[0] * d[0] + o[1] * d[1] + o[2] * d[2], oo = o[0] * o[0] + o[1] * o[1] + o[2] * o[2];
        const auto h = caster.firstHit(o, d);
        ASSERT_TRUE(h.has_value());
        const double tIn = -od + std::sqrt(od * od - oo + R * R);
        EXPECT_LE(h->t, tIn + 1e-9);
        EXPECT_GE(h->t, -od + std::sqrt(od * od - oo + (R - sagitta) * (R - sagitta)) - 1e-9);
        // Outside: towards the centre from 50 mm along -d.
        const Vec3d far{-50 * d[0], -50 * d[1], -50 * d[2]};
        const auto g = caster.firstHit(far, d);
        ASSERT_TRUE(g.has_value());
        EXPECT_GE(g->t, 50 - R - 1e-9);
        EXPECT_LE(g->t, 50 - R + sagitta);
    }
}

TEST(RayCaster, TheTreeIsShallowAndQueriesAreFast) {
    mesh::PhantomParams p;
    p.generations = 1;
    p.resolution = 0.5;
    const mesh::Mesh m = mesh::makePhantom(p).mesh;
    const auto start = std::chrono::steady_clock::now();
    const dataset::RayCaster caster(m);
    const double build = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    EXPECT_LE(caster.nodeCount(), 2 * m.triangleCount());
    EXPECT_LE(caster.depth(), 64);
    std::printf("%zu triangles: %zu nodes, depth %d, built in %.1f ms\n", m.triangleCount(), caster.nodeCount(),
                caster.depth(), build * 1e3);
    // An empty mesh has no hits.
    const mesh::Mesh empty;
    EXPECT_FALSE(dataset::RayCaster(empty).firstHit({0, 0, 0}, {0, 0, 1}).has_value());
}

}  // namespace
}  // namespace mucosa
