// Every mode renders the default scene (the phantom) with no black frame and
// no NaN (GL agrees with the C++ reference, which would propagate a NaN
// differently), and frames are identical run to run on llvmpipe.
#include <gtest/gtest.h>

#include <mucosa/render/offscreen.hpp>
#include <mucosa/scene/scene.hpp>

#include "render_test_support.hpp"
#include "test_support.hpp"

namespace mucosa {
namespace {

struct Fixture {
    scene::Scene scene = scene::defaultScene();
    scene::SceneAssets assets;
    camera::Pose pose;
    Fixture() {
        scene.filter = shading::Filter::Nearest;  // the reference samples exactly as GL
        // The scope's mask would blacken the corners: this test looks for black frames and NaN.
        scene.params.set(shading::Param::Mask, 0.0f);
        assets = scene::loadAssets(scene);
        pose = scene::cameraPoses(scene, assets, 5)[2];
    }
};

const Fixture& fixture() {
    static Fixture f;
    return f;
}

TEST(RenderModes, EveryModeRendersThePhantomWithoutBlackFramesOrNaN) {
    const Fixture& fx = fixture();
    render::OffscreenSession session(fx.scene, fx.assets, 320, 240);
    const shading::Textures textures = scene::referenceTextures(fx.scene, fx.assets);
    for (int m = 0; m < shading::kModeCount; ++m) {
        const auto mode = static_cast<shading::Mode>(m);
        const std::string name(shading::modeName(mode));
        const image::Image8 gl = session.render(fx.pose, mode);
        double sum = 0;
        std::size_t black = 0;
        for (int y = 0; y < gl.height(); ++y)
            for (int x = 0; x < gl.width(); ++x) {
                const int s = gl.at(x, y, 0) + gl.at(x, y, 1) + gl.at(x, y, 2);
                sum += s;
                black += s == 0;
            }
        const double mean = sum / (3.0 * gl.width() * gl.height());
        const double blackFraction = double(black) / (gl.width() * gl.height());
        std::printf("%-13s mean %.1f/255, %.2f%% black pixels\n", name.c_str(), mean, 100 * blackFraction);
        EXPECT_GT(mean, 20.0) << name;
        EXPECT_LT(blackFraction, 0.05) << name;
        shading::FrameSetup f = scene::frameSetup(fx.scene, fx.pose, 320, 240);
        f.mode = mode;
        const image::Image8 ref = shading::renderReference(fx.assets.mesh, f, textures);
        const test::DiffStats d = test::diff(gl, ref, 2);
        std::printf("%-13s vs reference: max %d/255, %.4f%% over 2/255\n", name.c_str(), d.maxDiff,
                    100 * d.fractionOver);
        // Looser than the analytic parity scenes (0.1 %): the phantom minifies
        // the map under nearest sampling, so texel choices at boundaries (a
        // 1e-7 difference in interpolated uv) flip more often. A NaN would
        // differ over whole triangles.
        EXPECT_LE(d.fractionOver, 0.005) << name;
        if (d.fractionOver > 0.005) test::writeComparison("phantom_" + name, gl, ref);
    }
}

TEST(RenderModes, FramesAreIdenticalRunToRun) {
    const Fixture& fx = fixture();
    image::Image8 first;
    for (int run = 0; run < 2; ++run) {
        render::OffscreenSession session(fx.scene, fx.assets, 320, 240);  // a new context each run
        const image::Image8 img = session.render(fx.pose, shading::Mode::Noise);
        if (run == 0) {
            first = img;
        } else {
            EXPECT_TRUE(img == first) << "noise-mode frame differs between two runs";
            if (!(img == first)) test::writeComparison("determinism_noise", img, first);
        }
    }
}

TEST(RenderModes, CullingBackFacesOfTheClosedPhantomChangesNoPixel) {
    const Fixture& fx = fixture();
    ASSERT_TRUE(scene::frameSetup(fx.scene, fx.pose, 320, 240).cullBackFaces);
    scene::Scene open = fx.scene;
    open.closed = false;
    render::OffscreenSession culled(fx.scene, fx.assets, 320, 240);
    const image::Image8 a = culled.render(fx.pose, shading::Mode::Noise);
    render::OffscreenSession all(open, fx.assets, 320, 240);
    const image::Image8 b = all.render(fx.pose, shading::Mode::Noise);
    // Equal up to depth ties where a culled face and a kept one meet (a pixel
    // may round 1/255 differently).
    const test::DiffStats d = test::diff(a, b, 0);
    std::printf("culled vs all faces: %zu pixels differ, max %d/255\n", d.pixelsOver, d.maxDiff);
    EXPECT_LE(d.maxDiff, 2);
    EXPECT_LE(d.fractionOver, 1e-4);
    if (d.maxDiff > 2) test::writeComparison("culling", a, b);
}

TEST(RenderModes, CliFramesAreIdenticalRunToRun) {
    test::TempDir dir;
    const auto a = dir / "a.png", b = dir / "b.png";
    auto r1 = test::runCli("render -q --size 160x120 -o '" + a.string() + "'");
    auto r2 = test::runCli("render -q --size 160x120 -o '" + b.string() + "'");
    ASSERT_EQ(r1.exitCode, 0) << r1.err;
    ASSERT_EQ(r2.exitCode, 0) << r2.err;
    EXPECT_EQ(test::readBytes(a), test::readBytes(b));
}

}  // namespace
}  // namespace mucosa
