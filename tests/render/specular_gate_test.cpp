// Specular light does not reach a surface that faces away from the lamp: in
// every mode with a specular term, on both paths (the GL renderer and the C++
// reference, both shaders/common_shading.glsl), a pixel whose geometric N.L
// <= 0 is the same with the specular lobe and the sheen at full strength as
// with both off -- even where the map's or the noise's perturbed normal would
// face the lamp. Two cases: a sphere seen from its unlit side (lit_side
// "back" seen from outside: the --flip trap, where the fitted brdf-noise mode
// once put k_s highlights on the walls), and a sphere lit from the side,
// whose terminator cuts through triangles.
#include <cmath>

#include <gtest/gtest.h>

#include <fmt/format.h>

#include <mucosa/camera/camera.hpp>
#include <mucosa/mesh/primitives.hpp>
#include <mucosa/reflectance/map.hpp>
#include <mucosa/reflectance/normal_map.hpp>
#include <mucosa/render/renderer.hpp>
#include <mucosa/shading/reference.hpp>

#include "render_test_support.hpp"

namespace mucosa {
namespace {

using shading::Mode;
using P = shading::Param;

constexpr float kRadius = 10.0f;

struct Frames {
    image::Image8 gl, ref;
};

Frames renderBoth(const mesh::Mesh& m, const shading::FrameSetup& f, const image::Image8& map) {
    test::glContext();
    image::Image8 diffuse(8, 8, 3);
    for (std::size_t i = 0; i < diffuse.size(); ++i) diffuse.data()[i] = 180;
    const image::Image8 hl = shading::highlightSphereMap(shading::kHighlightTextureSize, f.params[P::Shininess]);
    render::Renderer r;
    r.setMesh(m);
    r.setTexture(render::TextureSlot::Diffuse, diffuse, shading::Filter::Nearest, shading::Wrap::Repeat);
    r.setTexture(render::TextureSlot::Reflectance, map, shading::Filter::Nearest, shading::Wrap::Repeat);
    r.setTexture(render::TextureSlot::Highlight, hl, shading::Filter::Nearest, shading::Wrap::Clamp);
    render::Framebuffer fb(f.width, f.height);
    fb.bind();
    r.draw(f);
    Frames out;
    out.gl = fb.readRgb();
    shading::Textures t;
    t.diffuse = {&diffuse, shading::Filter::Nearest, shading::Wrap::Repeat};
    t.reflectance = {&map, shading::Filter::Nearest, shading::Wrap::Repeat};
    t.highlight = {&hl, shading::Filter::Nearest, shading::Wrap::Clamp};
    out.ref = shading::renderReference(m, f, t);
    return out;
}

// Where the pixel's ray meets the sphere (origin, kRadius), the cosine between
// its outward normal times `normalSign` and the direction to the light; NaN
// where it misses.
float geometricCosine(const shading::FrameSetup& f, const camera::Pose& pose, int x, int y) {
    const float fov = 70.0f * 3.14159265f / 180.0f;
    const float t = std::tan(0.5f * fov), aspect = float(f.width) / float(f.height);
    const float sx = (2.0f * (float(x) + 0.5f) / float(f.width) - 1.0f) * t * aspect,
                sy = (1.0f - 2.0f * (float(y) + 0.5f) / float(f.height)) * t;
    auto norm = [](std::array<float, 3> a) {
        const float l = std::sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2]);
        return std::array<float, 3>{a[0] / l, a[1] / l, a[2] / l};
    };
    auto cross = [](const std::array<float, 3>& a, const std::array<float, 3>& b) {
        return std::array<float, 3>{a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
    };
    const std::array<float, 3> fw = norm(pose.forward), r = norm(cross(fw, pose.up)), up = cross(r, fw);
    std::array<float, 3> d;
    for (std::size_t k = 0; k < 3; ++k) d[k] = fw[k] + sx * r[k] + sy * up[k];
    const float dd = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
    const std::array<float, 3>& o = pose.position;
    const float b = o[0] * d[0] + o[1] * d[1] + o[2] * d[2],
                c = o[0] * o[0] + o[1] * o[1] + o[2] * o[2] - kRadius * kRadius;
    const float disc = b * b - dd * c;
    if (disc < 0) return NAN;
    const float s = (-b - std::sqrt(disc)) / dd;
    std::array<float, 3> p, l;
    for (std::size_t k = 0; k < 3; ++k) p[k] = o[k] + s * d[k], l[k] = f.light[k] - p[k];
    const float ll = std::sqrt(l[0] * l[0] + l[1] * l[1] + l[2] * l[2]);
    return f.normalSign * (p[0] * l[0] + p[1] * l[1] + p[2] * l[2]) / (kRadius * ll);
}

// Renders `f` with the specular lobe and the sheen strong, then off, and
// returns how many pixels facing away from the lamp (cosine < -margin)
// differ, on each path; also how many pixels facing it differ (the
// specular must show somewhere, or the test proves nothing).
struct Leak {
    std::size_t away = 0, leakGl = 0, leakRef = 0, shownGl = 0;
};

Leak leakOf(const mesh::Mesh& m, shading::FrameSetup f, const camera::Pose& pose, const image::Image8& map,
            float margin) {
    f.params.set(P::SpecularStrength, 1.0f);
    f.params.set(P::SheenStrength, 1.0f);
    const Frames on = renderBoth(m, f, map);
    f.params.set(P::SpecularStrength, 0.0f);
    f.params.set(P::SheenStrength, 0.0f);
    const Frames off = renderBoth(m, f, map);
    Leak l;
    for (int y = 0; y < f.height; ++y)
        for (int x = 0; x < f.width; ++x) {
            const float c = geometricCosine(f, pose, x, y);
            if (std::isnan(c)) continue;
            bool differGl = false, differRef = false;
            for (int k = 0; k < 3; ++k) {
                differGl |= on.gl.at(x, y, k) != off.gl.at(x, y, k);
                differRef |= on.ref.at(x, y, k) != off.ref.at(x, y, k);
            }
            if (c < -margin) {
                ++l.away;
                l.leakGl += differGl;
                l.leakRef += differRef;
            } else if (c > margin) {
                l.shownGl += differGl;
            }
        }
    return l;
}

shading::FrameSetup frameFor(const camera::Pose& pose, Mode mode) {
    shading::FrameSetup f;
    camera::Lens lens;
    lens.fovDeg = 70.0f;
    lens.nearMm = 1.0f;
    lens.farMm = 200.0f;
    f.width = 320;
    f.height = 240;
    f.view = camera::viewMatrix(pose);
    f.projection = camera::projectionMatrix(lens, f.width, f.height);
    f.eye = pose.position;
    f.mode = mode;
    shading::setCameraIdentity(f.params);  // no auto-exposure: the two renders develop alike
    f.params.set(P::Shininess, 8.0f);      // a broad lobe: glints everywhere the lamp could reach
    f.params.set(P::BumpScale, 3.0f);      // strongly tilted map normals
    f.specularAA = false;
    return f;
}

image::Image8 testMap() {
    reflectance::MapParams p = reflectance::findPreset("bronchial").params;
    p.size = 128;
    return reflectance::encodeNormals8(reflectance::heightField(p), p.strength, reflectance::Edges::Wrap);
}

const Mode kSpecularModes[] = {Mode::Noise, Mode::Procedural, Mode::VertexPhong, Mode::Multitexture, Mode::BrdfNoise};

// The unlit side of a sphere (normals out, lit_side "back", seen from
// outside with the lamp at the scope): every visible pixel faces away.
TEST(SpecularGate, NothingOnASurfaceSeenFromItsUnlitSide) {
    const mesh::Mesh sphere = mesh::makeSphere(kRadius, 96, 48);
    const image::Image8 map = testMap();
    const camera::Pose pose = camera::lookAt({0.0f, -26.0f, 12.0f}, {0, 0, 0}, {0, 0, 1});
    for (Mode mode : kSpecularModes) {
        shading::FrameSetup f = frameFor(pose, mode);
        f.light = camera::lightPosition(pose, camera::TipLight{{3.0f, 2.0f, 0.0f}});
        f.normalSign = -1.0f;
        const Leak l = leakOf(sphere, f, pose, map, 0.0f);
        std::printf("%s, unlit side: %zu pixels face away; specular changes %zu (GL), %zu (reference)\n",
                    shading::modeName(mode).data(), l.away, l.leakGl, l.leakRef);
        EXPECT_GT(l.away, 10000u);
        EXPECT_EQ(l.leakGl, 0u) << shading::modeName(mode);
        EXPECT_EQ(l.leakRef, 0u) << shading::modeName(mode);
    }
}

// Lit from the side: the terminator runs across the visible half. Beyond it
// (geometric cosine below -0.03, clear of the tessellation's normals) no
// specular; before it, some.
TEST(SpecularGate, NothingPastTheTerminatorOfASideLitSphere) {
    const mesh::Mesh sphere = mesh::makeSphere(kRadius, 96, 48);
    const image::Image8 map = testMap();
    const camera::Pose pose = camera::lookAt({0.0f, -26.0f, 12.0f}, {0, 0, 0}, {0, 0, 1});
    for (Mode mode : kSpecularModes) {
        shading::FrameSetup f = frameFor(pose, mode);
        f.light = {24.0f, -6.0f, 2.0f};
        const Leak l = leakOf(sphere, f, pose, map, 0.03f);
        std::printf(
            "%s, side light: %zu pixels past the terminator; specular changes %zu (GL), %zu (reference); "
            "%zu lit pixels show it\n",
            shading::modeName(mode).data(), l.away, l.leakGl, l.leakRef, l.shownGl);
        EXPECT_GT(l.away, 5000u);
        EXPECT_GT(l.shownGl, 100u) << shading::modeName(mode);
        EXPECT_EQ(l.leakGl, 0u) << shading::modeName(mode);
        EXPECT_EQ(l.leakRef, 0u) << shading::modeName(mode);
    }
}

}  // namespace
}  // namespace mucosa
