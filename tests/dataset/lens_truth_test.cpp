// Ground truth through a lens (dataset::groundTruth with a Lens): exact per
// pixel-centre ray, on analytic scenes (a plane, a sphere from inside and
// from outside, a cylinder), for every lens model.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <functional>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include <mucosa/dataset/ground_truth.hpp>
#include <mucosa/dataset/lens.hpp>
#include <mucosa/dataset/raycast.hpp>
#include <mucosa/frames/frames.hpp>
#include <mucosa/mesh/phantom.hpp>
#include <mucosa/mesh/primitives.hpp>

namespace mucosa {
namespace {

using frames::Vec3d;

// A camera at (0, 0, 10) looking down -z at the z = 0 plane, up +y: OpenCV
// camera x = world x, y = -world y, z = -world z.
frames::Mat4 lookingDown() {
    return frames::lookAtPose({0, 0, 10}, {0, 0, 0}, {0, 1, 0});
}

dataset::Lens omnidirectional() {
    nlohmann::json j = {{"model", "omnidirectional"}, {"width", 120}, {"height", 90},
                        {"pol", {-50.0, 0.0, 0.004}}, {"xc", 44.5},   {"yc", 59.5}};
    return dataset::lensFromJson(j);
}

struct NamedLens {
    std::string name;
    dataset::Lens lens;
};

std::vector<NamedLens> lenses() {
    dataset::Lens kb = dataset::equidistantFisheye(120, 90, 150.0);
    kb.k1 = -0.02, kb.k2 = 0.004, kb.k3 = -0.0005, kb.k4 = 0.0001;
    dataset::validateLens(kb);
    const frames::Intrinsics K = dataset::intrinsicsOf(camera::Lens{}, 120, 90);
    dataset::Lens brown = dataset::fromIntrinsics(K);
    brown.k1 = -0.1, brown.k2 = 0.01;
    dataset::validateLens(brown);
    return {{"pinhole", dataset::fromIntrinsics(K)},
            {"equidistant fisheye", dataset::equidistantFisheye(120, 90, 160.0)},
            {"Kannala-Brandt fisheye", kb},
            {"Brown pinhole", brown},
            {"omnidirectional", omnidirectional()},
            // Wider than 180 degrees: the rays beyond 90 degrees have no planar depth.
            {"220-degree fisheye", dataset::equidistantFisheye(120, 90, 220.0)}};
}

// A straight open cylinder of radius r around the z axis from z0 to z1,
// normals inward (towards the axis).
mesh::Mesh makeCylinder(float r, float z0, float z1, int around, int along) {
    mesh::Mesh m;
    for (int j = 0; j <= along; ++j)
        for (int i = 0; i < around; ++i) {
            const double a = 2 * M_PI * i / around;
            const float z = z0 + (z1 - z0) * static_cast<float>(j) / static_cast<float>(along);
            m.positions.push_back({static_cast<float>(r * std::cos(a)), static_cast<float>(r * std::sin(a)), z});
            m.normals.push_back({static_cast<float>(-std::cos(a)), static_cast<float>(-std::sin(a)), 0.f});
        }
    for (int j = 0; j < along; ++j)
        for (int i = 0; i < around; ++i) {
            const auto v = [&](int jj, int ii) { return static_cast<std::uint32_t>(jj * around + (ii % around)); };
            m.indices.insert(m.indices.end(),
                             {v(j, i), v(j + 1, i), v(j + 1, i + 1), v(j, i), v(j + 1, i + 1), v(j, i + 1)});
        }
    return m;
}

struct Scene {
    std::string name;
    mesh::Mesh mesh;
    frames::Mat4 c2w;
    // The analytic surface's normal (either orientation) at a world point.
    std::function<Vec3d(const Vec3d&)> normalAt;
    bool closed;  // every ray in front of the camera meets it
};

std::vector<Scene> scenes() {
    auto radial = [](const Vec3d& p) { return p; };
    return {
        {"plane", mesh::makeQuad(400.0f, 8), lookingDown(),
         [](const Vec3d&) {
             return Vec3d{0, 0, 1};
         },
         false},
        {"sphere from inside", mesh::makeSphere(30.0f, 96, 48), frames::lookAtPose({3, -2, 5}, {10, 4, -20}, {0, 1, 0}),
         radial, true},
        {"sphere from outside", mesh::makeSphere(10.0f, 128, 64), frames::lookAtPose({0, 4, 22}, {0, 0, 0}, {0, 1, 0}),
         radial, false},
        {"cylinder from inside", makeCylinder(8.0f, -200.0f, 20.0f, 64, 110),
         frames::lookAtPose({1, -0.5, 0}, {2, 1, -50}, {0, 1, 0}),
         [](const Vec3d& p) {
             return Vec3d{p[0], p[1], 0};
         },
         false},
    };
}

double dot(const Vec3d& a, const Vec3d& b) {
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

Vec3d cross(const Vec3d& a, const Vec3d& b) {
    return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}

// The angle between two directions, well conditioned where it is small
// (unlike acos of the dot product).
double angleDeg(const Vec3d& a, const Vec3d& b) {
    const Vec3d c = cross(a, b);
    return std::atan2(std::sqrt(dot(c, c)), dot(a, b)) * 180 / M_PI;
}

Vec3d vertex(const mesh::Mesh& m, std::int32_t tri, int k) {
    const auto& p = m.positions[m.indices[3 * static_cast<std::size_t>(tri) + static_cast<std::size_t>(k)]];
    return {p[0], p[1], p[2]};
}

// The analytic check of every pixel of `t` (see the test below).
void expectExact(const Scene& scene, const NamedLens& named, const dataset::GroundTruth& t) {
    const dataset::Lens& lens = named.lens;
    const mesh::Mesh& m = scene.mesh;
    const frames::Mat4& c2w = scene.c2w;
    const frames::Mat4 w2c = frames::invertRigid(c2w);
    const Vec3d eye = frames::cameraCentre(c2w);
    const double nearMm = 0.5;
    int seen = 0, checked = 0, wide = 0;
    double worstDepth = 0, worstPixel = 0, worstNormal = 0, worstBary = 0;
    for (int y = 0; y < lens.height; ++y)
        for (int x = 0; x < lens.width; ++x) {
            const std::size_t i = static_cast<std::size_t>(y) * lens.width + x;
            const auto ray = dataset::unproject(lens, x, y);
            ASSERT_EQ(t.inView[i] != 0, ray.has_value()) << x << "," << y;
            if (!ray) {
                ASSERT_FALSE(t.valid[i]);
                continue;
            }
            const Vec3d& d = *ray;
            if (!(d[2] > 0)) {  // no planar depth beyond 90 degrees
                ++wide;
                ASSERT_FALSE(t.valid[i]) << x << "," << y;
                EXPECT_EQ(t.face[i], -1);
                continue;
            }
            const Vec3d dir = frames::transformDirection(c2w, d);
            const double tMin = nearMm / std::max({std::fabs(d[0]), std::fabs(d[1]), d[2]});
            // The first hit by brute force over every triangle, on a sample of pixels.
            if ((x + 3 * y) % 23 == 0) {
                ++checked;
                std::optional<dataset::Hit> best;
                for (std::size_t k = 0; k < m.triangleCount(); ++k)
                    if (auto h = dataset::intersectTriangle(m, static_cast<std::int32_t>(k), eye, dir, tMin))
                        if (!best || h->t < best->t) best = h;
                ASSERT_EQ(best.has_value(), t.valid[i] != 0) << x << "," << y;
                if (best) {
                    EXPECT_EQ(best->triangle, t.face[i]) << x << "," << y;
                }
            }
            if (scene.closed) {
                ASSERT_TRUE(t.valid[i]) << x << "," << y;
            }
            if (!t.valid[i]) continue;
            ++seen;
            // The ray meets the named triangle's plane (Cramer, double) at
            // distance s and barycentrics (c1, c2), inside the triangle.
            const std::int32_t tri = t.face[i];
            const Vec3d p0 = vertex(m, tri, 0), p1 = vertex(m, tri, 1), p2 = vertex(m, tri, 2);
            const Vec3d e1{p1[0] - p0[0], p1[1] - p0[1], p1[2] - p0[2]};
            const Vec3d e2{p2[0] - p0[0], p2[1] - p0[1], p2[2] - p0[2]};
            const Vec3d so{eye[0] - p0[0], eye[1] - p0[1], eye[2] - p0[2]};
            const Vec3d pv = cross(dir, e2), qv = cross(so, e1);
            const double det = dot(e1, pv);
            const double c1 = dot(so, pv) / det, c2 = dot(dir, qv) / det, s = dot(e2, qv) / det;
            worstBary =
                std::max({worstBary, -std::min({c1, c2, 1 - c1 - c2}), std::abs(c1 - t.b1[i]), std::abs(c2 - t.b2[i])});
            // Planar depth: the hit's z in the camera frame.
            const double z = s * d[2];
            worstDepth = std::max(worstDepth, std::abs(t.depth.at(x, y) - z) / z);
            // That point projects back onto the pixel.
            const Vec3d P{eye[0] + s * dir[0], eye[1] + s * dir[1], eye[2] + s * dir[2]};
            const auto px = dataset::project(lens, frames::transformPoint(w2c, P));
            ASSERT_TRUE(px.has_value());
            worstPixel = std::max(worstPixel, std::hypot(px->u - x, px->v - y));
            // The normal is the analytic surface's (the meshes' vertex normals
            // interpolate it exactly: radial on the sphere and the cylinder),
            // in camera axes, facing the camera.
            Vec3d n = frames::transformDirection(w2c, scene.normalAt(P));
            if (dot(n, d) > 0) n = {-n[0], -n[1], -n[2]};
            const Vec3d got{t.normals.at(x, y, 0), t.normals.at(x, y, 1), t.normals.at(x, y, 2)};
            worstNormal = std::max(worstNormal, angleDeg(n, got));
        }
    std::printf(
        "%-22s %-21s %5d pixels seen (%d by brute force), %d beyond 90 deg: depth %.1e relative, "
        "reprojection %.1e px, normal %.1e deg, barycentrics %.1e\n",
        scene.name.c_str(), named.name.c_str(), seen, checked, wide, worstDepth, worstPixel, worstNormal, worstBary);
    EXPECT_GT(seen, 200) << scene.name << ", " << named.name;
    EXPECT_LE(worstDepth, 1e-6) << scene.name << ", " << named.name;
    EXPECT_LE(worstPixel, 1e-6) << scene.name << ", " << named.name;
    EXPECT_LE(worstNormal, 0.01) << scene.name << ", " << named.name;
    EXPECT_LE(worstBary, 1e-6) << scene.name << ", " << named.name;
    if (named.name == "220-degree fisheye") {
        EXPECT_GT(wide, 0);
    }
}

TEST(LensTruth, AnalyticScenesThroughEveryLensAreExactAtEveryPixel) {
    // Per pixel: inView where the lens has a ray; no depth beyond 90 degrees;
    // the first triangle the ray meets (brute force on a sample); planar depth
    // the ray's intersection with that triangle's plane to 1e-6 relative, the
    // point projecting back onto the pixel to 1e-6 px, the normal the analytic
    // surface's to 0.01 degrees.
    for (const Scene& scene : scenes()) {
        const dataset::RayCaster caster(scene.mesh);
        for (const NamedLens& named : lenses())
            expectExact(scene, named, dataset::groundTruth(caster, named.lens, scene.c2w, 0.5));
    }
}

TEST(LensTruth, APlaneThroughEveryLensIsExactAtEveryPixel) {
    const mesh::Mesh plane = mesh::makeQuad(400.0f, 8);
    for (const NamedLens& named : lenses()) {
        const dataset::Lens& lens = named.lens;
        const dataset::GroundTruth t = dataset::groundTruth(plane, lens, lookingDown(), 0.5);
        for (int y = 0; y < lens.height; ++y)
            for (int x = 0; x < lens.width; ++x) {
                const std::size_t i = static_cast<std::size_t>(y) * lens.width + x;
                const auto ray = dataset::unproject(lens, x, y);
                // The plane is seen by every ray in front of the camera whose hit is on the 400 mm quad.
                const bool hits = ray && (*ray)[2] > 0 && std::abs((*ray)[0] / (*ray)[2] * 10) < 199 &&
                                  std::abs((*ray)[1] / (*ray)[2] * 10) < 199;
                if (!hits) continue;
                ASSERT_TRUE(t.valid[i]) << named.name << " " << x << "," << y;
                // Planar depth: the plane is at z = 10 in the camera's frame.
                EXPECT_NEAR(t.depth.at(x, y), 10.0, 1e-5);
                // The texture coordinates say where on the plane: u = x / 400 + 0.5.
                const double s = t.depth.at(x, y) / (*ray)[2];
                EXPECT_NEAR(t.uv.at(x, y, 0), (*ray)[0] * s / 400.0 + 0.5, 1e-5);
            }
    }
}

// Near clipping where the renderer clips: a camera 0.6 mm above the z = 0
// plane, looking along it. Through the one wide face (NearClip::Planar) no
// hit is nearer than the near plane (planar depth >= 0.5 mm); a cube's side
// face clips along its own axis, so rays steeply down see the plane nearer
// than that, and the two agree within 45 degrees of the axis.
TEST(LensTruth, NearClippingIsTheOneFacesPlaneOrEachCubeFacesAxis) {
    const mesh::Mesh plane = mesh::makeQuad(400.0f, 8);
    const dataset::Lens lens = dataset::equidistantFisheye(120, 120, 120.0, dataset::FieldOfViewSpan::Horizontal);
    const frames::Mat4 c2w = frames::lookAtPose({0, 0, 0.6}, {0, 100, 0.6}, {0, 0, 1});
    const dataset::GroundTruth planar = dataset::groundTruth(plane, lens, c2w, 0.5, 1, dataset::NearClip::Planar);
    const dataset::GroundTruth cube = dataset::groundTruth(plane, lens, c2w, 0.5, 1, dataset::NearClip::CubeFaces);
    int nearer = 0, agree = 0, within45 = 0;
    for (int y = 0; y < lens.height; ++y)
        for (int x = 0; x < lens.width; ++x) {
            const std::size_t i = static_cast<std::size_t>(y) * lens.width + x;
            if (planar.valid[i]) EXPECT_GE(planar.depth.at(x, y), 0.5f) << x << "," << y;
            if (cube.valid[i] && cube.depth.at(x, y) < 0.5f) ++nearer;
            const auto ray = dataset::unproject(lens, x, y);
            if (ray && (*ray)[2] >= std::max(std::abs((*ray)[0]), std::abs((*ray)[1]))) {
                ++within45;
                agree += planar.valid[i] == cube.valid[i];
            }
        }
    EXPECT_GT(nearer, 50);
    EXPECT_EQ(agree, within45);
}

TEST(LensTruth, ThePinholeThroughTheRayCasterIsTheRasterisedPinhole) {
    const mesh::Mesh sphere = mesh::makeSphere(30.0f, 96, 48);  // seen from inside
    const frames::Mat4 c2w = frames::lookAtPose({3, -2, 5}, {10, 4, -20}, {0, 1, 0});
    const frames::Intrinsics K = dataset::intrinsicsOf(camera::Lens{}, 160, 120);
    const dataset::GroundTruth raster = dataset::groundTruth(sphere, K, c2w, 0.5);
    const dataset::GroundTruth cast = dataset::groundTruth(sphere, dataset::fromIntrinsics(K), c2w, 0.5);
    std::size_t same = 0, valid = 0;
    double worst = 0, worstNormal = 0;
    for (std::size_t i = 0; i < raster.face.size(); ++i) {
        EXPECT_EQ(raster.valid[i], cast.valid[i]) << i % 160 << "," << i / 160;
        EXPECT_EQ(raster.inView[i], cast.inView[i]);
        if (!raster.valid[i]) continue;
        ++valid;
        if (raster.face[i] != cast.face[i]) continue;  // a pixel centre on an edge
        ++same;
        worst =
            std::max(worst, std::abs(double(raster.depth.data()[i]) - cast.depth.data()[i]) / raster.depth.data()[i]);
        const float* a = &raster.normals.data()[3 * i];
        const float* b = &cast.normals.data()[3 * i];
        worstNormal = std::max(worstNormal, angleDeg({a[0], a[1], a[2]}, {b[0], b[1], b[2]}));
    }
    std::printf(
        "pinhole through the ray caster: %zu of %zu pixels on the same triangle, depth within %.2g, "
        "normals within %.2g deg\n",
        same, valid, worst, worstNormal);
    EXPECT_GE(same, 0.995 * static_cast<double>(valid));
    EXPECT_LE(worst, 1e-5);
    EXPECT_LE(worstNormal, 0.01);
}

TEST(LensTruth, ThePinholeFlowThroughTheLensIsThePinholeFlow) {
    const mesh::Mesh sphere = mesh::makeSphere(30.0f, 96, 48);
    const frames::Intrinsics K = dataset::intrinsicsOf(camera::Lens{}, 160, 120);
    const frames::Mat4 a = frames::lookAtPose({0, 0, 0}, {0, 0, -20}, {0, 1, 0});
    const frames::Mat4 b = frames::lookAtPose({1, 0.5, -2}, {3, 0, -20}, {0, 1, 0});
    const dataset::GroundTruth prev = dataset::groundTruth(sphere, K, a, 0.5);
    dataset::GroundTruth pinhole = dataset::groundTruth(sphere, K, b, 0.5);
    dataset::GroundTruth lens = pinhole;
    dataset::flowToPrevious(pinhole, K, b, &prev, a, 0.5);
    dataset::flowToPrevious(lens, dataset::fromIntrinsics(K), b, &prev, a, 0.5);
    double worst = 0;
    int visible = 0;
    for (int y = 0; y < K.height; ++y)
        for (int x = 0; x < K.width; ++x) {
            for (int k = 0; k < 2; ++k)
                worst = std::max(worst, std::abs(double(pinhole.flow.at(x, y, k)) - lens.flow.at(x, y, k)));
            EXPECT_EQ(pinhole.flow.at(x, y, 2), lens.flow.at(x, y, 2)) << x << "," << y;
            visible += lens.flow.at(x, y, 2) > 0;
        }
    EXPECT_LE(worst, 1e-6);
    EXPECT_GT(visible, K.width * K.height / 2);
}

TEST(LensTruth, FlowThroughEveryLensIsEachPointsReprojection) {
    const mesh::Mesh sphere = mesh::makeSphere(30.0f, 96, 48);
    const frames::Mat4 a = frames::lookAtPose({0, 0, 0}, {0, 0, -20}, {0, 1, 0});
    const frames::Mat4 b = frames::lookAtPose({1, 0.5, -2}, {3, 0, -20}, {0, 1, 0});
    const dataset::RayCaster caster(sphere);
    const frames::Mat4 w2a = frames::invertRigid(a);
    for (const NamedLens& named : lenses()) {
        const dataset::Lens& lens = named.lens;
        const dataset::GroundTruth prev = dataset::groundTruth(caster, lens, a, 0.5);
        dataset::GroundTruth now = dataset::groundTruth(caster, lens, b, 0.5);
        dataset::flowToPrevious(now, lens, b, &prev, a, 0.5);
        int visible = 0;
        double worst = 0;
        for (int y = 0; y < lens.height; ++y)
            for (int x = 0; x < lens.width; ++x) {
                const std::size_t i = static_cast<std::size_t>(y) * lens.width + x;
                if (!now.valid[i]) continue;
                // The pixel's point in the world, then in the previous camera, projected by the lens.
                const auto ray = dataset::unproject(lens, x, y);
                const double s = now.depth.at(x, y) / (*ray)[2];
                const Vec3d pw = frames::transformPoint(b, {(*ray)[0] * s, (*ray)[1] * s, (*ray)[2] * s});
                const Vec3d pa = frames::transformPoint(w2a, pw);
                const auto p = pa[2] > 0.5 ? dataset::project(lens, pa) : std::nullopt;
                if (!p) continue;
                // Visible where the previous frame saw the same point there.
                if (now.flow.at(x, y, 2) == 0) continue;
                ++visible;
                worst = std::max(
                    {worst, std::abs(now.flow.at(x, y, 0) - (p->u - x)), std::abs(now.flow.at(x, y, 1) - (p->v - y))});
            }
        std::printf("%s: %d pixels visible in the previous frame, flow within %.1e px\n", named.name.c_str(), visible,
                    worst);
        EXPECT_GT(visible, lens.width * lens.height / 3) << named.name;
        EXPECT_LE(worst, 1e-4) << named.name;  // float flow of up to tens of pixels
    }
}

template <class T>
bool sameBytes(const std::vector<T>& a, const std::vector<T>& b) {
    return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(T)) == 0;
}

bool sameBytes(const image::ImageF& a, const image::ImageF& b) {
    const std::size_t n = static_cast<std::size_t>(a.width()) * a.height() * a.channels();
    return a.width() == b.width() && a.height() == b.height() && a.channels() == b.channels() &&
           std::memcmp(a.data(), b.data(), n * sizeof(float)) == 0;
}

TEST(LensTruth, ThePhantomThroughAFisheyeIsTheSameBytesForAnyThreadCount) {
    // The phantom at 1 cell per millimetre, 640 x 480 through a Kannala-Brandt
    // fisheye from inside the trachea looking at the carina.
    mesh::PhantomParams params;
    params.resolution = 1;
    const mesh::Mesh m = mesh::makePhantom(params).mesh;
    auto start = std::chrono::steady_clock::now();
    const dataset::RayCaster caster(m);
    const double build = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    dataset::Lens lens = dataset::equidistantFisheye(640, 480, 160.0);
    lens.k1 = -0.02, lens.k2 = 0.003;
    dataset::validateLens(lens);
    const frames::Mat4 c2w = frames::lookAtPose({1, -60, 1}, {0, -110, 0}, {0, 0, 1});
    double seconds[2] = {0, 0};
    dataset::GroundTruth t[2];
    for (int threads = 1; threads <= 2; ++threads) {
        start = std::chrono::steady_clock::now();
        t[threads - 1] = dataset::groundTruth(caster, lens, c2w, 0.5, threads);
        seconds[threads - 1] = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    }
    std::printf(
        "phantom (%zu triangles): tree built in %.0f ms; 640x480 through the fisheye in %.0f ms on 1 thread, "
        "%.0f ms on 2\n",
        m.triangleCount(), build * 1e3, seconds[0] * 1e3, seconds[1] * 1e3);
    const dataset::GroundTruth &a = t[0], &b = t[1];
    EXPECT_TRUE(sameBytes(a.depth, b.depth));
    EXPECT_TRUE(sameBytes(a.normals, b.normals));
    EXPECT_TRUE(sameBytes(a.uv, b.uv));
    EXPECT_TRUE(sameBytes(a.face, b.face));
    EXPECT_TRUE(sameBytes(a.b1, b.b1));
    EXPECT_TRUE(sameBytes(a.b2, b.b2));
    EXPECT_TRUE(sameBytes(a.valid, b.valid));
    EXPECT_TRUE(sameBytes(a.inView, b.inView));
    // Inside the closed airway every ray meets the wall.
    std::size_t valid = 0, inView = 0;
    for (std::size_t i = 0; i < a.valid.size(); ++i) valid += a.valid[i], inView += a.inView[i];
    EXPECT_GT(valid, 0.95 * static_cast<double>(inView));
}

}  // namespace
}  // namespace mucosa
