// The renderer's brdf modes read mucosa fit's output through the scene file.
#include <cmath>
#include <fstream>

#include <gtest/gtest.h>

#include <mucosa/core/error.hpp>
#include <mucosa/fit/fit.hpp>
#include <mucosa/image/png.hpp>
#include <mucosa/mesh/io.hpp>
#include <mucosa/scene/scene.hpp>
#include <mucosa/shading/params.hpp>

#include "synthetic.hpp"
#include "test_support.hpp"

using namespace mucosa;

TEST(SceneFit, FitFolderSetsTheBrdfParametersAndTheTexture) {
    test::TempDir dir;
    fit::FitResult r;
    r.brdf.c = {0.2, 0.9, -0.25, 0.15};
    r.brdf.d = {-0.5, 0.2, -0.03};
    r.brdf.zmin = 3;
    r.brdf.zmax = 47;
    r.texture = image::ImageF(16, 16, 3);
    r.coverage = image::ImageF(16, 16, 1);
    fit::writeFitOutputs(r, dir / "fit");
    const scene::Scene s = scene::parseScene(
        R"({"mesh": "tube", "fit": "fit", "mode": "brdf-noise", "brdf": {"d3": -0.04}})", dir / "scene.json");
    using shading::Param;
    EXPECT_EQ(s.mode, shading::Mode::BrdfNoise);
    EXPECT_FLOAT_EQ(s.params[Param::C0], 0.2f);
    EXPECT_FLOAT_EQ(s.params[Param::C2], -0.25f);
    EXPECT_FLOAT_EQ(s.params[Param::D1], -0.5f);
    EXPECT_FLOAT_EQ(s.params[Param::D3], -0.04f);  // the explicit value wins
    EXPECT_FLOAT_EQ(s.params[Param::DepthMin], 3.0f);
    EXPECT_FLOAT_EQ(s.params[Param::DepthMax], 47.0f);
    ASSERT_TRUE(s.diffuse.has_value());
    EXPECT_EQ(*s.diffuse, dir / "fit" / "texture.png");
    EXPECT_EQ(shading::parseMode("brdf"), shading::Mode::Brdf);
    try {
        scene::parseScene(R"({"mesh": "tube", "fit": "nowhere"})", dir / "scene.json");
        FAIL();
    } catch (const InputError& e) {
        EXPECT_NE(std::string(e.what()).find("fit"), std::string::npos) << e.what();
    }
}

TEST(SceneFit, RenderCommandShadesWithTheFittedModel) {
    test::TempDir dir;
    const mesh::Mesh tube = test::makeTube(9.0, 80.0, 96, 96);
    mesh::save(tube, dir / "tube.ply");
    test::SyntheticOptions so;
    so.frames = 4;
    so.size = 96;
    const frames::FrameSet frames = test::renderSynthetic(tube, test::Truth{}, so, dir.path());
    fit::FitOptions fo;
    fo.textureSize = 128;
    fo.minSamples = 500;
    fit::writeFitOutputs(fit::fitFrames(tube, frames, fo), dir / "fit");
    {
        std::ofstream(dir / "scene.json") << R"({"mesh": "tube.ply", "fit": "fit", "mode": "brdf",
            "material": {"shininess": 40},
            "camera": {"pose": {"position": [2, 1, 12], "look_at": [-4, 0, 40]}}, "resolution": [128, 96]})";
    }
    for (const char* mode : {"brdf", "brdf-noise"}) {
        const auto r = test::runCli(std::string("render scene.json -o ") + mode + ".png --mode " + mode, dir.path());
        ASSERT_EQ(r.exitCode, 0) << r.err;
    }
    const image::Image8 a = image::to8(image::readPng(dir / "brdf.png"));
    const image::Image8 b = image::to8(image::readPng(dir / "brdf-noise.png"));
    std::size_t lit = 0, brighter = 0;
    for (std::size_t i = 0; i < a.size(); ++i) {
        lit += a.data()[i] > 10;
        brighter += b.data()[i] > a.data()[i] + 30;
        EXPECT_GE(b.data()[i] + 1, a.data()[i]);  // the specular only adds light
    }
    EXPECT_GT(lit, a.size() / 2);
    EXPECT_GT(brighter, 10u);
}

// Centerline UVs leave [0, 1] (u wraps whole turns, v runs along the airway):
// the fit's atlas then spans uv_min..uv_max, and the scene's "fit" key must
// sample it there. Same frames, same geometry, UVs inside and outside [0, 1]:
// the two renders agree.
TEST(SceneFit, AtlasSpanningUvsOutsideTheUnitSquareRendersLikeOneInside) {
    test::TempDir dir;
    const mesh::Mesh tube = test::makeTube(9.0, 80.0, 96, 96);
    mesh::Mesh shifted = tube;
    for (auto& uv : shifted.uvs) uv = {2.0f + 3.0f * uv[0], -0.5f + 1.5f * uv[1]};
    mesh::save(tube, dir / "tube.ply");
    mesh::save(shifted, dir / "shifted.ply");
    test::SyntheticOptions so;
    so.frames = 4;
    so.size = 96;
    const frames::FrameSet frames = test::renderSynthetic(tube, test::Truth{}, so, dir.path());
    fit::FitOptions fo;
    fo.textureSize = 128;
    fo.minSamples = 500;
    fit::writeFitOutputs(fit::fitFrames(tube, frames, fo), dir / "fitA");
    const fit::FitResult b = fit::fitFrames(shifted, frames, fo);
    ASSERT_FLOAT_EQ(b.uvMin[0], 2.0f);
    ASSERT_FLOAT_EQ(b.uvMax[1], 1.0f);
    fit::writeFitOutputs(b, dir / "fitB");
    const char* camera =
        R"("camera": {"pose": {"position": [2, 1, 12], "look_at": [-4, 0, 40]}}, "resolution": [128, 96])";
    std::ofstream(dir / "a.json") << R"({"mesh": "tube.ply", "fit": "fitA", "mode": "brdf", )" << camera << "}";
    std::ofstream(dir / "b.json") << R"({"mesh": "shifted.ply", "fit": "fitB", "mode": "brdf", )" << camera << "}";
    for (const char* s : {"a", "b"}) {
        const auto r = test::runCli(std::string("render ") + s + ".json -o " + s + ".png", dir.path());
        ASSERT_EQ(r.exitCode, 0) << r.err;
    }
    const image::Image8 ia = image::to8(image::readPng(dir / "a.png"));
    const image::Image8 ib = image::to8(image::readPng(dir / "b.png"));
    double se = 0;
    for (std::size_t i = 0; i < ia.size(); ++i) se += (ia.data()[i] - ib.data()[i]) * (ia.data()[i] - ib.data()[i]);
    const double psnr = 10 * std::log10(255.0 * 255.0 / std::max(se / static_cast<double>(ia.size()), 1e-9));
    std::printf("fit atlas over uv [2, 5] x [-0.5, 1] vs [0, 1]^2: PSNR %.1f dB\n", psnr);
    EXPECT_GT(psnr, 30.0);
}
