// Mirrored UVs: the tangent's w flips B so the map's +v still runs along
// dP/dv, and its +u (red) along dP/du -- which on a mirrored quad points to -x.
// So a map whose normals all tilt towards +u shows world normals tilting to +x
// on the plain quad and to -x on the mirrored one, and the highlight (light at
// the eye, straight above) sits on the opposite side of the tilt; moving the
// light moves the highlight the same way on both. Checked on GL and the C++
// reference.
#include <gtest/gtest.h>

#include <cmath>

#include <mucosa/camera/camera.hpp>
#include <mucosa/mesh/primitives.hpp>
#include <mucosa/reflectance/normal_map.hpp>
#include <mucosa/render/renderer.hpp>
#include <mucosa/shading/reference.hpp>

#include "render_test_support.hpp"

namespace mucosa {
namespace {

image::Image8 tiltedMap() {
    // N tilted 20 degrees towards +u: rgb = 0.5 N + 0.5.
    const double a = 20.0 * 3.14159265358979 / 180.0;
    const auto rgb = reflectance::encode8({std::sin(a), 0.0, std::cos(a)});
    image::Image8 img(4, 4, 3);
    for (int y = 0; y < 4; ++y)
        for (int x = 0; x < 4; ++x)
            for (int c = 0; c < 3; ++c) img.at(x, y, c) = rgb[static_cast<std::size_t>(c)];
    return img;
}

struct Views {
    image::Image8 gl, ref;
};

Views renderQuad(bool mirrored, shading::Mode mode, float lightX) {
    test::glContext();
    const mesh::Mesh quad = mesh::makeQuad(60.0f, 4, mirrored);
    const image::Image8 map = tiltedMap();
    const camera::Pose pose = camera::lookAt({0, 0, 25}, {0, 0, 0});
    shading::FrameSetup f;
    camera::Lens lens;
    lens.fovDeg = 100.0f;
    f.view = camera::viewMatrix(pose);
    f.projection = camera::projectionMatrix(lens, 320, 240);
    f.eye = pose.position;
    f.light = camera::lightPosition(pose, camera::TipLight{{lightX, 0.0f, 0.0f}});
    f.mode = mode;
    f.width = 320;
    f.height = 240;
    // The map's glints only: black tissue, no ambient, no film sheen.
    f.params.setColor(shading::Param::BaseColor, {0, 0, 0});
    f.params.set(shading::Param::SheenStrength, 0.0f);
    f.params.set(shading::Param::MucusOpacity, 0.0f);
    f.params.set(shading::Param::Shininess, 60.0f);
    render::Renderer r;
    r.setMesh(quad);
    r.setTexture(render::TextureSlot::Reflectance, map, shading::Filter::Nearest, shading::Wrap::Repeat);
    render::Framebuffer fb(320, 240);
    fb.bind();
    r.draw(f);
    Views v;
    v.gl = fb.readRgb();
    shading::Textures t;
    t.reflectance = {&map, shading::Filter::Nearest, shading::Wrap::Repeat};
    v.ref = shading::renderReference(quad, f, t);
    return v;
}

// Brightness-weighted mean x of the image, in pixels from the centre (+ = right = world +x).
double centroidX(const image::Image8& img) {
    double sw = 0, sx = 0;
    for (int y = 0; y < img.height(); ++y)
        for (int x = 0; x < img.width(); ++x) {
            const double w = img.at(x, y, 0);
            sw += w;
            sx += w * (x + 0.5 - img.width() / 2.0);
        }
    return sw > 0 ? sx / sw : 0.0;
}

TEST(RenderHandedness, MirroredUvFlipsTheMapNormalAcrossX) {
    for (bool mirrored : {false, true}) {
        const Views v = renderQuad(mirrored, shading::Mode::Normals, 0.0f);
        for (const image::Image8* img : {&v.gl, &v.ref}) {
            const int red = img->at(160, 120, 0);
            if (mirrored)
                EXPECT_LT(red, 100) << "mirrored quad: the map's +u must point to world -x";
            else
                EXPECT_GT(red, 155) << "plain quad: the map's +u must point to world +x";
        }
    }
}

TEST(RenderHandedness, MirroredUvHighlightMovesTheRightWayWhenTheLightMoves) {
    for (bool mirrored : {false, true}) {
        const Views centre = renderQuad(mirrored, shading::Mode::Noise, 0.0f);
        const Views moved = renderQuad(mirrored, shading::Mode::Noise, 6.0f);
        for (int path = 0; path < 2; ++path) {
            const image::Image8& a = path == 0 ? centre.gl : centre.ref;
            const image::Image8& b = path == 0 ? moved.gl : moved.ref;
            const double x0 = centroidX(a), x1 = centroidX(b);
            std::printf("%s, %s: highlight centroid x %.1f px, light moved +x: %.1f px\n",
                        mirrored ? "mirrored" : "plain", path == 0 ? "GL" : "reference", x0, x1);
            // Normals tilted to +x (plain) put the highlight at -x; mirrored, at +x.
            if (mirrored)
                EXPECT_GT(x0, 10.0);
            else
                EXPECT_LT(x0, -10.0);
            EXPECT_GT(x1, x0 + 5.0) << "the highlight must follow the light";
        }
    }
}

}  // namespace
}  // namespace mucosa
