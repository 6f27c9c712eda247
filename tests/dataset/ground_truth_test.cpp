// Per-frame ground truth: depth, normals, uv and face ids of analytic scenes
// against their closed forms; the renderer's camera in OpenCV terms; the
// field-of-view mask; `mucosa render --outputs` end to end (files, manifest,
// resume, refusals).
#include <cmath>
#include <filesystem>
#include <fstream>

#include <gtest/gtest.h>

#include <mucosa/camera/camera.hpp>
#include <mucosa/core/error.hpp>
#include <mucosa/dataset/ground_truth.hpp>
#include <mucosa/fit/categories.hpp>
#include <mucosa/frames/frames.hpp>
#include <mucosa/image/exr.hpp>
#include <mucosa/image/png.hpp>
#include <mucosa/mesh/phantom.hpp>
#include <mucosa/mesh/primitives.hpp>
#include <mucosa/scene/scene.hpp>

#include "cli_helpers.hpp"
#include "test_support.hpp"

namespace mucosa {
namespace {

namespace fs = std::filesystem;
using frames::Mat4;
using frames::Vec3d;

// The ray of pixel (x, y) in world coordinates (camera z component 1).
Vec3d worldRay(const frames::Intrinsics& K, const Mat4& c2w, int x, int y) {
    const double d[3] = {(x - K.cx) / K.fx, (y - K.cy) / K.fy, 1.0};
    Vec3d w{};
    for (int r = 0; r < 3; ++r) w[r] = c2w[r][0] * d[0] + c2w[r][1] * d[1] + c2w[r][2] * d[2];
    return w;
}

double angleDeg(const double* a, const double* b) {
    const double dot = a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    const double na = std::sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2]);
    const double nb = std::sqrt(b[0] * b[0] + b[1] * b[1] + b[2] * b[2]);
    return std::acos(std::clamp(dot / (na * nb), -1.0, 1.0)) * 180 / M_PI;
}

frames::Intrinsics camera(int w, int h, double fovDeg) {
    camera::Lens lens;
    lens.fovDeg = static_cast<float>(fovDeg);
    return dataset::intrinsicsOf(lens, w, h);
}

TEST(GroundTruth, ATiltedPlanesDepthNormalUvAndFaceAreItsClosedForm) {
    const mesh::Mesh quad = mesh::makeQuad(400.f, 6);  // z = 0, facing +z
    const frames::Intrinsics K = camera(160, 120, 90);
    const Vec3d eye{12, -7, 40};
    const Mat4 c2w = frames::lookAtPose(eye, {-5, 4, 0}, {0, 1, 0});
    const dataset::GroundTruth t = dataset::groundTruth(quad, K, c2w, 0.5);
    // The quad's UVs are affine in x, y: solved from three of its vertices.
    const auto& p = quad.positions;
    const auto& uv = quad.uvs;
    const std::size_t a = quad.indices[0], b = quad.indices[1], c = quad.indices[2];
    const double det = (p[b][0] - p[a][0]) * (p[c][1] - p[a][1]) - (p[c][0] - p[a][0]) * (p[b][1] - p[a][1]);
    auto uvAt = [&](double x, double y, int k) {
        const double s = ((x - p[a][0]) * (p[c][1] - p[a][1]) - (p[c][0] - p[a][0]) * (y - p[a][1])) / det;
        const double r = ((p[b][0] - p[a][0]) * (y - p[a][1]) - (x - p[a][0]) * (p[b][1] - p[a][1])) / det;
        return uv[a][k] + s * (uv[b][k] - uv[a][k]) + r * (uv[c][k] - uv[a][k]);
    };
    int seen = 0;
    double worstDepth = 0, worstNormal = 0, worstUv = 0;
    for (int y = 0; y < K.height; ++y)
        for (int x = 0; x < K.width; ++x) {
            const Vec3d d = worldRay(K, c2w, x, y);
            const double s = -eye[2] / d[2];  // the plane z = 0 along the ray: the planar depth itself
            const std::size_t i = static_cast<std::size_t>(y) * K.width + x;
            if (!(s > 0)) {
                EXPECT_EQ(t.valid[i], 0);
                continue;
            }
            const double wx = eye[0] + s * d[0], wy = eye[1] + s * d[1];
            if (std::abs(wx) > 199 || std::abs(wy) > 199) continue;  // off the quad's edge
            ASSERT_EQ(t.valid[i], 1) << x << "," << y;
            ++seen;
            worstDepth = std::max(worstDepth, std::abs(t.depth.at(x, y) - s) / s);
            // +z in camera axes: row 2 of the rotation (R^T e_z).
            const double truth[3] = {c2w[2][0], c2w[2][1], c2w[2][2]};
            const double got[3] = {t.normals.at(x, y, 0), t.normals.at(x, y, 1), t.normals.at(x, y, 2)};
            worstNormal = std::max(worstNormal, angleDeg(truth, got));
            for (int k = 0; k < 2; ++k) worstUv = std::max(worstUv, std::abs(t.uv.at(x, y, k) - uvAt(wx, wy, k)));
            EXPECT_EQ(t.uv.at(x, y, 2), 1.f);
            // The face id names a triangle that holds the point.
            const std::int32_t f = t.face[i];
            ASSERT_GE(f, 0);
            const auto& q0 = p[quad.indices[3 * f]];
            const auto& q1 = p[quad.indices[3 * f + 1]];
            const auto& q2 = p[quad.indices[3 * f + 2]];
            auto edge = [&](const mesh::Vec3& u, const mesh::Vec3& v) {
                return (v[0] - u[0]) * (wy - u[1]) - (wx - u[0]) * (v[1] - u[1]);
            };
            const double e0 = edge(q0, q1), e1 = edge(q1, q2), e2 = edge(q2, q0);
            const double tol = 1e-3 * 400;
            EXPECT_TRUE((e0 >= -tol && e1 >= -tol && e2 >= -tol) || (e0 <= tol && e1 <= tol && e2 <= tol))
                << "pixel " << x << "," << y << " face " << f;
        }
    EXPECT_GT(seen, K.width * K.height / 2);
    EXPECT_LE(worstDepth, 1e-4);
    EXPECT_LE(worstNormal, 0.1);
    EXPECT_LE(worstUv, 1e-4);
}

// A quad moved so that its centre is at `c` (mm).
mesh::Mesh movedQuad(float size, const mesh::Vec3& c) {
    mesh::Mesh m = mesh::makeQuad(size, 2);
    for (auto& p : m.positions)
        for (int k = 0; k < 3; ++k) p[k] += c[k];
    return m;
}

TEST(GroundTruth, FlowIsEachPointsReprojectionIntoThePreviousFrame) {
    const mesh::Mesh quad = movedQuad(400.f, {0, 0, 0});
    const frames::Intrinsics K = camera(120, 90, 90);
    const Mat4 before = frames::lookAtPose({0, 0, 40}, {2, 1, 0}, {0, 1, 0});
    const Mat4 now = frames::lookAtPose({3, -1.5, 36}, {-2, 3, 0}, {0.2, 1, 0});
    dataset::GroundTruth t0 = dataset::groundTruth(quad, K, before, 0.5);
    dataset::GroundTruth t1 = dataset::groundTruth(quad, K, now, 0.5);
    dataset::flowToPrevious(t0, K, before, nullptr, before, 0.5);
    for (float v : t0.flow.span()) ASSERT_EQ(v, 0.f);  // the first frame: no flow, nothing visible
    dataset::flowToPrevious(t1, K, now, &t0, before, 0.5);
    const Vec3d eye = frames::cameraCentre(now);
    const Mat4 w2c = frames::invertRigid(before);
    double worst = 0;
    int visible = 0, leaving = 0;
    for (int y = 0; y < K.height; ++y)
        for (int x = 0; x < K.width; ++x) {
            const Vec3d d = worldRay(K, now, x, y);
            const double s = -eye[2] / d[2];
            const Vec3d p{eye[0] + s * d[0], eye[1] + s * d[1], 0};
            const Vec3d q = frames::transformPoint(w2c, p);
            const double u = K.fx * q[0] / q[2] + K.cx, v = K.fy * q[1] / q[2] + K.cy;
            worst = std::max({worst, std::abs(t1.flow.at(x, y, 0) - (u - x)), std::abs(t1.flow.at(x, y, 1) - (v - y))});
            const bool inside = u >= 0 && v >= 0 && u <= K.width - 1 && v <= K.height - 1;
            EXPECT_EQ(t1.flow.at(x, y, 2), inside ? 1.f : 0.f) << x << "," << y;
            visible += inside;
            leaving += !inside;
        }
    EXPECT_LE(worst, 2e-3);  // pixels, float storage
    EXPECT_GT(visible, K.width * K.height / 2);
    EXPECT_GT(leaving, 100);  // the motion takes part of the view out of the previous frame
}

TEST(GroundTruth, FlowMarksWhatAnOccluderHidInThePreviousFrame) {
    // A wall at z = 0 and a card 10 mm in front of it; the camera steps 15 mm sideways.
    mesh::Mesh scene = movedQuad(400.f, {0, 0, 0});
    const mesh::Mesh card = movedQuad(8.f, {0, 0, 10});
    const auto base = static_cast<std::uint32_t>(scene.positions.size());
    scene.positions.insert(scene.positions.end(), card.positions.begin(), card.positions.end());
    scene.normals.insert(scene.normals.end(), card.normals.begin(), card.normals.end());
    scene.uvs.insert(scene.uvs.end(), card.uvs.begin(), card.uvs.end());
    scene.tangents.insert(scene.tangents.end(), card.tangents.begin(), card.tangents.end());
    for (std::uint32_t i : card.indices) scene.indices.push_back(base + i);
    const frames::Intrinsics K = camera(120, 90, 90);
    const Mat4 before = frames::lookAtPose({0, 0, 40}, {0, 0, 0}, {0, 1, 0});
    const Mat4 now = frames::lookAtPose({15, 0, 40}, {15, 0, 0}, {0, 1, 0});
    const dataset::GroundTruth t0 = dataset::groundTruth(scene, K, before, 0.5);
    dataset::GroundTruth t1 = dataset::groundTruth(scene, K, now, 0.5);
    dataset::flowToPrevious(t1, K, now, &t0, before, 0.5);
    // Analytic: a point of the wall was hidden from the previous camera when
    // the segment to it crosses the card (|x|, |y| <= 4 at z = 10).
    const Vec3d eye = frames::cameraCentre(now), old = frames::cameraCentre(before);
    int hidden = 0, agree = 0, total = 0;
    for (int y = 0; y < K.height; ++y)
        for (int x = 0; x < K.width; ++x) {
            const Vec3d d = worldRay(K, now, x, y);
            const double s = -eye[2] / d[2];
            const Vec3d p{eye[0] + s * d[0], eye[1] + s * d[1], 0};
            const double sc = (10 - eye[2]) / d[2];  // this ray at the card's plane
            if (std::abs(eye[0] + sc * d[0]) <= 4.2 && std::abs(eye[1] + sc * d[1]) <= 4.2) continue;  // sees the card
            const double a = (10 - old[2]) / (p[2] - old[2]);  // the old camera's segment at z = 10
            const double cx = old[0] + a * (p[0] - old[0]), cy = old[1] + a * (p[1] - old[1]);
            if (std::abs(std::abs(cx) - 4) < 0.2 || std::abs(std::abs(cy) - 4) < 0.2) continue;  // the card's rim
            const bool wasHidden = std::abs(cx) < 4 && std::abs(cy) < 4;
            const Vec3d q = frames::transformPoint(frames::invertRigid(before), p);
            const double u = K.fx * q[0] / q[2] + K.cx, v = K.fy * q[1] / q[2] + K.cy;
            const bool outside = !(u >= 0 && v >= 0 && u <= K.width - 1 && v <= K.height - 1);
            hidden += wasHidden;
            ++total;
            agree += (t1.flow.at(x, y, 2) == 0.f) == (wasHidden || outside);
        }
    EXPECT_GT(hidden, 100);
    EXPECT_EQ(agree, total);
}

TEST(GroundTruth, EachWallVertexBelongsToTheBranchItSurrounds) {
    mesh::PhantomParams pp;
    pp.generations = 2;
    pp.resolution = 1;
    const mesh::Phantom ph = mesh::makePhantom(pp);
    const std::vector<std::int32_t> label = dataset::vertexBranches(ph.mesh, ph.centerline);
    ASSERT_EQ(label.size(), ph.mesh.vertexCount());
    // Around the middle of every branch (away from its junctions), the wall
    // within 1.3 radii of the centerline point is that branch's.
    int checked = 0;
    for (std::size_t b = 0; b < ph.centerline.branches.size(); ++b) {
        const mesh::CenterlineBranch& br = ph.centerline.branches[b];
        const std::size_t mid = br.points.size() / 2;
        const mesh::Vec3& c = br.points[mid];
        const double r = br.radii[mid];
        int here = 0;
        for (std::size_t v = 0; v < ph.mesh.vertexCount(); ++v) {
            const auto& p = ph.mesh.positions[v];
            const double d = std::hypot(p[0] - c[0], p[1] - c[1], p[2] - c[2]);
            if (d > 1.3 * r) continue;
            ++here;
            EXPECT_EQ(label[v], static_cast<std::int32_t>(b)) << br.name << " vertex " << v;
        }
        EXPECT_GT(here, 20) << br.name;
        checked += here;
    }
    EXPECT_GT(checked, 500);
    // Pixels take their triangle's nearest vertex's branch.
    const frames::Intrinsics K = camera(64, 48, 100);
    const auto& trachea = ph.centerline.branches[0];
    const mesh::Vec3& a = trachea.points[trachea.points.size() / 3];
    const mesh::Vec3& b = trachea.points.back();
    dataset::GroundTruth t =
        dataset::groundTruth(ph.mesh, K, frames::lookAtPose({a[0], a[1], a[2]}, {b[0], b[1], b[2]}, {0, 0, 1}), 0.5);
    dataset::labelBranches(t, ph.mesh, label);
    for (std::size_t i = 0; i < t.face.size(); ++i) {
        if (t.face[i] < 0) {
            EXPECT_EQ(t.branch[i], -1);
            continue;
        }
        const std::uint32_t* v = &ph.mesh.indices[3 * static_cast<std::size_t>(t.face[i])];
        const std::int32_t l = t.branch[i];
        EXPECT_TRUE(l == label[v[0]] || l == label[v[1]] || l == label[v[2]]);
    }
    EXPECT_EQ(t.branch[static_cast<std::size_t>(24 * 64 + 10)], 0);  // the trachea's wall, to the side
}

TEST(GroundTruth, TheZBufferSeesWhatRaysSeeWhateverTheThreads) {
    // Inside the phantom's trachea, the walls beside the camera cut by the
    // near plane: the z-buffer (triangles set up once, culled to the image,
    // rasterised in bands) against a ray per pixel into the SAH tree, and
    // against itself on 1, 2 and 3 threads (bit for bit).
    mesh::PhantomParams pp;
    pp.generations = 2;
    pp.resolution = 1;
    const mesh::Phantom ph = mesh::makePhantom(pp);
    const frames::Intrinsics K = camera(160, 120, 80);  // within 45 degrees of the axis: the same near plane for both
    const auto& trachea = ph.centerline.branches[0];
    const mesh::Vec3& a = trachea.points[trachea.points.size() / 3];
    const mesh::Vec3& b = trachea.points.back();
    const Mat4 c2w = frames::lookAtPose({a[0] + 2, a[1], a[2]}, {b[0], b[1], b[2]}, {0, 0, 1});
    const double near = 3.0;
    const dataset::GroundTruth z1 = dataset::groundTruth(ph.mesh, K, c2w, near, 1);
    for (int threads : {2, 3}) {
        const dataset::GroundTruth zn = dataset::groundTruth(ph.mesh, K, c2w, near, threads);
        EXPECT_EQ(zn.face, z1.face) << threads;
        EXPECT_EQ(zn.b1, z1.b1) << threads;
        EXPECT_TRUE(std::equal(z1.depth.data(), z1.depth.data() + z1.depth.size(), zn.depth.data())) << threads;
    }
    const dataset::GroundTruth rays = dataset::groundTruth(ph.mesh, dataset::fromIntrinsics(K), c2w, near);
    std::size_t seen = 0, sameFace = 0, sameDepth = 0;
    for (std::size_t i = 0; i < z1.face.size(); ++i) {
        EXPECT_EQ(z1.face[i] >= 0, rays.face[i] >= 0) << "pixel " << i;
        if (z1.face[i] < 0) continue;
        ++seen;
        sameFace += z1.face[i] == rays.face[i];
        const int x = static_cast<int>(i % K.width), y = static_cast<int>(i / K.width);
        sameDepth += std::abs(z1.depth.at(x, y) - rays.depth.at(x, y)) <= 1e-4 * rays.depth.at(x, y);
    }
    EXPECT_EQ(seen, z1.face.size());  // inside a closed tube every pixel sees the wall
    // Pixels on a shared edge may take either triangle; their depth agrees.
    EXPECT_GE(sameFace, seen * 98 / 100);
    EXPECT_GE(sameDepth, seen * 999 / 1000);
}

TEST(GroundTruth, TheZBufferCullsOnlyTrianglesWhollyOutsideTheView) {
    // The z-buffer drops a triangle when its three corners all lie past one
    // plane of the view (behind the near plane, or a pixel beyond an edge of
    // the image). Triangles that must survive: corners outside the image on
    // three different sides around its middle; corners behind the camera and
    // in front of it; a sliver crossing one corner of the image. Triangles
    // that may go: wholly left, right, above, below, behind. Every pixel's
    // face and depth against a ray per pixel.
    const frames::Intrinsics K = camera(64, 48, 60);
    Mat4 c2w{};
    for (int i = 0; i < 4; ++i) c2w[i][i] = 1;
    mesh::Mesh m;
    auto tri = [&](mesh::Vec3 a, mesh::Vec3 b, mesh::Vec3 c) {
        const auto base = static_cast<std::uint32_t>(m.positions.size());
        m.positions.insert(m.positions.end(), {a, b, c});
        m.indices.insert(m.indices.end(), {base, base + 1, base + 2});
    };
    const float z = 20;
    tri({-200, -100, z}, {200, -100, z}, {0, 200, z});  // 0: corners beyond three edges, covers all
    tri({-3, -3, 10}, {3, -3, 10}, {0, 6, -10});        // 1: from in front to behind the camera
    tri({-30, -30, 12}, {20, -30, 12}, {-30, 20, 12});  // 2: beyond three edges, across the top-left corner
    tri({-100, -5, 10}, {-60, 5, 10}, {-80, 0, 15});    // 3: wholly left of the image
    tri({60, -5, 10}, {100, 5, 10}, {80, 0, 15});       // 4: wholly right
    tri({-5, -100, 10}, {5, -60, 10}, {0, -80, 15});    // 5: wholly above
    tri({-5, 60, 10}, {5, 100, 10}, {0, 80, 15});       // 6: wholly below
    tri({-50, -50, -1}, {50, -50, -1}, {0, 50, -1});    // 7: behind the camera
    const double near = 0.5;
    const dataset::GroundTruth zb = dataset::groundTruth(m, K, c2w, near, 1);
    const dataset::GroundTruth zb2 = dataset::groundTruth(m, K, c2w, near, 2);
    EXPECT_EQ(zb2.face, zb.face);
    const dataset::GroundTruth rays = dataset::groundTruth(m, dataset::fromIntrinsics(K), c2w, near);
    std::array<int, 8> seen{};
    for (std::size_t i = 0; i < zb.face.size(); ++i) {
        ASSERT_GE(zb.face[i], 0) << "pixel " << i;  // triangle 0 covers the image
        EXPECT_EQ(zb.face[i], rays.face[i]) << "pixel " << i;
        const int x = static_cast<int>(i % K.width), y = static_cast<int>(i / K.width);
        EXPECT_NEAR(zb.depth.at(x, y), rays.depth.at(x, y), 1e-4 * rays.depth.at(x, y)) << "pixel " << i;
        ++seen[static_cast<std::size_t>(zb.face[i])];
    }
    EXPECT_GT(seen[0], 0);
    EXPECT_GT(seen[1], 20);
    EXPECT_GT(seen[2], 0);
    for (int t = 3; t < 8; ++t) EXPECT_EQ(seen[static_cast<std::size_t>(t)], 0) << t;
}

TEST(GroundTruth, InsideASphereDepthAndNormalsAreItsClosedForm) {
    const double r = 20;
    const mesh::Mesh sphere = mesh::makeSphere(static_cast<float>(r), 360, 180);
    const frames::Intrinsics K = camera(96, 80, 100);
    const Vec3d eye{3, -2, 1.5};
    const Mat4 c2w = frames::lookAtPose(eye, {10, 4, -12}, {0, 0, 1});
    const dataset::GroundTruth t = dataset::groundTruth(sphere, K, c2w, 0.5);
    double worstDepth = 0, worstNormal = 0;
    for (int y = 0; y < K.height; ++y)
        for (int x = 0; x < K.width; ++x) {
            ASSERT_EQ(t.valid[static_cast<std::size_t>(y) * K.width + x], 1);
            const Vec3d d = worldRay(K, c2w, x, y);
            // |eye + s d| = r, the far root (the eye is inside).
            const double A = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
            const double B = eye[0] * d[0] + eye[1] * d[1] + eye[2] * d[2];
            const double C = eye[0] * eye[0] + eye[1] * eye[1] + eye[2] * eye[2] - r * r;
            const double s = (-B + std::sqrt(B * B - A * C)) / A;
            worstDepth = std::max(worstDepth, std::abs(t.depth.at(x, y) - s) / s);
            // The inward normal, in camera axes.
            double nw[3], nc[3];
            for (int k = 0; k < 3; ++k) nw[k] = -(eye[k] + s * d[k]) / r;
            for (int k = 0; k < 3; ++k) nc[k] = c2w[0][k] * nw[0] + c2w[1][k] * nw[1] + c2w[2][k] * nw[2];
            const double got[3] = {t.normals.at(x, y, 0), t.normals.at(x, y, 1), t.normals.at(x, y, 2)};
            worstNormal = std::max(worstNormal, angleDeg(nc, got));
        }
    EXPECT_LE(worstDepth, 1e-4);
    EXPECT_LE(worstNormal, 0.1);
}

TEST(GroundTruth, TheRenderersCameraIsThePinholeTheManifestStates) {
    // intrinsicsOf / cameraToWorldOf give the matrices the renderer draws
    // with: the colour frame and the ground truth align pixel for pixel.
    for (const auto& [w, h, fov] : {std::tuple{640, 480, 120.0}, std::tuple{300, 400, 70.0}}) {
        camera::Lens lens;
        lens.fovDeg = static_cast<float>(fov);
        const auto P = camera::projectionMatrix(lens, w, h);
        const auto Q = frames::glProjectionMatrix(dataset::intrinsicsOf(lens, w, h), lens.nearMm, lens.farMm);
        for (int k = 0; k < 16; ++k) EXPECT_NEAR(P[k], Q[k], 1e-5 * std::max(1.0f, std::abs(P[k]))) << k;
    }
    camera::Pose pose;
    pose.position = {3, -4, 5};
    pose.forward = {0.2f, -0.9f, 0.3f};
    pose.up = {0, 0, 1};
    const auto V = camera::viewMatrix(pose);
    const auto U = frames::glViewMatrix(dataset::cameraToWorldOf(pose));
    for (int k = 0; k < 16; ++k) EXPECT_NEAR(V[k], U[k], 1e-5) << k;
}

TEST(GroundTruth, TheFieldOfViewIsTheShadersMask) {
    scene::Scene s = scene::defaultScene();
    shading::FrameSetup f = scene::frameSetup(s, camera::Pose{}, 200, 160);
    f.params.set(shading::Param::Mask, 1.0f);  // a circle of radius 0.9 x half the smaller side
    f.params.set(shading::Param::MaskRadius, 0.9f);
    const std::vector<std::uint8_t> in = dataset::fieldOfView(f);
    std::size_t n = 0;
    for (auto v : in) n += v;
    const double expected = M_PI * 72 * 72;
    EXPECT_NEAR(static_cast<double>(n), expected, 0.01 * expected);
    EXPECT_EQ(in[0], 0);
    EXPECT_EQ(in[80 * 200 + 100], 1);
    f.params.set(shading::Param::Mask, 0.0f);
    for (auto v : dataset::fieldOfView(f)) ASSERT_EQ(v, 1);
}

TEST(GroundTruth, OutputListsAreParsedAndRefused) {
    const dataset::Outputs o = dataset::parseOutputs("rgb, depth,face", "--outputs", "cli");
    EXPECT_TRUE(o.rgb && o.depth && o.face && !o.normals && !o.mask && !o.uv);
    EXPECT_EQ(dataset::outputNames(o), "rgb,depth,face");
    EXPECT_THROW(dataset::parseOutputs("rgb,depht", "--outputs", "cli"), InputError);
    EXPECT_THROW(dataset::parseOutputs("rgb,rgb", "--outputs", "cli"), InputError);
    EXPECT_THROW(dataset::parseOutputs("", "--outputs", "cli"), InputError);
    const auto files = dataset::outputFiles("out/fly_0003.png", dataset::parseOutputs("depth,normals", "", ""));
    ASSERT_EQ(files.size(), 4u);
    EXPECT_EQ(files[0], fs::path("out/fly_0003.depth.exr"));
    EXPECT_EQ(files[1], fs::path("out/fly_0003.depth.png"));
    EXPECT_EQ(files[3], fs::path("out/fly_0003.normals.png"));
}

TEST(GroundTruthCli, RenderWritesEveryOutputAndAManifestFitReads) {
    test::TempDir dir;
    const std::string out = (dir / "fly.png").string();
    const std::string args =
        "render -o '" + out + "' --frames 3 --size 96x72 --outputs rgb,depth,normals,mask,uv,face,flow,branch";
    test::RunResult r = test::runCli(args);
    ASSERT_EQ(r.exitCode, 0) << r.err;
    // The manifest: the frames file `mucosa fit` reads, with the outputs described.
    const frames::FrameSet set = frames::readFrames(dir / "fly.frames.json");
    ASSERT_EQ(set.frames.size(), 3u);
    const scene::Scene s = scene::defaultScene();
    const frames::Intrinsics K = dataset::intrinsicsOf(s.lens, 96, 72);
    EXPECT_DOUBLE_EQ(set.frames[1].K.fx, K.fx);
    EXPECT_DOUBLE_EQ(set.frames[1].K.cx, 47.5);
    EXPECT_EQ(set.frames[2].image, dir / "fly_0002.png");
    const nlohmann::json j = nlohmann::json::parse(test::readBytes(dir / "fly.frames.json"));
    EXPECT_EQ(j["outputs"]["depth"]["unit"], "mm");
    EXPECT_EQ(j["outputs"]["depth"]["file"], "fly_{frame:04}.depth.exr");
    EXPECT_EQ(j["outputs"]["depth_png"]["scale_mm"], 0.01);
    EXPECT_TRUE(j["conventions"].contains("camera_axes"));
    for (int i = 0; i < 3; ++i)
        for (const char* suffix :
             {".png", ".depth.exr", ".depth.png", ".normals.exr", ".normals.png", ".mask.png", ".uv.exr", ".face.exr"})
            EXPECT_TRUE(fs::exists(dir / ("fly_000" + std::to_string(i) + suffix))) << i << suffix;
    // The depth EXR is the ground truth of the manifest's camera, and the PNG its scaled copy.
    const image::ImageF depth = image::readExr(dir / "fly_0001.depth.exr");
    const dataset::GroundTruth t = dataset::groundTruth(scene::loadAssets(s, 0, false).mesh, set.frames[1].K,
                                                        set.frames[1].cameraToWorld, s.lens.nearMm);
    const image::PngImage png = image::readPng(dir / "fly_0001.depth.png");
    for (int y = 0; y < 72; y += 7)
        for (int x = 0; x < 96; x += 5) {
            EXPECT_NEAR(depth.at(x, y), t.depth.at(x, y), 1e-4 * t.depth.at(x, y));
            EXPECT_NEAR(png.pixels.at(x, y) * 0.01, t.depth.at(x, y), 0.0051);
        }
    // Branch labels: the tree's branches, in the table and in the picture.
    const nlohmann::json& labels = j["outputs"]["branch"]["labels"];
    ASSERT_EQ(labels.size(), scene::loadAssets(s, 0, false).centerlineTree.branches.size());
    EXPECT_EQ(labels[0]["name"], "trachea");
    EXPECT_EQ(labels[0]["generation"], 0);
    EXPECT_EQ(labels[1]["parent"], 1);
    const image::PngImage branch = image::readPng(dir / "fly_0001.branch.png");
    EXPECT_EQ(branch.bitDepth, 16);
    for (int y = 0; y < 72; ++y)
        for (int x = 0; x < 96; ++x) {
            const int l = branch.pixels.at(x, y);
            EXPECT_EQ(l == 0, t.depth.at(x, y) == 0);
            EXPECT_LE(l, static_cast<int>(labels.size()));
        }
    // The mask is the colour frame's field of view: black outside it.
    const image::PngImage mask = image::readPng(dir / "fly_0001.mask.png");
    const image::PngImage rgb = image::readPng(dir / "fly_0001.png");
    EXPECT_GE(test::maskAgreesWithLitPixels(rgb, mask), 0.97);
    // The field-of-view mask is the scope camera's: a mode that does not go
    // through the camera (brdf) shows the wall to the corners, and its mask
    // is every pixel that sees the wall.
    r = test::runCli("render -o '" + (dir / "brdf.png").string() +
                     "' --mode brdf --frames 1 --size 96x72 --outputs rgb,depth,mask");
    ASSERT_EQ(r.exitCode, 0) << r.err;
    {
        const image::PngImage m = image::readPng(dir / "brdf.mask.png");
        const image::ImageF d = image::readExr(dir / "brdf.depth.exr");
        int seen = 0, corners = 0;
        for (int y = 0; y < 72; ++y)
            for (int x = 0; x < 96; ++x) {
                EXPECT_EQ(m.pixels.at(x, y) == 255, d.at(x, y) > 0) << x << "," << y;
                seen += d.at(x, y) > 0;
                corners += (x < 8 || x >= 88) && (y < 8 || y >= 64) && m.pixels.at(x, y) == 255;
            }
        EXPECT_GT(seen, 96 * 72 / 2);
        EXPECT_GT(corners, 0);  // the photographic frames' circle masks every corner
    }

    // Resume: a frame missing one output is rendered again, the others kept;
    // its flow (from the frame before, computed again) is the same.
    const std::string flow = test::readBytes(dir / "fly_0001.flow.exr");
    fs::remove(dir / "fly_0001.normals.exr");
    r = test::runCli(args);
    ASSERT_EQ(r.exitCode, 0) << r.err;
    EXPECT_EQ(test::readBytes(dir / "fly_0001.flow.exr"), flow);
    EXPECT_NE(r.out.find("wrote 1 frame"), std::string::npos) << r.out;
    EXPECT_NE(r.out.find("kept 2 existing"), std::string::npos) << r.out;
    EXPECT_TRUE(fs::exists(dir / "fly_0001.normals.exr"));
    // Other outputs on resume are refused, naming them.
    fs::remove(dir / "fly_0002.png");
    r = test::runCli("render -o '" + out + "' --frames 3 --size 96x72 --outputs rgb,depth");
    test::expectOneErrorLine(r, "outputs");
    EXPECT_FALSE(fs::exists(dir / "fly_0002.png"));
    r = test::runCli("render -o '" + out + "' --outputs rgb,depht");
    test::expectOneErrorLine(r, "depht");
    // Branch labels need a centerline tree: the tube has none.
    std::ofstream(dir / "tube.json") << R"({"mesh": "tube"})";
    r = test::runCli("render '" + (dir / "tube.json").string() + "' -o '" + (dir / "tube.png").string() +
                     "' --outputs rgb,branch");
    test::expectOneErrorLine(r, "centerline tree");
    EXPECT_FALSE(fs::exists(dir / "tube.png"));
    EXPECT_FALSE(fs::exists(dir / "tube.frames.json"));
}

TEST(GroundTruthCli, TheExrCompressionChangesTheBytesNotTheValuesAndIsStated) {
    test::TempDir dir;
    const std::string base = " --frames 2 --size 80x64 --outputs depth,normals,uv,flow";
    auto render = [&](const std::string& name, const std::string& extra) {
        const test::RunResult r = test::runCli("render -o '" + (dir / name).string() + "'" + base + extra);
        EXPECT_EQ(r.exitCode, 0) << r.err;
    };
    render("zip.png", "");
    render("none.png", " --exr-compression none");
    render("piz.png", " --exr-compression piz");
    for (const char* suffix : {"_0001.depth.exr", "_0001.normals.exr", "_0001.uv.exr", "_0001.flow.exr"}) {
        const image::ImageF zip = image::readExr(dir / (std::string("zip") + suffix));
        for (const char* other : {"none", "piz"}) {
            const image::ImageF o = image::readExr(dir / (std::string(other) + suffix));
            EXPECT_TRUE(o == zip) << other << suffix;  // lossless: the same floats
        }
        // Uncompressed is larger: the options reached the writer.
        EXPECT_GT(fs::file_size(dir / (std::string("none") + suffix)),
                  fs::file_size(dir / (std::string("zip") + suffix)))
            << suffix;
    }
    // The manifest says which: in each output's encoding, and in the settings
    // when it is not the default.
    const nlohmann::json zipJ = nlohmann::json::parse(test::readBytes(dir / "zip.frames.json"));
    const nlohmann::json noneJ = nlohmann::json::parse(test::readBytes(dir / "none.frames.json"));
    EXPECT_NE(zipJ["outputs"]["depth"]["encoding"].get<std::string>().find("zip compression (lossless)"),
              std::string::npos);
    EXPECT_NE(noneJ["outputs"]["normals"]["encoding"].get<std::string>().find("none compression (lossless)"),
              std::string::npos);
    // A name OpenEXR has but that would lose ground truth, or none at all:
    // one line, nothing written.
    for (const char* bad : {"b44", "dwaa", "ZIP"}) {
        const test::RunResult r =
            test::runCli("render -o '" + (dir / "bad.png").string() + "'" + base + " --exr-compression " + bad);
        test::expectOneErrorLine(r, "--exr-compression", bad);
        EXPECT_FALSE(fs::exists(dir / "bad_0000.depth.exr"));
        EXPECT_FALSE(fs::exists(dir / "bad.frames.json"));
    }
    // A plan keeps it: its frames are written with it, and its manifest says so.
    std::ofstream(dir / "tube.json") << R"({"mesh": "tube"})";
    const fs::path plan = dir / "plan";
    test::RunResult r =
        test::runCli("dataset plan '" + (dir / "tube.json").string() +
                     "' --frames 2 --size 64x48 --outputs rgb,depth --exr-compression none -o '" + plan.string() + "'");
    ASSERT_EQ(r.exitCode, 0) << r.err;
    EXPECT_EQ(nlohmann::json::parse(test::readBytes(plan / "plan.json"))["args"]["exr_compression"], "none");
    r = test::runCli("dataset run '" + plan.string() + "'");
    ASSERT_EQ(r.exitCode, 0) << r.err;
    const fs::path depth = plan / "frames" / "frame_0001.depth.exr";
    ASSERT_TRUE(fs::exists(depth));
    EXPECT_GE(fs::file_size(depth), 64u * 48u * sizeof(float));
    test::expectOneErrorLine(test::runCli("dataset plan '" + (dir / "tube.json").string() +
                                          "' --frames 2 --exr-compression lzw -o '" + (dir / "plan2").string() + "'"),
                             "--exr-compression", "lzw");
    EXPECT_FALSE(fs::exists(dir / "plan2" / "plan.json"));
}

}  // namespace
}  // namespace mucosa
