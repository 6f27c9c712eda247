#include <algorithm>
#include <cmath>
#include <map>

#include <gtest/gtest.h>

#include <mucosa/core/error.hpp>
#include <mucosa/mesh/analysis.hpp>
#include <mucosa/mesh/centerline.hpp>
#include <mucosa/mesh/io.hpp>
#include <mucosa/mesh/phantom.hpp>

#include "gltf_validator.hpp"
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

// A vertex of the trachea in the trachea's own frame: s along its axis (mm
// from the top, as the rings are spaced), its distance from the centerline,
// and its angle from the anterior midline (degrees, 0 anterior, 180 posterior;
// positive towards the patient's left, +X).
struct TracheaSample {
    double s, radius, angleDeg;
    std::size_t vertex;
};

std::vector<TracheaSample> tracheaSamples(const mesh::Phantom& ph, double sLo, double sHi) {
    const auto& pts = ph.centerline.branches[0].points;
    const double L = 110.0;
    const std::size_t steps = pts.size() - 1;
    std::vector<TracheaSample> out;
    for (std::size_t v = 0; v < ph.mesh.vertexCount(); ++v) {
        const auto& P = ph.mesh.positions[v];
        if (P[1] > 5 || P[1] < -115) continue;
        double best = 1e30, bs = 0;
        std::array<double, 3> bestR{}, bestT{};
        for (std::size_t i = 0; i < steps; ++i) {
            std::array<double, 3> a{pts[i][0], pts[i][1], pts[i][2]}, ab{}, ap{};
            for (int k = 0; k < 3; ++k) ab[k] = pts[i + 1][k] - a[k], ap[k] = P[k] - a[k];
            const double abab = ab[0] * ab[0] + ab[1] * ab[1] + ab[2] * ab[2];
            const double t = std::clamp((ap[0] * ab[0] + ap[1] * ab[1] + ap[2] * ab[2]) / abab, 0.0, 1.0);
            std::array<double, 3> r{};
            for (int k = 0; k < 3; ++k) r[k] = ap[k] - t * ab[k];
            const double d = std::sqrt(r[0] * r[0] + r[1] * r[1] + r[2] * r[2]);
            if (d < best) best = d, bs = L * (double(i) + t) / double(steps), bestR = r, bestT = ab;
        }
        if (bs < sLo || bs > sHi || best > 12) continue;
        // Anterior (+Z) and left (+X) made orthogonal to the local axis.
        const double tl = std::sqrt(bestT[0] * bestT[0] + bestT[1] * bestT[1] + bestT[2] * bestT[2]);
        for (double& c : bestT) c /= tl;
        auto ortho = [&](std::array<double, 3> e) {
            const double d = e[0] * bestT[0] + e[1] * bestT[1] + e[2] * bestT[2];
            for (int k = 0; k < 3; ++k) e[k] -= d * bestT[k];
            return e;
        };
        const auto ant = ortho({0, 0, 1}), left = ortho({1, 0, 0});
        const double a = bestR[0] * ant[0] + bestR[1] * ant[1] + bestR[2] * ant[2];
        const double l = bestR[0] * left[0] + bestR[1] * left[1] + bestR[2] * left[2];
        out.push_back({bs, best, std::atan2(l, a) * 180.0 / M_PI, v});
    }
    return out;
}

// The ring list's ridge (mm into the lumen) where a trachea sample lies: the
// samples' angle is positive towards +X (the patient's left), the ring list's
// towards the trachea's e2 = -X.
double predictedRidgeMm(const mesh::TubeRings& rings, const TracheaSample& t) {
    return rings.heightMm * rings.ridge(t.s, -t.angleDeg * M_PI / 180.0);
}

// Least squares of the radius on the predicted ridge within 5-degree bins (the
// lumen's ellipse and the flatter posterior wall cancel): the slope (-1 when
// the surface carries the ridges exactly) and the residual's deviation (the
// sawtooth a grid-aligned error would add).
struct RidgeFit {
    double slope = 0, residual = 0, spread = 0;  // spread: deviation of the predicted ridge
};
RidgeFit fitRidges(const std::vector<TracheaSample>& samples, const mesh::TubeRings& rings, double lo, double hi) {
    std::map<int, std::vector<std::pair<double, double>>> bins;
    for (const auto& t : samples)
        if (t.angleDeg >= lo && t.angleDeg <= hi)
            bins[int(std::floor(t.angleDeg / 5))].push_back({predictedRidgeMm(rings, t), t.radius});
    double sxy = 0, sxx = 0;
    std::vector<std::pair<double, double>> centred;
    for (auto& [b, v] : bins) {
        double mx = 0, my = 0;
        for (auto [x, y] : v) mx += x, my += y;
        mx /= double(v.size()), my /= double(v.size());
        for (auto [x, y] : v)
            centred.push_back({x - mx, y - my}), sxy += (x - mx) * (y - my), sxx += (x - mx) * (x - mx);
    }
    RidgeFit f;
    f.slope = sxx > 0 ? sxy / sxx : 0;
    double ss = 0;
    for (auto [x, y] : centred) ss += (y - f.slope * x) * (y - f.slope * x);
    f.residual = std::sqrt(ss / double(std::max<std::size_t>(centred.size(), 1)));
    f.spread = std::sqrt(sxx / double(std::max<std::size_t>(centred.size(), 1)));
    return f;
}

// Cartilage rings are low ridges over the anterior and lateral wall where the
// ring list puts them (irregular: see RingsAreIrregular), absent on the
// posterior membranous wall, and smooth: the surface's radius follows the
// predicted ridges with slope -1, without a sawtooth, at the test's 2 cells/mm
// and at render's 1 cell/mm.
TEST(Phantom, RingsAreLowSmoothRidgesAbsentOnTheMembranousWall) {
    mesh::PhantomParams coarse;
    coarse.generations = 1;
    coarse.resolution = 1.0;
    const mesh::Phantom render = mesh::makePhantom(coarse);
    const std::vector<mesh::TubeRings> rings = mesh::phantomRings(mesh::PhantomParams{});
    ASSERT_FALSE(rings.empty());
    ASSERT_EQ(rings.front().branch, 0);
    for (const mesh::Phantom* ph : {&defaultPhantom(), &render}) {
        const auto samples = tracheaSamples(*ph, 15, 95);
        const RidgeFit front = fitRidges(samples, rings.front(), -60, 60);
        const RidgeFit sides = fitRidges(samples, rings.front(), 60, 110);
        double back = 0;
        for (const auto& t : samples)
            if (std::abs(t.angleDeg) > 160) back = std::max(back, predictedRidgeMm(rings.front(), t));
        std::printf(
            "rings (%zu samples): radius per mm of predicted ridge anterior %.2f, lateral %.2f (ridges' deviation "
            "%.3f mm); residual %.3f mm; largest ridge on the membranous wall %.3f mm\n",
            samples.size(), front.slope, sides.slope, front.spread, front.residual, back);
        EXPECT_GT(front.spread, 0.08) << "the ridges are there";
        EXPECT_NEAR(front.slope, -1.0, 0.2);
        EXPECT_NEAR(sides.slope, -1.0, 0.3);
        EXPECT_LT(front.residual, 0.05) << "no sawtooth along the ridges";
        EXPECT_LT(back, 0.02) << "no rings on the membranous wall";
    }
}

// No two rings alike: spacing 5 mm on average on the trachea, varying ring to
// ring; heights from barely raised to 1.3 x; tilted planes; each C's gap its
// own; every ring low (under 0.5 mm on the 18 mm trachea).
TEST(Phantom, RingsAreIrregular) {
    const std::vector<mesh::TubeRings> all = mesh::phantomRings(mesh::PhantomParams{});
    ASSERT_EQ(all.size(), 3u) << "trachea and main bronchi";
    const mesh::TubeRings& t = all.front();
    ASSERT_GE(t.rings.size(), 18u);
    std::vector<double> gaps;
    double hmin = 1e9, hmax = 0, tiltMax = 0, gapLo = 1, gapHi = -1;
    for (std::size_t i = 0; i < t.rings.size(); ++i) {
        const mesh::CartilageRing& r = t.rings[i];
        if (i > 0) gaps.push_back(r.s - t.rings[i - 1].s);
        hmin = std::min(hmin, r.height), hmax = std::max(hmax, r.height);
        tiltMax = std::max(tiltMax, std::abs(r.tilt));
        gapLo = std::min(gapLo, r.gap), gapHi = std::max(gapHi, r.gap);
        EXPECT_LT(r.height * t.heightMm, 0.5);
    }
    double mean = 0, var = 0;
    for (double g : gaps) mean += g / double(gaps.size());
    for (double g : gaps) var += (g - mean) * (g - mean) / double(gaps.size());
    const double cv = std::sqrt(var) / mean;
    std::printf(
        "trachea: %zu rings, spacing %.2f mm (CV %.2f), heights %.2f-%.2f, tilt up to %.2f mm, gap %.2f..%.2f\n",
        t.rings.size(), mean, cv, hmin, hmax, tiltMax, gapLo, gapHi);
    EXPECT_NEAR(mean, 5.0, 0.5);
    EXPECT_GT(cv, 0.1);
    EXPECT_LT(cv, 0.3);
    EXPECT_LT(hmin, 0.6);
    EXPECT_GT(hmax, 1.1);
    EXPECT_GT(tiltMax, 0.5);
    EXPECT_GT(gapHi - gapLo, 0.1);
    // Seeded: the same seed, the same rings; another, others.
    mesh::PhantomParams other;
    other.seed = 2;
    EXPECT_EQ(mesh::phantomRings(mesh::PhantomParams{}).front().rings.front().s, t.rings.front().s);
    EXPECT_NE(mesh::phantomRings(other).front().rings.front().s, t.rings.front().s);
}

TEST(Phantom, HasTheDocumentedDimensions) {
    const auto& ph = defaultPhantom();
    const auto r = mesh::analyze(ph.mesh);
    // The trachea's top cap reaches its radius above the origin.
    EXPECT_NEAR(r.boundsMax[1], 9.0, 0.6);
    // Trachea cross-section halfway down: about 18 mm across (rings make it
    // up to 4 % narrower, the ellipse 5 % shallower front to back, the
    // flatter posterior wall 7 %). Measured about the centerline (points
    // every 1 mm of y): the trachea curves (backwards and to the right), so
    // not about the Y axis; over one ring period (5 mm), crest and furrow.
    const auto& trachea = ph.centerline.branches[0].points;
    ASSERT_NEAR(trachea[55][1], -55.0f, 0.01f);
    double maxR = 0, minR = 1e9;
    for (const auto& p : ph.mesh.positions)
        if (std::abs(p[1] + 55) < 2.5) {
            const auto& mid = trachea[static_cast<std::size_t>(std::lround(-p[1]))];
            const double rr = std::hypot(p[0] - mid[0], p[2] - mid[2]);
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

// The posterior membranous wall carries fine longitudinal folds: across the
// wall the radius ripples (about every 3.5 mm, ~0.2 mm deep) where the
// anterior wall, between the same rings, is smooth.
TEST(Phantom, MembranousWallHasLongitudinalFolds) {
    const auto samples = tracheaSamples(defaultPhantom(), 20, 90);
    // Radius against arc length around the wall in 0.5 mm bins, detrended by a
    // 4 mm running mean: the ripple's RMS.
    auto ripple = [&](double centreDeg) {
        std::map<int, std::pair<double, int>> bins;
        for (const auto& t : samples) {
            double a = t.angleDeg - centreDeg;
            a = a - 360 * std::round(a / 360);
            if (std::abs(a) > 45) continue;
            auto& b = bins[int(std::floor(a * M_PI / 180 * 8.5 / 0.5))];
            b.first += t.radius, ++b.second;
        }
        std::vector<double> r;
        for (const auto& [k, v] : bins) r.push_back(v.first / v.second);
        double ss = 0;
        int n = 0;
        for (std::size_t i = 4; i + 4 < r.size(); ++i) {
            double m = 0;
            for (std::size_t j = i - 4; j <= i + 4; ++j) m += r[j];
            m /= 9;
            ss += (r[i] - m) * (r[i] - m), ++n;
        }
        return std::sqrt(ss / std::max(n, 1));
    };
    const double back = ripple(180), front = ripple(0);
    std::printf("membranous wall: fold ripple %.3f mm RMS (anterior wall %.3f mm)\n", back, front);
    EXPECT_GT(back, 0.04);
    EXPECT_LT(front, 0.5 * back);
}

// The tint: whiter (more green and blue for the red) on the ring crests than
// in the furrows, redder on the membranous wall, 1 or below everywhere.
TEST(Phantom, TintIsPaleOnCartilageAndRedderOnTheMembranousWall) {
    const auto& ph = defaultPhantom();
    ASSERT_TRUE(ph.mesh.hasColors());
    for (const Vec3& c : ph.mesh.colors)
        for (float x : c) ASSERT_TRUE(x > 0.5f && x <= 1.0f) << x;
    const auto samples = tracheaSamples(ph, 15, 95);
    const std::vector<mesh::TubeRings> rings = mesh::phantomRings(mesh::PhantomParams{});
    double crest = 0, furrow = 0, membrane = 0;
    int nc = 0, nf = 0, nm = 0;
    for (const auto& t : samples) {
        const Vec3& c = ph.mesh.colors[t.vertex];
        const double gr = c[1] / c[0];
        const double ridge = rings.front().ridge(t.s, -t.angleDeg * M_PI / 180.0);
        if (std::abs(t.angleDeg) < 60 && ridge > 0.8) crest += gr, ++nc;
        if (std::abs(t.angleDeg) < 60 && ridge < 0.05) furrow += gr, ++nf;
        if (std::abs(t.angleDeg) > 165) membrane += gr, ++nm;
    }
    ASSERT_TRUE(nc > 0 && nf > 0 && nm > 0);
    crest /= nc, furrow /= nf, membrane /= nm;
    std::printf("tint green/red: crests %.3f, furrows %.3f, membranous wall %.3f\n", crest, furrow, membrane);
    EXPECT_GT(crest, furrow + 0.05);
    EXPECT_LT(membrane, furrow - 0.02);
}

// The tree is not planar and the trachea is not a straight pipe: the trachea's
// centerline bows off its chord, the main bronchi leave the coronal plane.
TEST(Phantom, TracheaCurvesAndBranchesAreNotCoplanar) {
    const auto& c = defaultPhantom().centerline;
    const auto& t = c.branches[0].points;
    double bow = 0;
    for (const auto& p : t) {
        const double f = (p[1] - t.front()[1]) / (t.back()[1] - t.front()[1]);
        const double dx = p[0] - (t.front()[0] + f * (t.back()[0] - t.front()[0]));
        const double dz = p[2] - (t.front()[2] + f * (t.back()[2] - t.front()[2]));
        bow = std::max(bow, std::hypot(dx, dz));
    }
    EXPECT_GT(bow, 1.0);
    EXPECT_LT(bow, 4.0);
    for (int b : {1, 2}) {
        const auto& pts = c.branches[std::size_t(b)].points;
        const double dz = pts.back()[2] - pts.front()[2];
        const double len = std::hypot(pts.back()[0] - pts.front()[0], pts.back()[1] - pts.front()[1], dz);
        EXPECT_LT(dz / len, -0.05) << "main bronchus " << b << " runs slightly backwards";
    }
}

// The main carina is a defined crest: around its top (the highest vertex on
// both main bronchi's walls, midway front to back), the wall turns through a wide angle within 2 mm
// (the normals on its two flanks diverge).
TEST(Phantom, MainCarinaHasADefinedCrest) {
    const auto& ph = defaultPhantom();
    const auto& c = ph.centerline;
    auto distanceTo = [](const mesh::CenterlineBranch& b, const Vec3& p) {
        double best = 1e30;
        for (std::size_t i = 0; i + 1 < b.points.size(); ++i) {
            double ab[3], ap[3];
            for (int k = 0; k < 3; ++k) ab[k] = b.points[i + 1][k] - b.points[i][k], ap[k] = p[k] - b.points[i][k];
            const double t = std::clamp(
                (ap[0] * ab[0] + ap[1] * ab[1] + ap[2] * ab[2]) / (ab[0] * ab[0] + ab[1] * ab[1] + ab[2] * ab[2]), 0.0,
                1.0);
            best = std::min(best, std::hypot(ap[0] - t * ab[0], ap[1] - t * ab[1], ap[2] - t * ab[2]));
        }
        return best;
    };
    std::size_t top = 0;
    float topY = -1e9f;
    for (std::size_t v = 0; v < ph.mesh.vertexCount(); ++v) {
        const auto& p = ph.mesh.positions[v];
        const auto& end = c.branches[0].points.back();
        if (p[1] > end[1] || p[1] < topY || std::abs(p[2] - end[2]) > 2.0f) continue;  // mid-septum
        if (std::abs(distanceTo(c.branches[1], p) - c.branches[1].radii[0]) < 0.8 &&
            std::abs(distanceTo(c.branches[2], p) - c.branches[2].radii[0]) < 0.8)
            topY = p[1], top = v;
    }
    ASSERT_GT(topY, -1e8f);
    // The spread of the normals' component across the crest (the direction
    // between the two bronchi's axes, about X).
    float lo = 1, hi = -1;
    const auto& q = ph.mesh.positions[top];
    for (std::size_t v = 0; v < ph.mesh.vertexCount(); ++v) {
        const auto& p = ph.mesh.positions[v];
        if (std::hypot(p[0] - q[0], p[1] - q[1], p[2] - q[2]) > 2.0f) continue;
        lo = std::min(lo, ph.mesh.normals[v][0]), hi = std::max(hi, ph.mesh.normals[v][0]);
    }
    std::printf(
        "main carina: crest at (%.1f, %.1f, %.1f) mm (trachea ends at y %.1f), normals' x within 2 mm: "
        "%.2f .. %.2f\n",
        q[0], q[1], q[2], c.branches[0].points.back()[1], lo, hi);
    EXPECT_GT(hi - lo, 1.2f);
}

TEST(Phantom, CenterlineUvsStayNearSquare) {
    const auto s = mesh::measureUvStretch(defaultPhantom().mesh);
    std::printf("phantom uv stretch: area ratio p5 %.2f p50 %.2f p95 %.2f; anisotropy p50 %.3f p95 %.2f; flipped %zu\n",
                s.areaP05, s.areaP50, s.areaP95, s.anisotropyP50, s.anisotropyP95, s.flippedTriangles);
    EXPECT_LT(s.anisotropyP50, 1.2);
    EXPECT_LT(s.anisotropyP95, 4.0);
    EXPECT_EQ(s.zeroUvAreaTriangles, 0u);
    // Folded over: 1 (a sliver facing against its own vertex normals); 9 432
    // before the interpolated axis frames and the (branch, sense) charts.
    EXPECT_LT(double(s.flippedTriangles), 0.001 * double(defaultPhantom().mesh.triangleCount()));
    // Triangles spanning more than a quarter turn of u: only at the poles of
    // the closed caps (99 of 567 936 at the defaults), never at the seam.
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
    EXPECT_LT(double(mirrored), 0.001 * double(m.vertexCount())) << "UVs follow the winding: frames are right-handed";
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

// Fills a stretch of the stack below the caller with one byte, so what an
// uninitialised local would read there differs from call to call.
[[gnu::noinline]] void scribbleStack(unsigned char byte) {
    volatile unsigned char junk[1 << 16];
    for (std::size_t i = 0; i < sizeof(junk); ++i) junk[i] = byte;
}

[[gnu::noinline]] mesh::Centerline treeAfterScribbling(unsigned char byte, const mesh::PhantomParams& p) {
    scribbleStack(byte);
    return mesh::phantomCenterline(p);
}

// The tree is a function of its parameters only: the branching-plane choice
// once read a tube's start before it was set (an uninitialised std::array),
// which made `mucosa render`'s resumed frames differ under the sanitizers.
TEST(Phantom, TheTreeDoesNotDependOnWhatTheStackHeld) {
    mesh::PhantomParams p;
    p.generations = 5;
    const mesh::Centerline zeros = treeAfterScribbling(0x00, p);
    for (const int byte : {0xff, 0x7f, 0x41, 0xc3}) {
        const mesh::Centerline other = treeAfterScribbling(static_cast<unsigned char>(byte), p);
        ASSERT_EQ(other.branches.size(), zeros.branches.size());
        for (std::size_t i = 0; i < zeros.branches.size(); ++i)
            EXPECT_EQ(other.branches[i].points, zeros.branches[i].points) << "byte " << byte << " branch " << i;
    }
    // The daughters leave the midline: the lobar and segmental bronchi end
    // on their main bronchus's side (x < 0 right, x > 0 left).
    for (std::size_t i = 3; i < zeros.branches.size(); ++i) {
        if (zeros.branches[i].generation > 3) continue;
        std::size_t main = i;
        while (zeros.branches[main].parent > 0) main = static_cast<std::size_t>(zeros.branches[main].parent);
        const float side = zeros.branches[main].points.back()[0];
        EXPECT_GT(zeros.branches[i].points.back()[0] * side, 0.0f) << zeros.branches[i].name;
    }
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
    expectValidGltf(dir / "a.glb");
    // .gltf, and the plain material: valid too (the plain one's UVs, which no
    // material reads, are the one info a user asks for: --material plain).
    const auto gltf = runCli("-q phantom -o '" + (dir / "g.gltf").string() + "' --generations 1 --resolution 1");
    ASSERT_EQ(gltf.exitCode, 0) << gltf.err;
    expectValidGltf(dir / "g.gltf");
    const auto plain =
        runCli("-q phantom -o '" + (dir / "p.glb").string() + "' --generations 1 --resolution 1 --material plain");
    ASSERT_EQ(plain.exitCode, 0) << plain.err;
    const nlohmann::json report = validateGltf(dir / "p.glb");
    EXPECT_EQ(report["errors"], 0);
    EXPECT_EQ(report["warnings"], 0);
    EXPECT_EQ(report["infos"], 1) << report.dump();

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
