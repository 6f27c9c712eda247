// What a scene loads: a mesh file given as the scene, the fly-through of a
// mesh file (a centerline beside it or computed from its shape), files the
// scene names that are missing (one line naming the field), and where the
// default fly-through stops (clear of the wall that closes a blind bronchus).
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <limits>
#include <optional>

#include <fmt/format.h>

#include <mucosa/core/error.hpp>
#include <mucosa/mesh/centerline.hpp>
#include <mucosa/mesh/io.hpp>
#include <mucosa/scene/scene.hpp>

#include "test_support.hpp"

namespace mucosa {
namespace {

using mesh::Vec3;

Vec3 sub(const Vec3& a, const Vec3& b) {
    return {a[0] - b[0], a[1] - b[1], a[2] - b[2]};
}
Vec3 cross(const Vec3& a, const Vec3& b) {
    return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}
double dot(const Vec3& a, const Vec3& b) {
    return double(a[0]) * b[0] + double(a[1]) * b[1] + double(a[2]) * b[2];
}

// Distance along the unit ray (o, d) to the nearest triangle of `m` (either
// side; Moeller & Trumbore 1997), or infinity.
double rayHit(const mesh::Mesh& m, const Vec3& o, const Vec3& d) {
    double best = std::numeric_limits<double>::infinity();
    for (std::size_t t = 0; t + 2 < m.indices.size(); t += 3) {
        const Vec3& a = m.positions[m.indices[t]];
        const Vec3 e1 = sub(m.positions[m.indices[t + 1]], a), e2 = sub(m.positions[m.indices[t + 2]], a);
        const Vec3 p = cross(d, e2);
        const double det = dot(e1, p);
        if (std::abs(det) < 1e-12) continue;
        const Vec3 s = sub(o, a);
        const double u = dot(s, p) / det;
        if (u < 0 || u > 1) continue;
        const Vec3 q = cross(s, e1);
        const double v = dot(d, q) / det;
        if (v < 0 || u + v > 1) continue;
        const double dist = dot(e2, q) / det;
        if (dist > 0 && dist < best) best = dist;
    }
    return best;
}

Vec3 unit(const Vec3& v) {
    const double n = std::sqrt(dot(v, v));
    return {static_cast<float>(v[0] / n), static_cast<float>(v[1] / n), static_cast<float>(v[2] / n)};
}

// The wall straight ahead of the last pose of a scene's fly-through (mm).
double wallAheadOfTheLastPose(const scene::Scene& s, const scene::SceneAssets& a, int frames) {
    const camera::Pose last = scene::cameraPoses(s, a, frames).back();
    return rayHit(a.mesh, last.position, unit(last.forward));
}

// Nearest mesh vertex to p (mm).
double nearestVertex(const mesh::Mesh& m, const Vec3& p) {
    double best = std::numeric_limits<double>::infinity();
    for (const Vec3& q : m.positions) best = std::min(best, dot(sub(q, p), sub(q, p)));
    return std::sqrt(best);
}

std::string ctScene(const std::filesystem::path& mesh, const std::string& extra = "") {
    return fmt::format(R"({{"mesh": "{}", "mode": "procedural", "noise_space": "object"{}}})", mesh.string(), extra);
}

TEST(SceneAssets, DefaultFlyThroughEndsClearOfTheWallAhead) {
    scene::Scene s = scene::defaultScene();
    s.path.survey = false;  // one path (route "path"); the survey's leaf stops: SurveyVisitsEveryBranch...
    const scene::SceneAssets a = scene::loadAssets(s, 0, false);
    ASSERT_GT(a.centerlineEndRadius, 0.0f);
    const int frames = s.path.fly.frames;
    // The flight stops the near plane + the end's radius + 3 mm short of the
    // end, so the wall closing the bronchus ahead is at least that far.
    const double clear = s.lens.nearMm + a.centerlineEndRadius + 3.0;
    const double ahead = wallAheadOfTheLastPose(s, a, frames);
    std::printf("phantom: end radius %.2f mm; wall %.2f mm ahead of the last pose (clear: %.2f)\n",
                a.centerlineEndRadius, ahead, clear);
    EXPECT_GE(ahead, clear);
    EXPECT_LT(ahead, 60.0) << "the ray must hit the bronchus' end, not leave the mesh";
    // Flying to the very end (stop_mm 0), the last frame is pressed into it.
    s.path.stopMm = 0.0f;
    const double pressed = wallAheadOfTheLastPose(s, a, frames);
    std::printf("phantom, stop_mm 0: wall %.2f mm ahead\n", pressed);
    EXPECT_LT(pressed, clear);
}

// A mesh file flies along the centerline its shape gives when there is no
// file beside it: the real CT airway, down the trachea, inside the lumen,
// stopping clear of the wall ahead.
TEST(SceneAssets, MeshFileWithoutACenterlineFliesAlongOneComputedFromItsShape) {
    test::TempDir dir;
    const auto ct = test::testdata("airway/vh_m_airway_lumen.obj");
    std::ofstream(dir / "ct.json") << ctScene(ct, R"(, "camera": {"path": {"centerline": "auto", "route": "path"}})");
    const scene::Scene s = scene::loadScene(dir / "ct.json");
    ASSERT_EQ(s.path.kind, scene::PathKind::Centerline);
    ASSERT_FALSE(s.path.survey);
    ASSERT_TRUE(s.path.centerlineFile.empty());
    const scene::SceneAssets a = scene::loadAssets(s, 0, false);
    bool noted = false;
    for (const std::string& n : a.notes) noted |= n.find("centerline: computed from the mesh") != std::string::npos;
    EXPECT_TRUE(noted);
    ASSERT_GE(a.centerline.size(), 10u);
    EXPECT_GT(camera::pathLength(a.centerline), 80.0f);  // the trachea is ~150 mm long
    EXPECT_GT(a.centerline.front()[1], a.centerline.back()[1] + 50.0f) << "from the top, down the airway (+Y up)";
    // Inside the lumen: every point is well away from the wall.
    double closest = std::numeric_limits<double>::infinity();
    for (const Vec3& p : a.centerline) closest = std::min(closest, nearestVertex(a.mesh, p));
    std::printf("CT airway: computed centerline %zu points, %.0f mm, end radius %.1f mm, %.1f mm from the wall\n",
                a.centerline.size(), camera::pathLength(a.centerline), a.centerlineEndRadius, closest);
    EXPECT_GT(closest, 2.0);
    const auto poses = scene::cameraPoses(s, a, 30);
    EXPECT_LT(poses.front().forward[1], -0.7f) << "looking down the trachea";
    const double ahead = wallAheadOfTheLastPose(s, a, 30);
    EXPECT_GE(ahead, s.lens.nearMm + a.centerlineEndRadius + 3.0);
}

// A centerline beside the mesh is used before computing one: <stem>.centerline.json
// first, else airway.centerline.json (what mucosa phantom writes).
TEST(SceneAssets, MeshFileFliesAlongTheCenterlineBesideIt) {
    test::TempDir dir;
    auto r = test::runCli("phantom -q --generations 1 --resolution 1 -o '" + (dir / "airway.glb").string() + "'");
    ASSERT_EQ(r.exitCode, 0) << r.err;
    const mesh::Centerline c = mesh::readCenterlineJson(dir / "airway.centerline.json");
    ASSERT_GE(c.branches.size(), 3u);
    std::filesystem::copy_file(dir / "airway.glb", dir / "lung.glb");
    std::ofstream(dir / "lung.json") << R"({"mesh": "lung.glb"})";
    scene::SceneAssets a = scene::loadAssets(scene::loadScene(dir / "lung.json"), 0, false);
    EXPECT_NE(a.notes.back().find("airway.centerline.json (beside the mesh)"), std::string::npos) << a.notes.back();
    // The longest root-to-leaf path of the file, not the trachea alone.
    EXPECT_GT(a.centerline.size(), c.branches[0].points.size());
    EXPECT_EQ(a.centerline.front(), c.branches[0].points.front());
    // <stem>.centerline.json wins: here the trachea alone.
    mesh::Centerline trachea = c;
    trachea.branches.resize(1);
    mesh::writeCenterlineJson(trachea, dir / "lung.centerline.json");
    a = scene::loadAssets(scene::loadScene(dir / "lung.json"), 0, false);
    EXPECT_NE(a.notes.back().find("lung.centerline.json (beside the mesh)"), std::string::npos) << a.notes.back();
    EXPECT_EQ(a.centerline, c.branches[0].points);
    EXPECT_EQ(a.centerlineEndRadius, c.branches[0].radii.back());
}

// `mucosa render mesh.obj`: the default scene with that mesh, framed by its
// centerline; a file that is neither a mesh nor JSON is one JSON error line.
TEST(SceneAssets, MeshFileGivenAsTheSceneIsTheDefaultSceneWithThatMesh) {
    const auto ct = test::testdata("airway/vh_m_airway_lumen.obj");
    const scene::Scene s = scene::loadScene(ct);
    EXPECT_EQ(s.mesh.kind, scene::MeshKind::File);
    EXPECT_EQ(s.mesh.file, ct);
    EXPECT_EQ(s.path.kind, scene::PathKind::Centerline);
    EXPECT_EQ(s.mode, scene::defaultScene().mode);
    EXPECT_TRUE(mesh::isMeshFile("a.OBJ"));
    for (const char* f : {"a.ply", "a.stl", "a.gltf", "a.glb"}) EXPECT_TRUE(mesh::isMeshFile(f)) << f;
    EXPECT_FALSE(mesh::isMeshFile("scene.json"));
    EXPECT_FALSE(mesh::isMeshFile("noextension"));

    test::TempDir dir;
    auto r = test::runCli(fmt::format("render '{}' -o '{}' --mode procedural --noise-space object --size 96x72",
                                      ct.string(), (dir / "ct.png").string()));
    ASSERT_EQ(r.exitCode, 0) << r.err;
    EXPECT_TRUE(std::filesystem::exists(dir / "ct.png"));
    EXPECT_NE(r.out.find("centerline: computed from the mesh"), std::string::npos) << r.out;
    // Without UVs the default mode says how to render it, in one line.
    r = test::runCli(fmt::format("render '{}' -o '{}'", ct.string(), (dir / "noise.png").string()));
    EXPECT_EQ(r.exitCode, 1);
    EXPECT_EQ(r.err.rfind("error: mesh in " + ct.string() + ": has no texture coordinates", 0), 0u) << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
    // Not a mesh extension: read as a scene, and not JSON.
    std::ofstream(dir / "notes.txt") << "v 0 0 0\n";
    r = test::runCli(fmt::format("render '{}' -o '{}'", (dir / "notes.txt").string(), (dir / "t.png").string()));
    EXPECT_EQ(r.exitCode, 1);
    EXPECT_EQ(r.err.rfind("error: " + (dir / "notes.txt").string() + ":1:1: JSON: ", 0), 0u) << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
}

// A file the scene names that is missing: one InputError naming the field and
// the scene, and the file as the scene wrote it.
TEST(SceneAssets, MissingFilesNameTheSceneField) {
    test::TempDir dir;
    struct Case {
        const char* field;
        const char* scene;
        const char* shown;
    };
    const Case cases[] = {
        {"diffuse", R"({"mesh": "tube", "diffuse": "textures/x.png"})", "textures/x.png"},
        {"reflectance_map", R"({"mesh": "tube", "reflectance_map": "maps/m.png"})", "maps/m.png"},
        {"mesh", R"({"mesh": "meshes/airway.glb"})", "meshes/airway.glb"},
        {"camera.path.centerline", R"({"mesh": "tube", "camera": {"path": {"centerline": "c.json"}}})", "c.json"},
    };
    for (const Case& c : cases) {
        std::ofstream(dir / "scene.json") << c.scene;
        try {
            (void)scene::loadAssets(scene::loadScene(dir / "scene.json"), 0, true);
            ADD_FAILURE() << c.field << " was accepted";
        } catch (const InputError& e) {
            EXPECT_EQ(e.subject(), c.field);
            EXPECT_EQ(e.file(), (dir / "scene.json").string());
            EXPECT_EQ(e.reason(), std::string(c.shown) + " does not exist");
        }
    }
    std::ofstream(dir / "scene.json") << R"({"mesh": "tube", "diffuse": "textures/x.png"})";
    const auto r = test::runCli("render scene.json -o out.png", dir.path());
    EXPECT_EQ(r.exitCode, 1);
    EXPECT_EQ(r.err, "error: diffuse in scene.json: textures/x.png does not exist\n");
    EXPECT_FALSE(std::filesystem::exists(dir / "out.png"));
}

}  // namespace
}  // namespace mucosa
