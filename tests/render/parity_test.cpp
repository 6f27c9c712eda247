// GL/C++ parity: the GPU path and the C++ reference (both
// shaders/common_shading.glsl) render analytic scenes; max abs error <= 2/255
// per channel on >= 99.9 % of pixels.
#include <gtest/gtest.h>

#include <fmt/format.h>

#include <mucosa/camera/camera.hpp>
#include <mucosa/mesh/primitives.hpp>
#include <mucosa/reflectance/map.hpp>
#include <mucosa/reflectance/normal_map.hpp>
#include <mucosa/render/context.hpp>
#include <mucosa/render/renderer.hpp>
#include <mucosa/shading/reference.hpp>
#include <mucosa/shading/scatter.hpp>

#include "render_test_support.hpp"

namespace mucosa {
namespace {

using shading::Filter;
using shading::Mode;
using shading::Wrap;

image::Image8 testMap(int size, const char* preset) {
    reflectance::MapParams p = reflectance::findPreset(preset).params;
    p.size = size;
    const image::ImageF h = reflectance::heightField(p);
    return reflectance::encodeNormals8(h, p.strength, reflectance::Edges::Wrap);
}

image::Image8 testDiffuse(int size) {
    // A soft two-colour pattern, so the diffuse texture's sampling is exercised.
    image::Image8 img(size, size, 3);
    for (int y = 0; y < size; ++y)
        for (int x = 0; x < size; ++x) {
            const bool odd = ((x * 8 / size) + (y * 8 / size)) % 2;
            img.at(x, y, 0) = odd ? 230 : 190;
            img.at(x, y, 1) = odd ? 150 : 110;
            img.at(x, y, 2) = odd ? 140 : 120;
        }
    return img;
}

struct Scene {
    mesh::Mesh mesh;
    shading::FrameSetup frame;
};

shading::FrameSetup frameFor(const camera::Pose& pose, int w, int h, Mode mode) {
    shading::FrameSetup f;
    camera::Lens lens;
    lens.fovDeg = 70.0f;
    lens.nearMm = 1.0f;
    lens.farMm = 200.0f;
    f.view = camera::viewMatrix(pose);
    f.projection = camera::projectionMatrix(lens, w, h);
    f.eye = pose.position;
    f.light = camera::lightPosition(pose, camera::TipLight{{3.0f, 2.0f, 0.0f}});
    f.mode = mode;
    f.width = w;
    f.height = h;
    return f;
}

struct Parity {
    image::Image8 gl, ref;
    test::DiffStats stats;
};

Parity renderBoth(const mesh::Mesh& m, const shading::FrameSetup& f, const image::Image8& map,
                  const image::Image8& diffuse) {
    test::glContext();
    render::Renderer r;
    r.setMesh(m);
    r.setTexture(render::TextureSlot::Diffuse, diffuse, Filter::Nearest, Wrap::Repeat);
    r.setTexture(render::TextureSlot::Reflectance, map, Filter::Nearest, Wrap::Repeat);
    const image::Image8 hl =
        shading::highlightSphereMap(shading::kHighlightTextureSize, f.params[shading::Param::Shininess]);
    r.setTexture(render::TextureSlot::Highlight, hl, Filter::Nearest, Wrap::Clamp);
    render::Framebuffer fb(f.width, f.height);
    fb.bind();
    r.draw(f);
    Parity p;
    p.gl = fb.readRgb();
    shading::Textures t;
    t.diffuse = {&diffuse, Filter::Nearest, Wrap::Repeat};
    t.reflectance = {&map, Filter::Nearest, Wrap::Repeat};
    t.highlight = {&hl, Filter::Nearest, Wrap::Clamp};
    p.ref = shading::renderReference(m, f, t);
    p.stats = test::diff(p.gl, p.ref, 2);
    return p;
}

void expectParity(const Parity& p, const std::string& name) {
    std::printf("%s: max diff %d/255, %.4f%% of pixels over 2/255, mean abs %.4f\n", name.c_str(), p.stats.maxDiff,
                100.0 * p.stats.fractionOver, p.stats.meanAbs);
    EXPECT_LE(p.stats.fractionOver, 0.001) << name;
    // Not a trivially empty frame: most of the view is covered.
    std::size_t lit = 0;
    for (int y = 0; y < p.gl.height(); ++y)
        for (int x = 0; x < p.gl.width(); ++x)
            if (p.gl.at(x, y, 0) + p.gl.at(x, y, 1) + p.gl.at(x, y, 2) > 0) ++lit;
    EXPECT_GT(double(lit) / (p.gl.width() * p.gl.height()), 0.2) << name;
    if (p.stats.fractionOver > 0.001 || std::getenv("MUCOSA_TEST_WRITE_IMAGES"))
        test::writeComparison(name, p.gl, p.ref);
}

TEST(RenderParity, FlatQuadWithKnownMapMatchesReferenceInEveryMode) {
    const mesh::Mesh quad = mesh::makeQuad(40.0f, 8);
    const image::Image8 map = testMap(256, "bronchial");
    const image::Image8 diffuse = testDiffuse(64);
    for (int mode = 0; mode < shading::kModeCount; ++mode) {
        shading::FrameSetup f =
            frameFor(camera::lookAt({6.0f, -14.0f, 22.0f}, {0, 0, 0}), 640, 480, static_cast<Mode>(mode));
        f.params.set(shading::Param::MapTiling, 1.5f);
        const Parity p = renderBoth(quad, f, map, diffuse);
        expectParity(p, "parity_quad_" + std::string(shading::modeName(static_cast<Mode>(mode))));
    }
}

// The camera's variants: off (drawn straight, no HDR target), and fixed
// exposure with an octagonal mask, the sRGB curve, strong vignetting, full
// softness and heavy noise (the default camera is in every test above).
TEST(RenderParity, TheCameraOffAndItsVariantsMatchReference) {
    const mesh::Mesh quad = mesh::makeQuad(40.0f, 8);
    const image::Image8 map = testMap(256, "bronchial");
    const image::Image8 diffuse = testDiffuse(64);
    using P = shading::Param;
    for (Mode mode : {Mode::Noise, Mode::VertexPhong, Mode::Diffuse, Mode::Clearcoat, Mode::ClearcoatProcedural}) {
        shading::FrameSetup f = frameFor(camera::lookAt({6.0f, -14.0f, 22.0f}, {0, 0, 0}), 640, 480, mode);
        f.params.set(P::MapTiling, 1.5f);
        shading::setCameraIdentity(f.params);
        ASSERT_TRUE(shading::cameraIsIdentity(f.params));
        expectParity(renderBoth(quad, f, map, diffuse), "parity_camera_off_" + std::string(shading::modeName(mode)));
        f.params.set(P::ExposureEv, 3.0f);
        f.params.set(P::Mask, 2.0f);
        f.params.set(P::MaskRadius, 0.8f);
        f.params.set(P::ToneCurve, 2.0f);
        f.params.set(P::Vignetting, 4.0f);
        f.params.set(P::Softness, 0.7f);
        f.params.set(P::FullWell, 300.0f);
        f.params.set(P::ReadNoise, 0.02f);
        f.frameIndex = 5;
        expectParity(renderBoth(quad, f, map, diffuse),
                     "parity_camera_variant_" + std::string(shading::modeName(mode)));
    }
}

// The mesh's per-vertex tint (mesh::Mesh::colors, the phantom's paler
// cartilage) multiplies the albedo alike on both paths, and shows.
// Sub-surface scattering (scatter.frag against shading::applyScatter): a
// sphere close up, so the light diffuses over many pixels, with silhouettes
// against the empty background and the scope's mask; and it shows.
TEST(RenderParity, ScatteringMatchesReferenceAndSoftensTheTexture) {
    const mesh::Mesh sphere = mesh::makeSphere(10.0f, 96, 48);
    const image::Image8 map = testMap(256, "bronchial");
    const image::Image8 diffuse = testDiffuse(64);
    using P = shading::Param;
    for (Mode mode : {Mode::Noise, Mode::VertexPhong}) {
        shading::FrameSetup f = frameFor(camera::lookAt({0.0f, -19.0f, 9.0f}, {0, 0, 0}, {0, 0, 1}), 320, 240, mode);
        f.params.setColor(P::Scatter, {0.6f, 0.3f, 0.2f});
        f.params.set(P::ScatterShare, 0.8f);
        f.params.set(P::Mask, 1.0f);
        f.params.set(P::MaskRadius, 0.95f);
        ASSERT_TRUE(shading::scattersLight(f));
        const Parity scattered = renderBoth(sphere, f, map, diffuse);
        expectParity(scattered, "parity_scatter_" + std::string(shading::modeName(mode)));
        f.params.set(P::ScatterShare, 0.0f);
        const Parity sharp = renderBoth(sphere, f, map, diffuse);
        EXPECT_GT(test::diff(scattered.gl, sharp.gl, 4).fractionOver, 0.05) << "the scattering must show";
    }
}

TEST(RenderParity, PerVertexTintMatchesReferenceAndShows) {
    mesh::Mesh quad = mesh::makeQuad(40.0f, 8);
    const image::Image8 map = testMap(256, "bronchial");
    const image::Image8 diffuse = testDiffuse(64);
    for (const auto& p : quad.positions)
        quad.colors.push_back({1.0f, 0.5f + p[0] / 80.0f, 0.5f - p[1] / 80.0f});  // 0..1 across the quad
    ASSERT_TRUE(quad.hasColors());
    mesh::Mesh plain = quad;
    plain.colors.clear();
    for (Mode mode : {Mode::Noise, Mode::Diffuse}) {
        const shading::FrameSetup f = frameFor(camera::lookAt({6.0f, -14.0f, 22.0f}, {0, 0, 0}), 320, 240, mode);
        const Parity tinted = renderBoth(quad, f, map, diffuse);
        expectParity(tinted, "parity_tint_" + std::string(shading::modeName(mode)));
        const Parity untinted = renderBoth(plain, f, map, diffuse);
        EXPECT_GT(test::diff(tinted.gl, untinted.gl, 8).fractionOver, 0.3) << "the tint must change the picture";
    }
}

TEST(RenderParity, SphereMatchesReferenceInEveryMode) {
    const mesh::Mesh sphere = mesh::makeSphere(10.0f, 96, 48);
    const image::Image8 map = testMap(256, "serosa");
    const image::Image8 diffuse = testDiffuse(64);
    for (int mode = 0; mode < shading::kModeCount; ++mode) {
        shading::FrameSetup f =
            frameFor(camera::lookAt({0.0f, -26.0f, 12.0f}, {0, 0, 0}, {0, 0, 1}), 640, 480, static_cast<Mode>(mode));
        const Parity p = renderBoth(sphere, f, map, diffuse);
        expectParity(p, "parity_sphere_" + std::string(shading::modeName(static_cast<Mode>(mode))));
    }
}

TEST(RenderParity, ProceduralNoiseMatchesReferenceInBothSpacesWithAndWithoutAntiAliasing) {
    const mesh::Mesh sphere = mesh::makeSphere(10.0f, 96, 48);
    const image::Image8 map = testMap(64, "serosa");
    const image::Image8 diffuse = testDiffuse(64);
    for (const Mode mode : {Mode::Procedural, Mode::ClearcoatProcedural})
        for (const char* preset : {"bronchial", "rough"})
            for (shading::NoiseSpace space : {shading::NoiseSpace::Uv, shading::NoiseSpace::Object})
                for (bool aa : {true, false}) {
                    shading::FrameSetup f =
                        frameFor(camera::lookAt({0.0f, -26.0f, 12.0f}, {0, 0, 0}, {0, 0, 1}), 640, 480, mode);
                    const reflectance::MapParams mp = reflectance::findPreset(preset).params;
                    f.procedural.noise = mp.noise;
                    f.procedural.noise.seed = 5;
                    f.procedural.noise.z += 41.0;  // a slice beyond the first lattice layer (uPermSlice)
                    f.procedural.strength = static_cast<float>(mp.strength);
                    f.procedural.space = space;
                    f.specularAA = aa;
                    f.params.set(shading::Param::NoiseScale, 12.0f);
                    const Parity p = renderBoth(sphere, f, map, diffuse);
                    expectParity(p, fmt::format("parity_{}_{}_{}_aa_{}", shading::modeName(mode), preset,
                                                space == shading::NoiseSpace::Uv ? "uv" : "object", aa ? "on" : "off"));
                }
}

TEST(RenderParity, ProceduralNormalsViewMatchesReferenceAndShowsTheBump) {
    // The procedural path's debug view in both spaces (object space needs no
    // UVs): parity with the reference; flat (strength 0) it shows the
    // geometric normal, as the map's normals view does with a flat map; with
    // the bump it differs from that on most of the sphere.
    const mesh::Mesh sphere = mesh::makeSphere(10.0f, 96, 48);
    image::Image8 flat(4, 4, 3);
    for (int y = 0; y < 4; ++y)
        for (int x = 0; x < 4; ++x) flat.at(x, y, 0) = 128, flat.at(x, y, 1) = 128, flat.at(x, y, 2) = 255;
    const image::Image8 diffuse = testDiffuse(64);
    const camera::Pose pose = camera::lookAt({0.0f, -26.0f, 12.0f}, {0, 0, 0}, {0, 0, 1});
    for (shading::NoiseSpace space : {shading::NoiseSpace::Uv, shading::NoiseSpace::Object}) {
        shading::FrameSetup f = frameFor(pose, 320, 240, Mode::ProceduralNormals);
        f.procedural.space = space;
        f.procedural.noise = reflectance::findPreset("rough").params.noise;
        f.procedural.strength = 1.0f;
        f.params.set(shading::Param::NoiseScale, 12.0f);
        // Without the octave fade: with it the fade follows screen-space
        // derivatives, which GL takes per 2x2 quad and the reference per
        // pixel, and a normal shows every such difference (the shaded modes'
        // parity covers the fade, above).
        f.specularAA = false;
        const Parity bumped = renderBoth(sphere, f, flat, diffuse);
        const std::string name = space == shading::NoiseSpace::Uv ? "uv" : "object";
        expectParity(bumped, "parity_procedural_normals_" + name);
        f.procedural.strength = 0.0f;
        const Parity smooth = renderBoth(sphere, f, flat, diffuse);
        expectParity(smooth, "parity_procedural_normals_flat_" + name);
        shading::FrameSetup g = frameFor(pose, 320, 240, Mode::Normals);
        const Parity mapNormals = renderBoth(sphere, g, flat, diffuse);
        EXPECT_LE(test::diff(smooth.gl, mapNormals.gl, 2).fractionOver, 0.001) << name;
        std::size_t covered = 0;
        for (int y = 0; y < smooth.gl.height(); ++y)
            for (int x = 0; x < smooth.gl.width(); ++x)
                if (smooth.gl.at(x, y, 0) + smooth.gl.at(x, y, 1) + smooth.gl.at(x, y, 2) > 0) ++covered;
        const std::size_t moved = test::diff(bumped.gl, smooth.gl, 8).pixelsOver;
        std::printf("procedural normals (%s): %zu of %zu sphere pixels tilted by > 8/255\n", name.c_str(), moved,
                    covered);
        EXPECT_GT(moved, covered / 2) << name;
    }
}

TEST(RenderParity, HeadlightProgramsMatchReference) {
    // A tip light with no offset (the default scene's) puts the light exactly
    // at the eye, and the renderer switches the per-pixel modes to programs
    // that read V for L (MUCOSA_HEADLIGHT): the same pixels as the reference.
    const mesh::Mesh sphere = mesh::makeSphere(10.0f, 96, 48);
    const image::Image8 map = testMap(256, "serosa");
    const image::Image8 diffuse = testDiffuse(64);
    for (const Mode mode : {Mode::Noise, Mode::BrdfNoise, Mode::Procedural, Mode::VertexPhong, Mode::Clearcoat,
                            Mode::ClearcoatProcedural})
        for (shading::NoiseSpace space : {shading::NoiseSpace::Uv, shading::NoiseSpace::Object}) {
            const bool procedural = shading::info(mode).procedural;
            if (!procedural && space == shading::NoiseSpace::Object) continue;
            const camera::Pose pose = camera::lookAt({0.0f, -26.0f, 12.0f}, {0, 0, 0}, {0, 0, 1});
            shading::FrameSetup f = frameFor(pose, 640, 480, mode);
            f.light = camera::lightPosition(pose, camera::TipLight{});
            ASSERT_EQ(f.light, f.eye);
            f.procedural.space = space;
            f.params.set(shading::Param::NoiseScale, 12.0f);
            const Parity p = renderBoth(sphere, f, map, diffuse);
            expectParity(p, fmt::format("parity_headlight_{}{}", shading::modeName(mode),
                                        procedural && space == shading::NoiseSpace::Object ? "_object" : ""));
        }
}

}  // namespace
}  // namespace mucosa
