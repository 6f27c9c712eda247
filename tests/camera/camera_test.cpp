// Endoscope camera: the field of view spans the larger image side, the light
// sits at the tip (plus its offset), fly-throughs stay on the line, look ahead
// along it and never roll suddenly.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include <mucosa/camera/camera.hpp>
#include <mucosa/core/error.hpp>
#include <mucosa/scene/scene.hpp>

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

std::vector<camera::Vec3> helix() {
    std::vector<camera::Vec3> line;
    for (int i = 0; i <= 200; ++i) {
        const float t = static_cast<float>(i) / 200.0f;
        line.push_back({20.0f * std::sin(3.0f * t), -100.0f * t, 20.0f * (1.0f - std::cos(3.0f * t))});
    }
    return line;
}

// With wander and look-around at 0 the fly-through is the centred path of
// before the bronchoscopist's options: these poses are what the previous
// implementation gave (printed with %.9g before the change), radii or not.
TEST(Camera, FlyThroughWithoutWanderIsTheCentredPath) {
    const float expected[7][9] = {
        {0, -0, 0, 0.511100113f, -0.857895613f, 0.0528350361f, 0.853348255f, 0.513823867f, 0.0882149711f},
        {9.20997334f, -15.9520636f, 2.24701238f, 0.429357558f, -0.857897341f, 0.282248557f, 0.876983523f, 0.470703095f,
         0.0966362134f},
        {16.3504887f, -31.9041309f, 8.48272896f, 0.251158416f, -0.857898474f, 0.448251754f, 0.925418258f, 0.348583847f,
         0.148628488f},
        {19.8172722f, -47.856205f, 17.3060722f, 0.0165366437f, -0.857898951f, 0.513552129f, 0.95359844f, 0.167962015f,
         0.249877498f},
        {18.8314552f, -63.8082809f, 26.7346153f, -0.221800342f, -0.857899368f, 0.463479578f, 0.928618014f,
         -0.0408497415f, 0.368781775f},
        {13.6145401f, -79.7603912f, 34.6499786f, -0.410308719f, -0.85789901f, 0.309283286f, 0.854216337f, -0.242805779f,
         0.45973888f},
        {5.33867264f, -95.7125092f, 39.2737274f, -0.503345013f, -0.857652366f, 0.105243526f, 0.774022758f,
         -0.393384039f, 0.496122986f}};
    camera::FlyThrough o;
    o.frames = 7;
    o.stopMm = 5;
    const auto line = helix();
    const auto plain = camera::flyThrough(line, o);
    const auto withRadii = camera::flyThrough(line, o, std::vector<float>(line.size(), 6.0f));
    ASSERT_EQ(plain.size(), 7u);
    for (std::size_t i = 0; i < 7; ++i) {
        for (int k = 0; k < 3; ++k) {
            EXPECT_NEAR(plain[i].position[k], expected[i][k], 1e-5f) << i;
            EXPECT_NEAR(plain[i].forward[k], expected[i][3 + k], 1e-6f) << i;
            EXPECT_NEAR(plain[i].up[k], expected[i][6 + k], 1e-6f) << i;
        }
        EXPECT_EQ(withRadii[i].position, plain[i].position);
        EXPECT_EQ(withRadii[i].forward, plain[i].forward);
        EXPECT_EQ(withRadii[i].up, plain[i].up);
    }
}

float distanceToPolyline(const camera::Vec3& p, const std::vector<camera::Vec3>& line, std::size_t* segment,
                         float* along) {
    float best = 1e30f;
    for (std::size_t i = 0; i + 1 < line.size(); ++i) {
        const camera::Vec3 a = line[i], b = line[i + 1];
        const camera::Vec3 ab{b[0] - a[0], b[1] - a[1], b[2] - a[2]}, ap{p[0] - a[0], p[1] - a[1], p[2] - a[2]};
        const float t = std::clamp(dot(ap, ab) / std::max(dot(ab, ab), 1e-12f), 0.0f, 1.0f);
        const camera::Vec3 d{ap[0] - t * ab[0], ap[1] - t * ab[1], ap[2] - t * ab[2]};
        const float dist = norm(d);
        if (dist < best) best = dist, *segment = i, *along = t;
    }
    return best;
}

float angleDeg(const camera::Vec3& a, const camera::Vec3& b) {
    return std::acos(std::clamp(dot(a, b) / (norm(a) * norm(b)), -1.0f, 1.0f)) * 180.0f / 3.14159265f;
}

// The default scene's fly-through along one path (route "path": the phantom
// at render's 1 cell/mm, 120 frames) wanders like a bronchoscopist and stays in the lumen: every eye is
// nearer the centerline than the local radius less a margin larger than the
// near plane, at least 1.5 near planes from the nearest vertex of the actual
// surface and on its lumen side, short of the blind end; the offsets and the
// turns are real (not zero) and change smoothly from frame to frame.
TEST(Camera, DefaultFlyThroughWandersInsideTheLumenSmoothly) {
    scene::Scene sc = scene::defaultScene();
    sc.path.survey = false;
    ASSERT_GT(sc.path.fly.wander, 0.0f);
    ASSERT_GT(sc.path.fly.lookAroundDeg, 0.0f);
    const scene::SceneAssets assets = scene::loadAssets(sc, 0, false);
    ASSERT_EQ(assets.centerlineRadii.size(), assets.centerline.size());
    const int frames = 120;
    const auto poses = scene::cameraPoses(sc, assets, frames);
    scene::Scene centred = sc;
    centred.path.fly.wander = 0;
    centred.path.fly.lookAroundDeg = 0;
    const auto base = scene::cameraPoses(centred, assets, frames);
    ASSERT_EQ(poses.size(), base.size());
    const auto& line = assets.centerline;
    const auto& radii = assets.centerlineRadii;
    const mesh::Mesh& m = assets.mesh;
    const float nearMm = sc.lens.nearMm;
    float maxOffsetFraction = 0, maxTurn = 0, maxOffsetStep = 0, maxTurnStep = 0, minClearance = 1e30f;
    float maxBaseTurnStep = 0, maxRollStep = 0;
    for (std::size_t i = 0; i < poses.size(); ++i) {
        const auto& p = poses[i];
        std::size_t seg = 0;
        float t = 0;
        const float d = distanceToPolyline(p.position, line, &seg, &t);
        const float R = radii[seg] + (radii[seg + 1] - radii[seg]) * t;
        EXPECT_LT(d, R - 2 * nearMm) << "frame " << i;
        // The actual wall: the nearest vertex, and the eye on its lumen side.
        float best = 1e30f;
        std::size_t nv = 0;
        for (std::size_t v = 0; v < m.vertexCount(); ++v) {
            const camera::Vec3 e{p.position[0] - m.positions[v][0], p.position[1] - m.positions[v][1],
                                 p.position[2] - m.positions[v][2]};
            const float dd = dot(e, e);
            if (dd < best) best = dd, nv = v;
        }
        const camera::Vec3 e{p.position[0] - m.positions[nv][0], p.position[1] - m.positions[nv][1],
                             p.position[2] - m.positions[nv][2]};
        EXPECT_GT(dot(e, m.normals[nv]), 0.0f) << "frame " << i << " is outside the lumen";
        minClearance = std::min(minClearance, std::sqrt(best));
        // Off-centre and turned, relative to the centred pose of the same frame.
        const camera::Vec3 off{p.position[0] - base[i].position[0], p.position[1] - base[i].position[1],
                               p.position[2] - base[i].position[2]};
        maxOffsetFraction = std::max(maxOffsetFraction, norm(off) / R);
        maxTurn = std::max(maxTurn, angleDeg(p.forward, base[i].forward));
        EXPECT_LE(angleDeg(p.forward, base[i].forward), sc.path.fly.lookAroundDeg * std::sqrt(2.0f) + 0.01f);
        EXPECT_NEAR(dot(p.forward, p.up), 0.0f, 1e-4f);
        if (i > 0) {
            const camera::Vec3 offPrev{poses[i - 1].position[0] - base[i - 1].position[0],
                                       poses[i - 1].position[1] - base[i - 1].position[1],
                                       poses[i - 1].position[2] - base[i - 1].position[2]};
            const camera::Vec3 dOff{off[0] - offPrev[0], off[1] - offPrev[1], off[2] - offPrev[2]};
            maxOffsetStep = std::max(maxOffsetStep, norm(dOff));
            // Beyond the centred path's own turn (sharp where the path bends into a branch).
            const float baseTurn = angleDeg(base[i].forward, base[i - 1].forward);
            maxBaseTurnStep = std::max(maxBaseTurnStep, baseTurn);
            maxTurnStep = std::max(maxTurnStep, angleDeg(p.forward, poses[i - 1].forward) - baseTurn);
            maxRollStep = std::max(maxRollStep, angleDeg(p.up, poses[i - 1].up) - angleDeg(base[i].up, base[i - 1].up));
        }
    }
    // The last eye stops where the centred path stops: short of the blind end.
    std::size_t seg = 0;
    float t = 0;
    distanceToPolyline(poses.back().position, line, &seg, &t);
    const float stepMm = camera::pathLength(line) / float(frames);
    std::printf(
        "fly-through: max offset %.2f of the radius, max turn %.1f deg, max change per frame %.2f mm, "
        "%.1f deg view and %.1f deg up beyond the centred path's (its own up to %.1f deg; frame step %.2f mm), "
        "min distance to a vertex %.2f mm\n",
        maxOffsetFraction, maxTurn, maxOffsetStep, maxTurnStep, maxRollStep, maxBaseTurnStep, stepMm, minClearance);
    EXPECT_LT(seg, line.size() - 2) << "the last frame is short of the distal end";
    EXPECT_GT(minClearance, 1.5f * nearMm);
    EXPECT_GT(maxOffsetFraction, 0.15f) << "the eye leaves the centre";
    EXPECT_LE(maxOffsetFraction, sc.path.fly.wander + 1e-3f);
    EXPECT_GT(maxTurn, 8.0f) << "the view turns to the walls";
    EXPECT_LT(maxOffsetStep, 0.75f * stepMm) << "offsets change smoothly";
    // The turn's rate: each of yaw and pitch changes by at most
    // look_around x 2 pi / wander_period per mm (8.8 deg at this step).
    const float turnBound =
        sc.path.fly.lookAroundDeg * std::sqrt(2.0f) * 2 * 3.14159265f / sc.path.fly.wanderPeriodMm * stepMm;
    EXPECT_LT(maxTurnStep, turnBound) << "the view turns smoothly";
    EXPECT_LT(maxRollStep, turnBound) << "no sudden roll";
}

// The default fly-through is the bronchoscopist's survey of the whole tree
// (the phantom at render's 1 cell/mm, 120 frames). Geometry: every eye is in
// the lumen (nearer its branch's centerline than the radius less two near
// planes, on the lumen side of the nearest surface vertex, at least 1.5 near
// planes from it), and every branch's distal end is reached. Views: the
// distribution docs/theory.md ("The bronchoscopist's survey") states, within
// margins: the eye off the centre, the view turned from the branch's
// direction, rolled, and carinas in view.
TEST(Camera, SurveyVisitsEveryBranchInsideTheLumenWithABronchoscopistsViews) {
    const scene::Scene sc = scene::defaultScene();
    ASSERT_TRUE(sc.path.survey);
    const scene::SceneAssets assets = scene::loadAssets(sc, 0, false);
    const mesh::Centerline& tree = assets.centerlineTree;
    ASSERT_GE(tree.branches.size(), 7u);
    const int frames = 120;
    const auto poses = scene::cameraPoses(sc, assets, frames);
    ASSERT_EQ(poses.size(), std::size_t(frames));
    scene::Scene noRoll = sc;
    noRoll.path.surveyOptions.rollDeg = 0;
    const auto unrolled = scene::cameraPoses(noRoll, assets, frames);
    const mesh::Mesh& m = assets.mesh;
    const float nearMm = sc.lens.nearMm;
    const float halfFov = 0.5f * sc.lens.fovDeg;
    std::vector<float> offsetFraction, wallMm, turnDeg, rollDeg;
    int carinaFrames = 0;
    float minClearance = 1e30f;
    for (std::size_t i = 0; i < poses.size(); ++i) {
        const auto& p = poses[i];
        // The nearest centerline point over every branch, and its radius.
        float best = 1e30f, R = 0;
        camera::Vec3 along{0, 0, 0};
        for (const mesh::CenterlineBranch& b : tree.branches) {
            std::size_t seg = 0;
            float t = 0;
            if (b.points.size() < 2) continue;
            const float d = distanceToPolyline(p.position, b.points, &seg, &t);
            if (d < best) {
                best = d;
                R = b.radii[seg] + (b.radii[seg + 1] - b.radii[seg]) * t;
                along = {b.points[seg + 1][0] - b.points[seg][0], b.points[seg + 1][1] - b.points[seg][1],
                         b.points[seg + 1][2] - b.points[seg][2]};
            }
        }
        EXPECT_LT(best, R - 2 * nearMm) << "frame " << i;
        offsetFraction.push_back(best / R);
        wallMm.push_back(R - best);
        turnDeg.push_back(angleDeg(p.forward, along));
        float nearest = 1e30f;
        std::size_t nv = 0;
        for (std::size_t v = 0; v < m.vertexCount(); ++v) {
            const camera::Vec3 e{p.position[0] - m.positions[v][0], p.position[1] - m.positions[v][1],
                                 p.position[2] - m.positions[v][2]};
            const float dd = dot(e, e);
            if (dd < nearest) nearest = dd, nv = v;
        }
        const camera::Vec3 e{p.position[0] - m.positions[nv][0], p.position[1] - m.positions[nv][1],
                             p.position[2] - m.positions[nv][2]};
        EXPECT_GT(dot(e, m.normals[nv]), 0.0f) << "frame " << i << " is outside the lumen";
        minClearance = std::min(minClearance, std::sqrt(nearest));
        // A carina (where a branch leaves its parent) in view within 40 mm.
        for (const mesh::CenterlineBranch& b : tree.branches) {
            if (b.parent < 0 || b.points.empty()) continue;
            const camera::Vec3 c{b.points[0][0] - p.position[0], b.points[0][1] - p.position[1],
                                 b.points[0][2] - p.position[2]};
            if (norm(c) < 40.0f && angleDeg(c, p.forward) < halfFov) {
                ++carinaFrames;
                break;
            }
        }
        // The roll: up against the same survey's without it.
        rollDeg.push_back(angleDeg(unrolled[i].up, p.up));
        EXPECT_LT(angleDeg(unrolled[i].forward, p.forward), 1e-2f);
    }
    // Every branch entered: some eye within its stop distance (+ the wander) of its distal end.
    for (std::size_t b = 0; b < tree.branches.size(); ++b) {
        bool leaf = true;
        for (const auto& c : tree.branches) leaf &= c.parent != int(b);
        if (!leaf) continue;
        const mesh::CenterlineBranch& br = tree.branches[b];
        const camera::Vec3 end = br.points.back();
        float closest = 1e30f;
        for (const auto& p : poses)
            closest = std::min(closest, norm({p.position[0] - end[0], p.position[1] - end[1], p.position[2] - end[2]}));
        const float reach = nearMm + 3.0f + 3.0f * br.radii.back() + br.radii.back();
        EXPECT_LT(closest, reach + 3.0f) << br.name << " is not entered";
    }
    auto quantile = [](std::vector<float> v, double q) {
        std::sort(v.begin(), v.end());
        return v[static_cast<std::size_t>(q * double(v.size() - 1))];
    };
    const float carinaShare = float(carinaFrames) / float(frames);
    std::printf(
        "survey: eye off the centre (fraction of the radius) median %.2f, p90 %.2f; wall %.2f / %.2f / %.2f mm "
        "(p10 / median / p90); view from the branch's axis median %.0f deg, p90 %.0f deg; roll p90 %.0f deg; "
        "a carina in view in %.0f %% of frames; nearest vertex %.2f mm\n",
        quantile(offsetFraction, 0.5), quantile(offsetFraction, 0.9), quantile(wallMm, 0.1), quantile(wallMm, 0.5),
        quantile(wallMm, 0.9), quantile(turnDeg, 0.5), quantile(turnDeg, 0.9), quantile(rollDeg, 0.9),
        100 * carinaShare, minClearance);
    EXPECT_GT(minClearance, 1.5f * nearMm);
    EXPECT_GT(quantile(offsetFraction, 0.5), 0.2f) << "off the centre, close to the walls";
    EXPECT_GT(quantile(offsetFraction, 0.9), 0.35f);
    EXPECT_GT(quantile(turnDeg, 0.5), 12.0f) << "looking at the walls, not down the axis";
    EXPECT_LT(quantile(turnDeg, 0.9), 70.0f);
    EXPECT_GT(quantile(rollDeg, 0.9), 10.0f) << "the scope rolls";
    EXPECT_LE(quantile(rollDeg, 1.0), sc.path.surveyOptions.rollDeg + 0.01f);
    EXPECT_GT(carinaShare, 0.3f) << "carinas and orifices in view";
}

// Through the survey's legs the motion is continuous: twice the frames halve
// the largest step and the largest turn between frames (a jump anywhere
// would stay as large), and the pauses turn towards the next orifice
// gradually.
TEST(Camera, SurveyMovesContinuously) {
    const scene::Scene sc = scene::defaultScene();
    const scene::SceneAssets assets = scene::loadAssets(sc, 0, false);
    auto largest = [&](int frames) {
        const auto poses = scene::cameraPoses(sc, assets, frames);
        float maxStep = 0, maxTurn = 0;
        for (std::size_t i = 1; i < poses.size(); ++i) {
            const auto& a = poses[i - 1].position;
            const auto& b = poses[i].position;
            maxStep = std::max(maxStep, norm({b[0] - a[0], b[1] - a[1], b[2] - a[2]}));
            maxTurn = std::max(maxTurn, angleDeg(poses[i - 1].forward, poses[i].forward));
        }
        std::printf("survey of %d frames: largest step %.3f mm, largest turn %.3f deg\n", frames, maxStep, maxTurn);
        return std::pair{maxStep, maxTurn};
    };
    const auto [step1, turn1] = largest(1000);
    const auto [step2, turn2] = largest(2000);
    EXPECT_LT(step2, 0.6f * step1);
    EXPECT_LT(turn2, 0.6f * turn1);
    EXPECT_LT(step2, 2.5f);
}

TEST(Camera, SurveyRejectsBadOptionsAndAnEmptyTree) {
    camera::FlyThrough o;
    o.frames = 4;
    camera::Survey sv;
    EXPECT_THROW(camera::surveyTree({}, o, sv, 1.0f), InputError);
    mesh::Centerline tree;
    mesh::CenterlineBranch b;
    b.points = {{0, 0, 0}, {0, -10, 0}, {0, -20, 0}};
    b.radii = {5, 5, 5};
    tree.branches.push_back(b);
    EXPECT_EQ(camera::surveyTree(tree, o, sv, 1.0f).size(), 4u);
    sv.rollDeg = 120;
    EXPECT_THROW(camera::surveyTree(tree, o, sv, 1.0f), InputError);
    sv = {};
    sv.withdrawSpeed = 0.5f;
    EXPECT_THROW(camera::surveyTree(tree, o, sv, 1.0f), InputError);
}

TEST(Camera, FlyThroughWanderIsSeededAndValidated) {
    const auto line = helix();
    const std::vector<float> radii(line.size(), 8.0f);
    camera::FlyThrough o;
    o.frames = 30;
    o.wander = 0.4f;
    o.lookAroundDeg = 15;
    const auto a = camera::flyThrough(line, o, radii), b = camera::flyThrough(line, o, radii);
    o.seed = 2;
    const auto c = camera::flyThrough(line, o, radii);
    bool differs = false;
    for (std::size_t i = 0; i < a.size(); ++i) {
        EXPECT_EQ(a[i].position, b[i].position);
        EXPECT_EQ(a[i].forward, b[i].forward);
        differs = differs || a[i].position != c[i].position;
    }
    EXPECT_TRUE(differs);
    // The clearance wins over the fraction in a narrow lumen: R 2 mm, clearance 1.5 mm.
    o.wander = 0.9f;
    o.wallClearanceMm = 1.5f;
    const auto narrow = camera::flyThrough(line, o, std::vector<float>(line.size(), 2.0f));
    for (const auto& p : narrow) {
        std::size_t seg = 0;
        float t = 0;
        EXPECT_LE(distanceToPolyline(p.position, line, &seg, &t), 0.5f + 1e-3f);
    }
    for (float bad : {-0.1f, 0.95f, NAN}) {
        camera::FlyThrough w;
        w.wander = bad;
        try {
            camera::flyThrough(line, w, radii);
            ADD_FAILURE() << bad;
        } catch (const InputError& e) {
            EXPECT_EQ(e.subject(), "camera.path.wander");
        }
    }
    camera::FlyThrough w;
    w.lookAroundDeg = 90;
    EXPECT_THROW(camera::flyThrough(line, w), InputError);
}

// The scene keys camera.path.wander, look_around_deg, wall_clearance_mm,
// wander_period_mm and seed reach the fly-through; out of range, one error
// naming the key.
TEST(Camera, SceneKeysSetTheWanderingAndNameTheFieldWhenWrong) {
    const scene::Scene s = scene::parseScene(
        R"({"mesh": "tube", "camera": {"path": {"centerline": "auto", "wander": 0.5, "look_around_deg": 12,
            "wall_clearance_mm": 2, "wander_period_mm": 60, "seed": 7}}})",
        "s.json");
    EXPECT_EQ(s.path.fly.wander, 0.5f);
    EXPECT_EQ(s.path.fly.lookAroundDeg, 12.0f);
    EXPECT_EQ(s.path.fly.wallClearanceMm, 2.0f);
    EXPECT_EQ(s.path.fly.wanderPeriodMm, 60.0f);
    EXPECT_EQ(s.path.fly.seed, 7u);
    const scene::Scene d = scene::parseScene(R"({"mesh": "tube"})", "d.json");
    EXPECT_EQ(d.path.fly.wander, scene::defaultScene().path.fly.wander);
    for (const auto& [key, value] :
         {std::pair<std::string, std::string>{"wander", "2"}, {"look_around_deg", "-1"}, {"wall_clearance_mm", "-3"}}) {
        try {
            scene::parseScene(
                R"({"mesh": "tube", "camera": {"path": {"centerline": "auto", ")" + key + "\": " + value + "}}}",
                "bad.json");
            ADD_FAILURE() << key;
        } catch (const InputError& e) {
            EXPECT_EQ(e.subject(), "camera.path." + key);
            EXPECT_EQ(e.file(), "bad.json");
        }
    }
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
