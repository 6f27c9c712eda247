// Endoscope camera: the field of view spans the larger image side, the light
// sits at the tip (plus its offset), fly-throughs stay on the line, look ahead
// along it and never roll suddenly.
#include <gtest/gtest.h>

#include <cmath>

#include <mucosa/camera/camera.hpp>
#include <mucosa/core/error.hpp>

namespace mucosa {
namespace {

std::array<float, 4> apply(const camera::Mat4& m, const std::array<float, 4>& v) {
    std::array<float, 4> r{};
    for (int row = 0; row < 4; ++row)
        for (int c = 0; c < 4; ++c) r[row] += m[c * 4 + row] * v[c];
    return r;
}

float dot(const camera::Vec3& a, const camera::Vec3& b) {
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}
float norm(const camera::Vec3& a) {
    return std::sqrt(dot(a, a));
}

TEST(Camera, FieldOfViewSpansTheLargerSide) {
    camera::Lens lens;  // 120 degrees
    const camera::Mat4 P = camera::projectionMatrix(lens, 640, 480);
    // A point 60 degrees to the right of the axis lands on the right edge.
    const float x = std::tan(60.0f * 3.14159265f / 180.0f);
    const auto c = apply(P, {x * 10.0f, 0.0f, -10.0f, 1.0f});
    EXPECT_NEAR(c[0] / c[3], 1.0f, 1e-4f);
    const camera::Mat4 Pt = camera::projectionMatrix(lens, 480, 640);  // portrait: vertical
    const auto d = apply(Pt, {0.0f, x * 10.0f, -10.0f, 1.0f});
    EXPECT_NEAR(d[1] / d[3], 1.0f, 1e-4f);
}

TEST(Camera, ViewMatrixLooksDownForward) {
    const camera::Pose p = camera::lookAt({1, 2, 3}, {1, 2, -7});
    const camera::Mat4 V = camera::viewMatrix(p);
    const auto e = apply(V, {1, 2, -7, 1});
    EXPECT_NEAR(e[0], 0.0f, 1e-5f);
    EXPECT_NEAR(e[1], 0.0f, 1e-5f);
    EXPECT_NEAR(e[2], -10.0f, 1e-5f);  // OpenGL eye space looks down -z
}

TEST(Camera, TipLightFollowsTheCameraFrame) {
    const camera::Pose p = camera::lookAt({0, 0, 0}, {0, 0, -1});
    const camera::Vec3 l = camera::lightPosition(p, camera::TipLight{{2, 0, 1}});
    EXPECT_NEAR(l[0], 2.0f, 1e-6f);   // right
    EXPECT_NEAR(l[2], -1.0f, 1e-6f);  // forward
}

TEST(Camera, LensValidationNamesTheField) {
    camera::Lens l;
    l.fovDeg = 200;
    try {
        camera::validate(l);
        FAIL();
    } catch (const InputError& e) {
        EXPECT_EQ(e.subject(), "camera.fov_deg");
    }
}

TEST(Camera, FlyThroughStaysOnTheLineLooksAheadAndDoesNotRoll) {
    // A helix-like bending path.
    std::vector<camera::Vec3> line;
    for (int i = 0; i <= 200; ++i) {
        const float t = static_cast<float>(i) / 200.0f;
        line.push_back({20.0f * std::sin(3.0f * t), -100.0f * t, 20.0f * (1.0f - std::cos(3.0f * t))});
    }
    camera::FlyThrough o;
    o.frames = 150;
    const auto poses = camera::flyThrough(line, o);
    ASSERT_EQ(poses.size(), 150u);
    EXPECT_NEAR(poses.front().position[1], 0.0f, 1e-4f);
    for (std::size_t i = 0; i < poses.size(); ++i) {
        const auto& p = poses[i];
        EXPECT_NEAR(norm(p.forward), 1.0f, 1e-4f);
        EXPECT_NEAR(norm(p.up), 1.0f, 1e-4f);
        EXPECT_NEAR(dot(p.forward, p.up), 0.0f, 1e-4f);
        EXPECT_LT(p.forward[1], 0.0f);  // heading down the path
        if (i > 0) {
            // Smooth: consecutive up vectors turn by less than 5 degrees.
            EXPECT_GT(dot(p.up, poses[i - 1].up), std::cos(5.0f * 3.14159265f / 180.0f)) << i;
        }
    }
    o.speedMm = 1.0f;
    o.frames = 10;
    const auto slow = camera::flyThrough(line, o);
    const camera::Vec3 d{slow[1].position[0] - slow[0].position[0], slow[1].position[1] - slow[0].position[1],
                         slow[1].position[2] - slow[0].position[2]};
    EXPECT_NEAR(norm(d), 1.0f, 0.05f);  // 1 mm per frame
}

// stopMm ends the flight that far before the path's end: frames spread up to
// there, or (at a fixed speed) stay there, still looking ahead along the path.
TEST(Camera, FlyThroughStopsStopMmBeforeTheEnd) {
    const std::vector<camera::Vec3> line = {{0, 0, 0}, {0, 0, -100}};
    camera::FlyThrough o;
    o.frames = 11;
    o.stopMm = 10.0f;
    auto poses = camera::flyThrough(line, o);
    ASSERT_EQ(poses.size(), 11u);
    EXPECT_NEAR(poses.front().position[2], 0.0f, 1e-4f);
    EXPECT_NEAR(poses[1].position[2], -9.0f, 1e-4f);
    EXPECT_NEAR(poses.back().position[2], -90.0f, 1e-4f);
    EXPECT_NEAR(poses.back().forward[2], -1.0f, 1e-4f);
    o.speedMm = 20.0f;
    poses = camera::flyThrough(line, o);
    EXPECT_NEAR(poses[4].position[2], -80.0f, 1e-4f);
    EXPECT_NEAR(poses[5].position[2], -90.0f, 1e-4f);
    EXPECT_NEAR(poses.back().position[2], -90.0f, 1e-4f);
    // A stop beyond the start keeps the camera at the start.
    o.speedMm = 0.0f;
    o.startMm = 50.0f;
    o.stopMm = 80.0f;
    poses = camera::flyThrough(line, o);
    EXPECT_NEAR(poses.back().position[2], -50.0f, 1e-4f);
}

TEST(Camera, PoseListIsInterpolatedThroughTheKeys) {
    const std::vector<camera::Pose> keys = {camera::lookAt({0, 0, 0}, {0, 0, -1}),
                                            camera::lookAt({0, 0, -10}, {0, 0, -11}),
                                            camera::lookAt({10, 0, -20}, {11, 0, -20})};
    const auto poses = camera::interpolatePoses(keys, 5);
    ASSERT_EQ(poses.size(), 5u);
    EXPECT_NEAR(poses[2].position[2], -10.0f, 1e-4f);
    EXPECT_NEAR(poses[4].position[0], 10.0f, 1e-4f);
    EXPECT_THROW(camera::interpolatePoses({}, 3), InputError);
}

}  // namespace
}  // namespace mucosa
