// A raw CT airway surface (no UVs, no tangents) renders with the
// method's highlights directly in the procedural mode's object space; the
// modes that need UVs refuse it with one clear line. This file's wall seen
// from the lumen already faces the lumen (its normals and winding; lit from
// inside with "lit_side": "front"), so it needs no `mucosa mesh --flip`; a
// flipped copy renders the same with "lit_side": "back".
#include <gtest/gtest.h>

#include <fstream>
#include <sstream>

#include <fmt/format.h>

#include <mucosa/image/png.hpp>
#include <mucosa/mesh/io.hpp>
#include <mucosa/render/offscreen.hpp>

#include "render_test_support.hpp"
#include "test_support.hpp"

namespace mucosa {
namespace {

// Centroid of the vertices within a slab of the airway's long (y) axis.
mesh::Vec3 slabCentroid(const mesh::Mesh& m, float y0, float y1) {
    double s[3] = {0, 0, 0};
    int n = 0;
    for (const auto& p : m.positions)
        if (p[1] >= y0 && p[1] <= y1) {
            for (int k = 0; k < 3; ++k) s[k] += p[k];
            ++n;
        }
    return {static_cast<float>(s[0] / n), static_cast<float>(s[1] / n), static_cast<float>(s[2] / n)};
}

TEST(CtAirway, RawCtSurfaceRendersWithTheMethodsHighlightsInObjectSpace) {
    test::TempDir dir;
    const auto ct = test::testdata("airway/vh_m_airway_lumen.obj");
    const mesh::Mesh m = mesh::load(ct);
    ASSERT_FALSE(m.hasUvs());
    ASSERT_TRUE(m.hasNormals());
    // Inside the trachea (it runs along y, 504..660 mm): from 20 mm below its
    // top, looking 60 mm down its axis.
    const mesh::Vec3 eye = slabCentroid(m, 630, 640), target = slabCentroid(m, 570, 580);
    const std::string scene = fmt::format(
        // The paper's map and material and a camera that only exposes (as test::paperLook).
        R"({{"mesh": "{}", "mode": "procedural", "noise_space": "object", "resolution": [640, 480],
            "reflectance_map": {{"preset": "bronchial"}},
            "material": {{"noise_scale_mm": 12, "specular_strength": 0.8, "shininess": 40, "sheen": 0, "wrap": 0,
                          "base_color": [0.8, 0.45, 0.4]}},
            "light": {{"spread": 0}},
            "camera": {{"fov_deg": 100, "near_mm": 0.5, "far_mm": 200, "auto_peak": 0, "auto_key": 0.4,
                        "tone_curve": 0, "full_well": 0, "read_noise": 0, "softness_px": 0, "vignetting": 0, "mask": 0, "saturation": 1,
                        "pose": {{"position": [{}, {}, {}], "look_at": [{}, {}, {}], "up": [0, 0, 1]}}}}}})",
        ct.string(), eye[0], eye[1], eye[2], target[0], target[1], target[2]);
    std::ofstream(dir / "ct.json") << scene;
    auto r = test::runCli(fmt::format("render '{}' -o '{}'", (dir / "ct.json").string(), (dir / "ct.png").string()));
    ASSERT_EQ(r.exitCode, 0) << r.err;
    EXPECT_NE(r.out.find("no texture coordinates"), std::string::npos) << r.out;
    const image::Image8 img = image::to8(image::readPng(dir / "ct.png"));
    // The lumen fills the view (lit wall, no background) ...
    std::size_t lit = 0;
    for (int y = 0; y < img.height(); ++y)
        for (int x = 0; x < img.width(); ++x) lit += img.at(x, y, 0) + img.at(x, y, 1) + img.at(x, y, 2) > 30;
    EXPECT_GT(double(lit) / (img.width() * img.height()), 0.8);
    // ... with many small, ragged glints (the method), not one blob.
    const render::HighlightStats st = render::highlightStats(img, 170, 2);
    std::printf("CT airway, procedural object space: %d glints, %.0f px, area-weighted P^2/A %.1f\n", st.components,
                st.totalArea, st.weightedIsoperimetric);
    EXPECT_GT(st.components, 15);
    // Without noise (vertex-phong) the same view shows few highlights.
    r = test::runCli(fmt::format("render '{}' -o '{}' --mode vertex-phong", (dir / "ct.json").string(),
                                 (dir / "ct_phong.png").string()));
    ASSERT_EQ(r.exitCode, 0) << r.err;
    const render::HighlightStats phong =
        render::highlightStats(image::to8(image::readPng(dir / "ct_phong.png")), 170, 2);
    EXPECT_LT(phong.components * 5, st.components);
    if (std::getenv("MUCOSA_TEST_WRITE_IMAGES")) image::writePng(test::outputDir() / "ct_airway_procedural.png", img);

    // Flipped (normals away from the lumen), the same view lit from the back side is the same picture.
    r = test::runCli(fmt::format("mesh '{}' --flip -o '{}'", ct.string(), (dir / "flipped.glb").string()));
    ASSERT_EQ(r.exitCode, 0) << r.err;
    std::string flipped = scene;
    flipped.replace(flipped.find(ct.string()), ct.string().size(), (dir / "flipped.glb").string());
    flipped.replace(flipped.find("\"mode\""), 6, "\"lit_side\": \"back\", \"mode\"");
    std::ofstream(dir / "flipped.json") << flipped;
    r = test::runCli(
        fmt::format("render '{}' -o '{}'", (dir / "flipped.json").string(), (dir / "flipped.png").string()));
    ASSERT_EQ(r.exitCode, 0) << r.err;
    const image::Image8 back = image::to8(image::readPng(dir / "flipped.png"));
    std::size_t differ = 0;
    for (int y = 0; y < img.height(); ++y)
        for (int x = 0; x < img.width(); ++x)
            for (int c = 0; c < 3; ++c) differ += std::abs(img.at(x, y, c) - back.at(x, y, c)) > 2;
    EXPECT_LT(double(differ) / (img.width() * img.height()), 0.01);

    // The map needs texture coordinates: one line naming the mesh and a way out.
    r = test::runCli(
        fmt::format("render '{}' -o '{}' --mode noise", (dir / "ct.json").string(), (dir / "bad.png").string()));
    EXPECT_NE(r.exitCode, 0);
    EXPECT_NE(r.err.find("error: mesh in "), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("--noise-space object"), std::string::npos) << r.err;
    EXPECT_FALSE(std::filesystem::exists(dir / "bad.png"));
}

// The --flip trap: turned inside out, the CT airway's wall faces away from a
// camera inside it, which then sees the walls' unlit side. `mucosa render`
// says so in one line (naming lit_side and --orient lumen), and is silent when
// the lit side faces the camera: the file as it comes, the flipped one lit
// from the back, and the flipped one after `mucosa mesh --orient lumen`.
TEST(CtAirway, RenderWarnsOnceWhenTheCameraSeesBackFaces) {
    test::TempDir dir;
    const auto ct = test::testdata("airway/vh_m_airway_lumen.obj");
    const mesh::Mesh m = mesh::load(ct);
    const mesh::Vec3 eye = slabCentroid(m, 630, 640), target = slabCentroid(m, 570, 580);
    auto sceneFor = [&](const std::filesystem::path& mesh, const char* litSide) {
        return fmt::format(
            R"({{"mesh": "{}", "lit_side": "{}", "mode": "procedural", "noise_space": "object",
                "resolution": [160, 120], "camera": {{"fov_deg": 100, "near_mm": 0.5, "far_mm": 200,
                "pose": {{"position": [{}, {}, {}], "look_at": [{}, {}, {}], "up": [0, 0, 1]}}}}}})",
            mesh.string(), litSide, eye[0], eye[1], eye[2], target[0], target[1], target[2]);
    };
    auto r = test::runCli(fmt::format("mesh '{}' --flip -o '{}'", ct.string(), (dir / "flipped.glb").string()));
    ASSERT_EQ(r.exitCode, 0) << r.err;
    r = test::runCli(fmt::format("mesh '{}' --orient lumen -o '{}'", (dir / "flipped.glb").string(),
                                 (dir / "oriented.glb").string()));
    ASSERT_EQ(r.exitCode, 0) << r.err;
    auto warnings = [&](const std::filesystem::path& mesh, const char* litSide) {
        std::ofstream(dir / "s.json") << sceneFor(mesh, litSide);
        const auto out =
            test::runCli(fmt::format("render '{}' -o '{}'", (dir / "s.json").string(), (dir / "s.png").string()));
        EXPECT_EQ(out.exitCode, 0) << out.err;
        std::vector<std::string> lines;
        std::istringstream in(out.err);
        for (std::string l; std::getline(in, l);)
            if (l.find("back faces") != std::string::npos) lines.push_back(l);
        return lines;
    };
    const std::vector<std::string> flipped = warnings(dir / "flipped.glb", "front");
    ASSERT_EQ(flipped.size(), 1u);
    std::printf("%s\n", flipped[0].c_str());
    EXPECT_EQ(flipped[0].rfind("warning: ", 0), 0u);
    EXPECT_NE(flipped[0].find("lit_side"), std::string::npos);
    EXPECT_NE(flipped[0].find("--orient lumen"), std::string::npos);
    EXPECT_NE(flipped[0].find("100 %"), std::string::npos) << "all of this view is the wall's back";
    EXPECT_TRUE(warnings(ct, "front").empty());
    EXPECT_TRUE(warnings(dir / "flipped.glb", "back").empty());
    EXPECT_TRUE(warnings(dir / "oriented.glb", "front").empty());
}

}  // namespace
}  // namespace mucosa
