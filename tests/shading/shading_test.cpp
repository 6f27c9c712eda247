// The shading model's equations (docs/theory.md, "Shading model") and the
// parameter registry.
#include <gtest/gtest.h>

#include <cmath>
#include <set>

#include <mucosa/camera/camera.hpp>
#include <mucosa/core/error.hpp>
#include <mucosa/mesh/primitives.hpp>
#include <mucosa/reflectance/map.hpp>
#include <mucosa/reflectance/normal_map.hpp>
#include <mucosa/shading/params.hpp>
#include <mucosa/shading/reference.hpp>

#include "shading/glsl.hpp"

namespace mucosa {
namespace {

using namespace shading::glsl;

TEST(ShadingModel, BrdfCubicsAreThePapersEquations) {
    const vec4 c(0.1f, 0.7f, -0.2f, 0.05f);
    const vec3 d(-0.3f, 0.1f, 0.02f);
    for (float g : {0.0f, 0.3f, 0.77f, 1.0f}) {
        EXPECT_NEAR(brdfRho(g, c), 0.1f + 0.7f * g - 0.2f * g * g + 0.05f * g * g * g, 1e-6f);     // eq. 9
        EXPECT_NEAR(depthDelta(g, d), 1.0f - 0.3f * g + 0.1f * g * g + 0.02f * g * g * g, 1e-6f);  // eq. 10
    }
    EXPECT_FLOAT_EQ(depthRatio(50.0f, 10.0f, 90.0f), 0.5f);
    EXPECT_FLOAT_EQ(depthRatio(500.0f, 10.0f, 90.0f), 1.0f);
}

TEST(ShadingModel, PhongLobePeaksOnTheMirrorDirection) {
    const vec3 N(0, 0, 1), L = normalize(vec3(1, 0, 1)), V = normalize(vec3(-1, 0, 1));
    EXPECT_NEAR(phongLobe(N, L, V, 50.0f), 1.0f, 1e-5f);
    EXPECT_LT(phongLobe(N, L, normalize(vec3(-1, 0.3f, 1)), 50.0f), 0.5f);
    EXPECT_EQ(phongLobe(N, L, L * -1.0f, 50.0f), 0.0f);
}

TEST(ShadingModel, DecodedMapNormalRoundTripsAndBumpScaleTilts) {
    const std::array<double, 3> n = {0.3, -0.2, std::sqrt(1 - 0.13)};
    const auto rgb = reflectance::encode8(n);
    const vec3 d = decodeReflectanceNormal(vec3(rgb[0], rgb[1], rgb[2]) / 255.0f, 1.0f);
    EXPECT_NEAR(d.x, 0.3f, 0.01f);
    EXPECT_NEAR(d.y, -0.2f, 0.01f);
    EXPECT_NEAR(length(d), 1.0f, 1e-5f);
    EXPECT_NEAR(decodeReflectanceNormal(vec3(rgb[0], rgb[1], rgb[2]) / 255.0f, 0.0f).z, 1.0f, 1e-6f);
    // A back-facing texel (blue < 0.5) gives a finite normal, not NaN.
    const vec3 bad = decodeReflectanceNormal(vec3(0.5f, 0.5f, 0.2f), 1.0f);
    EXPECT_TRUE(std::isfinite(bad.x) && std::isfinite(bad.z));
}

TEST(ShadingModel, TangentSpaceIsTheRowsTBN) {
    const vec3 T(0, 1, 0), B(0, 0, 1), N(1, 0, 0);
    const vec3 v = toTangentSpace(vec3(2, 3, 4), T, B, N);
    EXPECT_EQ(v, vec3(3, 4, 2));
}

TEST(ShadingModel, HighlightTextureIsThePhongLobeAroundItsCentre) {
    const image::Image8 img = shading::highlightSphereMap(64, 40.0f);
    EXPECT_GE(img.at(32, 32), 230);  // texel centres sit half a texel off the pole
    EXPECT_EQ(img.at(0, 0), 0);
    EXPECT_LT(img.at(40, 32), img.at(34, 32));
}

TEST(ParameterRegistry, DefaultsAreInRangeAndNamesUnique) {
    std::set<std::string> names;
    for (const auto& p : shading::registry()) {
        EXPECT_TRUE(names.insert(std::string(p.name)).second) << p.name;
        for (int c = 0; c < p.components; ++c) {
            EXPECT_GE(p.defaults[c], p.min) << p.name;
            EXPECT_LE(p.defaults[c], p.max) << p.name;
        }
        EXPECT_FALSE(p.description.empty());
        EXPECT_TRUE(p.group == "material" || p.group == "brdf" || p.group == "light" || p.group == "camera") << p.name;
    }
    EXPECT_EQ(names.size(), shading::kParamCount);
    // The seven parameters the paper fits (eq. 8-11).
    int fittable = 0;
    for (const auto& p : shading::registry()) fittable += p.fittable;
    EXPECT_EQ(fittable, 7);
}

TEST(ParameterRegistry, OutOfRangeValuesNameTheField) {
    shading::ParamSet p;
    try {
        p.set(shading::Param::Shininess, 0.0f, "s.json");
        FAIL();
    } catch (const InputError& e) {
        EXPECT_EQ(e.subject(), "material.shininess");
        EXPECT_EQ(e.file(), "s.json");
    }
    EXPECT_THROW(p.set(shading::Param::Ambient, NAN), InputError);
    EXPECT_THROW(p.setColor(shading::Param::BaseColor, {0.5f, 2.0f, 0.5f}), InputError);
    EXPECT_THROW(shading::parseMode("glossy"), InputError);
    EXPECT_EQ(shading::parseMode("multitexture"), shading::Mode::Multitexture);
}

TEST(ModeTable, RowsAreInModeOrderWithUniqueNamesThatParseBack) {
    std::set<std::string_view> names;
    ASSERT_EQ(shading::modes().size(), static_cast<std::size_t>(shading::kModeCount));
    for (std::size_t i = 0; i < shading::modes().size(); ++i) {
        const shading::ModeInfo& m = shading::modes()[i];
        EXPECT_EQ(static_cast<std::size_t>(m.id), i);
        EXPECT_TRUE(names.insert(m.name).second) << m.name;
        EXPECT_EQ(shading::parseMode(m.name), m.id);
        EXPECT_FALSE(m.description.empty());
        // Anything that samples the map by UV needs UVs; procedural modes need them only in texture space.
        if (m.readsMap) {
            EXPECT_EQ(m.uvs, shading::UvNeed::Always) << m.name;
        }
        if (m.procedural) {
            EXPECT_EQ(m.uvs, shading::UvNeed::InTextureSpace) << m.name;
        }
    }
    EXPECT_NE(shading::modeList().find("procedural-normals"), std::string::npos);
}

// The table is what each mode does: swapping the reflectance map (flat for a
// bumpy one) or the subject texture (white for red) changes the reference's
// frame exactly in the modes whose row says they read it.
TEST(ModeTable, EachModeReadsExactlyTheTexturesItsRowNames) {
    const mesh::Mesh sphere = mesh::makeSphere(10.0f, 64, 32);
    reflectance::MapParams mp = reflectance::findPreset("bronchial").params;
    mp.size = 128;
    const image::Image8 bumpy =
        reflectance::encodeNormals8(reflectance::heightField(mp), mp.strength * 4, reflectance::Edges::Wrap);
    // Mid grey under the light so that nothing clips; the alternative is red.
    image::Image8 grey(8, 8, 3), red(8, 8, 3);
    for (int y = 0; y < 8; ++y)
        for (int x = 0; x < 8; ++x) {
            for (int c = 0; c < 3; ++c) grey.at(x, y, c) = 100;
            red.at(x, y, 0) = 200;
        }
    const camera::Pose pose = camera::lookAt({0, 0, 40}, {0, 0, 0});
    for (const shading::ModeInfo& m : shading::modes()) {
        if (m.readsHighlight) continue;  // the generated highlight texture: see HighlightTextureIsThePhongLobe...
        shading::FrameSetup f;
        f.width = f.height = 64;
        f.view = camera::viewMatrix(pose);
        f.projection = camera::projectionMatrix(camera::Lens{}, f.width, f.height);
        f.eye = f.light = {0, 0, 40};
        f.mode = m.id;
        // The paper's material under a camera that only exposes (1 EV: the
        // lamp's 0.25 at 40 mm to mid grey): what is sampled shows unclipped.
        using P = shading::Param;
        f.params.set(P::SpecularStrength, 0.8f);
        f.params.set(P::Shininess, 40.0f);
        shading::setCameraIdentity(f.params);
        f.params.set(P::ExposureEv, 1.0f);
        shading::Textures plain;
        plain.diffuse = {&grey, shading::Filter::Linear, shading::Wrap::Repeat};
        shading::Textures withMap = plain, withDiffuse = plain;
        withMap.reflectance = {&bumpy, shading::Filter::Linear, shading::Wrap::Repeat};
        withDiffuse.diffuse = {&red, shading::Filter::Linear, shading::Wrap::Repeat};
        const image::Image8 a = shading::renderReference(sphere, f, plain);
        const bool mapChanges = !(shading::renderReference(sphere, f, withMap) == a);
        const bool diffuseChanges = !(shading::renderReference(sphere, f, withDiffuse) == a);
        EXPECT_EQ(mapChanges, m.readsMap) << m.name;
        EXPECT_EQ(diffuseChanges, m.readsDiffuse) << m.name;
    }
}

}  // namespace
}  // namespace mucosa
