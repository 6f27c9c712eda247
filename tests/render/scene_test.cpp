// Scene files: a good one parses; bad ones give one clear error naming the field.
#include <gtest/gtest.h>

#include <fstream>

#include <mucosa/core/error.hpp>
#include <mucosa/scene/scene.hpp>

#include "test_support.hpp"

namespace mucosa {
namespace {

std::string subjectOf(const std::string& json) {
    try {
        scene::parseScene(json, "scene.json");
    } catch (const InputError& e) {
        EXPECT_EQ(e.file(), "scene.json");
        return e.subject();
    }
    return "<no error>";
}

TEST(RenderScene, FullSceneParses) {
    const scene::Scene s = scene::parseScene(R"({
      "mesh": "tube", "lit_side": "front", "filter": "linear", "mode": "vertex-phong",
      "reflectance_map": {"preset": "fine", "frequency": 32, "size": 256},
      "material": {"shininess": 80, "base_color": [0.7, 0.4, 0.4], "mucus_opacity": 0.3},
      "brdf": {"c0": 0.1, "c1": 0.9, "d1": -0.2},
      "light": {"intensity": 2, "spread": 2.5, "offset_mm": [2, 0, 0]},
      "camera": {"fov_deg": 100, "near_mm": 1, "far_mm": 300, "exposure_ev": 1.5, "mask": 2,
                 "path": {"poses": [{"position": [0, 0, 0], "look_at": [0, 0, -10]},
                                    {"position": [0, 0, -20], "forward": [0, 0, -1], "up": [0, 1, 0]}]}},
      "resolution": [320, 240], "frames": 12})",
                                             "dir/scene.json");
    EXPECT_EQ(s.mesh.kind, scene::MeshKind::Tube);
    EXPECT_EQ(s.mode, shading::Mode::VertexPhong);
    EXPECT_EQ(s.filter, shading::Filter::Linear);
    EXPECT_FLOAT_EQ(s.params[shading::Param::Shininess], 80.0f);
    EXPECT_FLOAT_EQ(s.params.color(shading::Param::BaseColor)[0], 0.7f);
    EXPECT_FLOAT_EQ(s.params[shading::Param::C0], 0.1f);
    EXPECT_FLOAT_EQ(s.params[shading::Param::LightSpread], 2.5f);
    EXPECT_FLOAT_EQ(s.params[shading::Param::ExposureEv], 1.5f);
    EXPECT_FLOAT_EQ(s.params[shading::Param::Mask], 2.0f);
    EXPECT_FLOAT_EQ(s.light.offset[0], 2.0f);
    EXPECT_DOUBLE_EQ(s.mapParams.noise.frequency, 32.0);
    EXPECT_EQ(s.mapParams.size, 256);
    EXPECT_EQ(s.path.kind, scene::PathKind::Poses);
    EXPECT_EQ(s.path.poses.size(), 2u);
    EXPECT_EQ(s.width, 320);
    EXPECT_EQ(s.frames, 12);
}

// Each kind's name parses back to the kind; other names are refused naming the field.
TEST(RenderScene, KindNamesRoundTripAndUnknownNamesAreRefused) {
    for (scene::MeshKind k : {scene::MeshKind::Phantom, scene::MeshKind::Tube, scene::MeshKind::File})
        EXPECT_EQ(scene::parseMeshKind(scene::meshKindName(k)), k) << scene::meshKindName(k);
    for (scene::PathKind k : {scene::PathKind::None, scene::PathKind::Poses, scene::PathKind::Centerline})
        EXPECT_EQ(scene::parsePathKind(scene::pathKindName(k)), k) << scene::pathKindName(k);
    EXPECT_EQ(scene::meshKindName(scene::MeshKind::File), "file");
    EXPECT_EQ(scene::pathKindName(scene::PathKind::Centerline), "centerline");
    try {
        (void)scene::parsePathKind("centreline", "camera.path", "s.json");
        ADD_FAILURE() << "accepted";
    } catch (const InputError& e) {
        EXPECT_EQ(e.subject(), "camera.path");
        EXPECT_EQ(e.file(), "s.json");
        EXPECT_NE(e.reason().find("known: none, poses, centerline"), std::string::npos) << e.what();
    }
    EXPECT_THROW((void)scene::parseMeshKind("sphere"), InputError);
    // The scene's keys set them.
    EXPECT_EQ(scene::parseScene(R"({"mesh": "phantom"})", "s.json").mesh.kind, scene::MeshKind::Phantom);
    EXPECT_EQ(scene::parseScene(R"({"mesh": {"tube": {}}})", "s.json").mesh.kind, scene::MeshKind::Tube);
    EXPECT_EQ(scene::parseScene(R"({"mesh": "tube"})", "s.json").path.kind, scene::PathKind::Centerline);
    EXPECT_EQ(scene::parseScene(
                  R"({"mesh": "tube", "camera": {"pose": {"position": [0, 0, 0], "forward": [0, 0, 1]}}})", "s.json")
                  .path.kind,
              scene::PathKind::None);
}

TEST(RenderScene, MapFileIsResolvedAgainstTheSceneFolder) {
    const scene::Scene s =
        scene::parseScene(R"({"mesh": "airway.glb", "reflectance_map": "maps/m.png"})", "/data/scenes/a.json");
    EXPECT_EQ(s.mesh.kind, scene::MeshKind::File);
    EXPECT_EQ(s.mesh.file, std::filesystem::path("/data/scenes/airway.glb"));
    EXPECT_EQ(*s.reflectanceMap, std::filesystem::path("/data/scenes/maps/m.png"));
}

TEST(RenderScene, BadScenesNameTheField) {
    EXPECT_EQ(subjectOf(R"({"mode": "noise"})"), "mesh");                                             // missing mesh
    EXPECT_EQ(subjectOf(R"({"mesh": 3})"), "mesh");                                                   // wrong type
    EXPECT_EQ(subjectOf(R"({"mesh": "tube", "mode": "shiny"})"), "mode");                             // unknown mode
    EXPECT_EQ(subjectOf(R"({"mesh": "tube", "mode": 2})"), "mode");                                   // wrong type
    EXPECT_EQ(subjectOf(R"({"mesh": "tube", "material": {"shininess": 0}})"), "material.shininess");  // range
    EXPECT_EQ(subjectOf(R"({"mesh": "tube", "material": {"shininess": "high"}})"), "material.shininess");
    EXPECT_EQ(subjectOf(R"({"mesh": "tube", "material": {"shinyness": 5}})"), "material.shinyness");  // typo
    EXPECT_EQ(subjectOf(R"({"mesh": "tube", "material": {"base_color": [1, 2]}})"), "material.base_color");
    EXPECT_EQ(subjectOf(R"({"mesh": "tube", "material": {"base_color": [1, 0, 2]}})"), "material.base_color");
    EXPECT_EQ(subjectOf(R"({"mesh": "tube", "light": {"intensity": -1}})"), "light.intensity");
    EXPECT_EQ(subjectOf(R"({"mesh": "tube", "camera": {"fov_deg": 200}})"), "camera.fov_deg");
    EXPECT_EQ(subjectOf(R"({"mesh": "tube", "camera": {"pose": {"position": [0, 0]}}})"), "camera.pose.position");
    EXPECT_EQ(subjectOf(R"({"mesh": "tube", "camera": {"pose": {"position": [0, 0, 0]}}})"), "camera.pose");
    EXPECT_EQ(subjectOf(R"({"mesh": "tube", "resolution": [0, 10]})"), "resolution[0]");
    EXPECT_EQ(subjectOf(R"({"mesh": "tube", "reflectance_map": {"preset": "velvet"}})"), "reflectance_map.preset");
    EXPECT_EQ(subjectOf(R"({"mesh": "tube", "reflectance_map": {"octaves": 99}})"), "reflectance_map.octaves");
    EXPECT_EQ(subjectOf(R"({"mesh": "tube", "noise_space": "screen"})"), "noise_space");
    EXPECT_EQ(subjectOf(R"({"mesh": "tube", "specular_aa": "yes"})"), "specular_aa");
    EXPECT_EQ(subjectOf(R"({"mesh": "tube", "material": {"noise_scale_mm": 0}})"), "material.noise_scale_mm");
    EXPECT_EQ(subjectOf(R"({"mesh": "tube", "colour": 1})"), "colour");  // unknown key
    EXPECT_EQ(subjectOf(R"({"mesh": "tube",)"), "JSON");
}

// One spelling (centerline); the British key is read for one release, with a
// warning naming it, and giving both is an error.
TEST(RenderScene, DeprecatedCentrelineKeyIsReadWithAWarning) {
    const scene::Scene us =
        scene::parseScene(R"({"mesh": "a.glb", "camera": {"path": {"centerline": "a.centerline.json"}}})", "/d/s.json");
    EXPECT_TRUE(us.warnings.empty());
    const scene::Scene uk =
        scene::parseScene(R"({"mesh": "a.glb", "camera": {"path": {"centreline": "a.centerline.json"}}})", "/d/s.json");
    EXPECT_EQ(uk.path.centerlineFile, us.path.centerlineFile);
    ASSERT_EQ(uk.warnings.size(), 1u);
    EXPECT_EQ(uk.warnings[0], "camera.path.centreline in /d/s.json: 'centreline' is deprecated, use 'centerline'");
    EXPECT_EQ(subjectOf(R"({"mesh": "tube", "camera": {"path": {"centerline": "auto", "centreline": "auto"}}})"),
              "camera.path.centreline");
    EXPECT_EQ(subjectOf(R"({"mesh": "tube", "camera": {"path": {"centreline": 3}}})"), "camera.path.centreline");

    test::TempDir dir;
    std::ofstream(dir / "tube.json") << R"({"mesh": "tube", "resolution": [64, 48],
                                          "camera": {"path": {"centreline": "auto"}}})";
    const auto r = test::runCli("render tube.json -o t.png --mode diffuse", dir.path());
    ASSERT_EQ(r.exitCode, 0) << r.err;
    EXPECT_NE(r.err.find("warning: camera.path.centreline in tube.json: 'centreline' is deprecated, use 'centerline'"),
              std::string::npos)
        << r.err;
}

TEST(RenderScene, CliReportsOneErrorLineNamingTheField) {
    test::TempDir dir;
    const auto scene = dir / "bad.json";
    std::ofstream(scene) << R"({"mesh": "tube", "material": {"shininess": 1e9}})";
    const auto r = test::runCli("render '" + scene.string() + "' -o '" + (dir / "out.png").string() + "'");
    EXPECT_EQ(r.exitCode, 1);
    EXPECT_NE(r.err.find("error: material.shininess in " + scene.string()), std::string::npos) << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
    EXPECT_FALSE(std::filesystem::exists(dir / "out.png"));

    const auto missing =
        test::runCli("render '" + (dir / "nope.json").string() + "' -o '" + (dir / "o.png").string() + "'");
    EXPECT_EQ(missing.exitCode, 1);
    EXPECT_NE(missing.err.find("error: scene file"), std::string::npos) << missing.err;

    const auto mode = test::runCli("render --mode glossy -o '" + (dir / "o.png").string() + "'");
    EXPECT_EQ(mode.exitCode, 1);
    EXPECT_NE(mode.err.find("error: --mode"), std::string::npos) << mode.err;
    for (const char* bad : {"--noise-space screen", "--specular-aa maybe"}) {
        const auto r2 = test::runCli(std::string("render ") + bad + " -o '" + (dir / "o.png").string() + "'");
        EXPECT_EQ(r2.exitCode, 1) << bad;
        EXPECT_NE(r2.err.find(std::string("error: ") + std::string(bad).substr(0, std::string(bad).find(' '))),
                  std::string::npos)
            << r2.err;
        EXPECT_EQ(std::count(r2.err.begin(), r2.err.end(), '\n'), 1) << r2.err;
        EXPECT_FALSE(std::filesystem::exists(dir / "o.png"));
    }
}

TEST(RenderScene, SetOverridesTheMapParametersTheProceduralModeReads) {
    scene::Scene s = scene::parseScene(R"({"mesh": "tube", "reflectance_map": "maps/m.png"})", "/d/scene.json");
    ASSERT_TRUE(s.reflectanceMap.has_value());
    scene::setMapParameter(s, "frequency", "32");
    scene::setMapParameter(s, "turbulence", "true");
    scene::setMapParameter(s, "octaves", "3");
    EXPECT_EQ(s.mapParams.noise.frequency, 32.0);
    EXPECT_TRUE(s.mapParams.noise.turbulence);
    EXPECT_EQ(s.mapParams.noise.octaves, 3);
    EXPECT_FALSE(s.reflectanceMap.has_value());  // generated from the parameters now
    const shading::FrameSetup f = scene::frameSetup(s, camera::lookAt({0, 0, 0}, {0, 0, -1}), 64, 48);
    EXPECT_EQ(f.procedural.noise.frequency, 32.0);
    EXPECT_EQ(f.procedural.noise.octaves, 3);
    scene::setMapParameter(s, "preset", "serosa");
    EXPECT_EQ(s.mapParams.noise.frequency, reflectance::findPreset("serosa").params.noise.frequency);
    for (const auto& [key, value, field] :
         std::vector<std::array<std::string, 3>>{{"octaves", "99", "--set reflectance_map.octaves"},
                                                 {"frequency", "-2", "--set reflectance_map.frequency"},
                                                 {"tileable", "3", "--set reflectance_map.tileable"},
                                                 {"colour", "1", "--set reflectance_map.colour"},
                                                 {"preset", "velvet", "--set reflectance_map.preset"}}) {
        try {
            scene::setMapParameter(s, key, value);
            ADD_FAILURE() << key << "=" << value << " was accepted";
        } catch (const InputError& e) {
            EXPECT_EQ(e.subject(), field) << e.what();
        }
    }
    test::TempDir dir;
    const auto r =
        test::runCli("render --mode procedural --set reflectance_map.octaves=99 -o '" + (dir / "o.png").string() + "'");
    EXPECT_EQ(r.exitCode, 1);
    EXPECT_NE(r.err.find("error: --set reflectance_map.octaves"), std::string::npos) << r.err;
    EXPECT_FALSE(std::filesystem::exists(dir / "o.png"));
}

// A scene's "reflectance_map" reads the map registry: the same range and the
// same words as `mucosa map` and sidecars, under the scene's field name.
TEST(SceneFile, MapParametersHaveTheRegistrysRanges) {
    try {
        scene::parseScene(R"({"mesh": "phantom", "reflectance_map": {"octaves": 33}})", "s.json");
        FAIL();
    } catch (const InputError& e) {
        EXPECT_STREQ(e.what(), "reflectance_map.octaves in s.json: must be in 1..32, got 33");
    }
    const scene::Scene s =
        scene::parseScene(R"({"mesh": "phantom", "reflectance_map": {"seed": 18446744073709551615}})", "s.json");
    EXPECT_EQ(s.mapParams.noise.seed, 18446744073709551615ull);
    EXPECT_THROW(scene::parseScene(R"({"mesh": "phantom", "reflectance_map": {"size": 16384}})", "s.json"), InputError);
    EXPECT_THROW(scene::parseScene(R"({"mesh": "phantom", "reflectance_map": {"bits": 16}})", "s.json"),
                 InputError);  // rendered maps are 8-bit
}

// "tissue" / --set tissue.<key>: the generated texture's parameters by name,
// over the patient's draw, kept when a variation is drawn later; a look file
// sets the centre the patients vary about and refuses anything else.
TEST(SceneFile, TissueParametersAndLookFiles) {
    scene::Scene s = scene::parseScene(R"({"mesh": "tube", "tissue": {"hue": 30, "vessel_contrast": 0.4}})", "s.json");
    EXPECT_EQ(scene::tissueParams(s).hue, 30);
    EXPECT_EQ(scene::tissueParams(s).vesselContrast, 0.4);
    EXPECT_EQ(scene::tissueParams(s).chroma, scene::defaultScene().appearance.tissue.chroma);
    scene::applyVariation(s, 7);  // the patient's tone and vessels, the file's hue and contrast
    EXPECT_EQ(scene::tissueParams(s).hue, 30);
    EXPECT_EQ(scene::tissueParams(s).vesselContrast, 0.4);
    EXPECT_EQ(scene::tissueParams(s).vesselDensity, s.appearance.tissue.vesselDensity);
    EXPECT_NE(s.appearance.tissue.vesselDensity, scene::defaultScene().appearance.tissue.vesselDensity);
    EXPECT_EQ(subjectOf(R"({"mesh": "tube", "tissue": {"hue": 400}})"), "tissue.hue");
    EXPECT_EQ(subjectOf(R"({"mesh": "tube", "tissue": {"vessels": 1}})"), "tissue.vessels");
    EXPECT_EQ(subjectOf(R"({"mesh": "tube", "tissue": {"hue": "red"}})"), "tissue.hue");
    EXPECT_EQ(subjectOf(R"({"mesh": "tube", "tissue": 3})"), "tissue");

    test::TempDir dir;
    const std::filesystem::path look = dir / "look.json";
    std::ofstream(look) << R"({"tissue": {"chroma": 20}, "camera": {"saturation": 1.1}, "material": {"sheen": 0.3},
                               "light": {"spread": 1.5}, "reflectance_map": {"frequency": 8}})";
    scene::Scene t = scene::defaultScene();
    scene::applyLook(t, look);
    EXPECT_EQ(scene::tissueParams(t).chroma, 20);
    EXPECT_FLOAT_EQ(t.params[shading::Param::Saturation], 1.1f);
    EXPECT_FLOAT_EQ(t.params[shading::Param::SheenStrength], 0.3f);
    EXPECT_FLOAT_EQ(t.params[shading::Param::LightSpread], 1.5f);
    EXPECT_EQ(t.mapParams.noise.frequency, 8);
    // A patient drawn with the look varies about it: the mucus and the
    // scope's factors scale the look's values, the tissue's draw moves the
    // look's chroma by its own difference from the default look.
    scene::applyVariation(t, 3);
    const scene::Scene plain3 = [] {
        scene::Scene p = scene::defaultScene();
        scene::applyVariation(p, 3);
        return p;
    }();
    EXPECT_FLOAT_EQ(t.params[shading::Param::SheenStrength], 0.3f);  // not varied
    EXPECT_NEAR(scene::tissueParams(t).chroma,
                20 + plain3.appearance.tissue.chroma - scene::defaultScene().appearance.tissue.chroma, 1e-9);
    // The order does not matter: the variation first, then the look.
    scene::Scene u = scene::defaultScene();
    std::ofstream(look) << R"({"camera": {"softness_px": 0.5, "exposure_ev": 1}, "tissue": {"vessel_density": 2}})";
    scene::applyVariation(u, 3);
    scene::applyLook(u, look);
    scene::Scene v = scene::defaultScene();
    scene::applyLook(v, look);
    scene::applyVariation(v, 3);
    const float scope =
        plain3.params[shading::Param::Softness] / scene::defaultScene().params[shading::Param::Softness];
    for (const scene::Scene* w : {&u, &v}) {
        EXPECT_NEAR(w->params[shading::Param::Softness], 0.5f * scope, 1e-6);
        EXPECT_NEAR(w->params[shading::Param::ExposureEv], 1.0 + plain3.appearance.exposureEv, 1e-6);
        EXPECT_NEAR(scene::tissueParams(*w).vesselDensity, 2 * plain3.appearance.tissue.vesselDensity, 1e-9);
    }
    std::ofstream(look) << R"({"tissue": {"chroma": 20}, "camera": {"saturation": 1.1}, "material": {"sheen": 0.3},
                               "light": {"spread": 1.5}, "reflectance_map": {"frequency": 8}})";
    // A look file stands for the default scene where a scene file is expected.
    EXPECT_EQ(scene::tissueParams(scene::loadSceneOrLook(look)).chroma, 20);
    // Only the look's objects: a mesh or a path in a look is refused, naming it.
    std::ofstream(look) << R"({"camera": {"saturation": 1.1}, "frames": 3})";
    try {
        scene::applyLook(t, look);
        FAIL() << "a look with frames was read";
    } catch (const InputError& e) {
        EXPECT_EQ(e.subject(), "frames");
        EXPECT_EQ(e.file(), look.string());
    }
    std::ofstream(look) << R"({"camera": {"fov_deg": 90}})";
    EXPECT_THROW(scene::applyLook(t, look), InputError);
}

}  // namespace
}  // namespace mucosa
