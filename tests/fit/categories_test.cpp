// The study's categories, rendered on the GPU path at the frames' own poses.
#include <algorithm>
#include <cmath>
#include <cstdlib>

#include <fmt/format.h>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <mucosa/core/file.hpp>
#include <mucosa/fit/categories.hpp>
#include <mucosa/fit/fit.hpp>
#include <mucosa/image/png.hpp>
#include <mucosa/mesh/io.hpp>
#include <mucosa/shading/reference.hpp>
#include <mucosa/study/plan.hpp>

#include "synthetic.hpp"
#include "test_support.hpp"

using namespace mucosa;

namespace {

// PSNR of `a` (8-bit render) against `b` (the real frame) over pixels where the
// render sees the mesh and the real frame has no highlight.
double maskedPsnr(const image::Image8& render, const image::PngImage& real, std::size_t* used) {
    const double maxv = real.bitDepth == 16 ? 65535.0 : 255.0;
    double se = 0;
    std::size_t n = 0;
    for (int y = 0; y < render.height(); ++y)
        for (int x = 0; x < render.width(); ++x) {
            double lr = 0, lf = 0, e2 = 0;
            for (int c = 0; c < 3; ++c) {
                const double r = render.at(x, y, c) / 255.0, f = real.pixels.at(x, y, c) / maxv;
                lr += r;
                lf += f;
                e2 += (r - f) * (r - f);
            }
            if (lr < 0.03 || lf > 1.25 * lr + 0.09) continue;  // background or a highlight
            se += e2;
            n += 3;
        }
    *used = n / 3;
    return 10 * std::log10(1.0 / (se / static_cast<double>(n)));
}

}  // namespace

TEST(Categories, RenderEveryCategoryAtTheFramesPosesAndMatchTheRealFrames) {
    test::TempDir dir;
    const mesh::Mesh tube = test::makeTube(9.0, 80.0, 160, 160);
    test::SyntheticOptions so;
    so.frames = 6;
    so.size = 160;
    const frames::FrameSet frames = test::renderSynthetic(tube, test::Truth{}, so, dir.path());
    fit::FitOptions fo;
    fo.textureSize = 256;
    fo.minSamples = 1000;
    const fit::FitResult r = fit::fitFrames(tube, frames, fo);
    fit::writeFitOutputs(r, dir / "fit");
    const fit::FittedModel model = fit::readFitDirectory(dir / "fit");
    EXPECT_NEAR(model.brdf.c[1], r.brdf.c[1], 1e-12);

    const auto images = fit::renderCategories(tube, frames, model, dir / "stimuli", {});
    // MUCOSA_CATEGORIES_EXAMPLE_DIR=path keeps the images (README picture).
    if (const char* keep = std::getenv("MUCOSA_CATEGORIES_EXAMPLE_DIR"))
        std::filesystem::copy(
            dir / "stimuli", keep,
            std::filesystem::copy_options::recursive | std::filesystem::copy_options::overwrite_existing);
    ASSERT_EQ(images.size(), 30u);
    // The manifest is the study kit's input.
    const auto manifest = study::readManifest(dir / "stimuli" / "images.json");
    ASSERT_EQ(manifest.size(), 30u);
    for (int pose = 0; pose < 6; ++pose) {
        const image::PngImage real = image::readPng(frames.frames[static_cast<std::size_t>(pose)].image);
        std::array<image::Image8, 5> cat;
        for (int c = 1; c <= 4; ++c)
            cat[static_cast<std::size_t>(c - 1)] =
                image::to8(image::readPng(dir / "stimuli" / fmt::format("pose{:03}_cat{}.png", pose, c)));
        // Category 3 is the fitted model at the frame's own camera: it lines up
        // with the real frame (a wrong view or projection convention would not).
        std::size_t used = 0;
        const double psnr3 = maskedPsnr(cat[2], real, &used);
        std::printf("pose %d: category 3 vs real %.1f dB over %zu pixels\n", pose, psnr3, used);
        EXPECT_GT(psnr3, 28.0) << pose;
        EXPECT_GT(used, 8000u);
        // Category 1 (unreal) is further from the real frame than category 3.
        std::size_t used1 = 0;
        EXPECT_LT(maskedPsnr(cat[0], real, &used1), psnr3 - 3.0) << pose;
        // Category 4 adds highlights to category 3: brighter somewhere, never darker.
        std::size_t brighter = 0, darker = 0;
        for (std::size_t i = 0; i < cat[2].size(); ++i) {
            const int d = cat[3].data()[i] - cat[2].data()[i];
            brighter += d > 30;
            darker += d < -2;
        }
        EXPECT_GT(brighter, 20u) << pose;
        EXPECT_EQ(darker, 0u) << pose;
        // Category 5 is the real frame, byte for byte.
        EXPECT_EQ(test::readBytes(dir / "stimuli" / fmt::format("pose{:03}_cat5.png", pose)),
                  test::readBytes(frames.frames[static_cast<std::size_t>(pose)].image));
    }
}

TEST(Categories, GlCameraMatchesTheOpenCvProjection) {
    // A world point projected by the GL matrices lands on OpenCV's pixel.
    frames::Intrinsics K{320, 240, 200.0, 210.0, 150.3, 118.7, 0, 0};
    frames::Mat4 c2w{};
    const double a = 0.3;
    c2w[0] = {std::cos(a), 0, std::sin(a), 4};
    c2w[1] = {0, 1, 0, -2};
    c2w[2] = {-std::sin(a), 0, std::cos(a), 7};
    c2w[3] = {0, 0, 0, 1};
    const auto V = frames::glViewMatrix(c2w);
    const auto P = frames::glProjectionMatrix(K, 0.5, 500);
    const frames::Vec3d world{6.0, 1.5, 30.0};
    const frames::Vec3d cam = frames::transformPoint(frames::invertRigid(c2w), world);
    const double u = K.fx * cam[0] / cam[2] + K.cx, v = K.fy * cam[1] / cam[2] + K.cy;
    std::array<double, 4> e{}, clip{};
    for (int r = 0; r < 4; ++r)
        e[r] = V[0 * 4 + r] * world[0] + V[1 * 4 + r] * world[1] + V[2 * 4 + r] * world[2] + V[3 * 4 + r];
    for (int r = 0; r < 4; ++r)
        clip[r] = P[0 * 4 + r] * e[0] + P[1 * 4 + r] * e[1] + P[2 * 4 + r] * e[2] + P[3 * 4 + r] * e[3];
    const double xn = clip[0] / clip[3], yn = clip[1] / clip[3];
    // Pixel centre (u, v) <-> NDC: x = 2 (u + 0.5) / w - 1, y = 1 - 2 (v + 0.5) / h.
    EXPECT_NEAR((xn + 1) / 2 * K.width - 0.5, u, 1e-3);
    EXPECT_NEAR((1 - yn) / 2 * K.height - 0.5, v, 1e-3);
}

TEST(Categories, FittedCategoriesAreDevelopedLikeTheFramesBehindTheirMask) {
    // The synthetic frames as a scope delivers them: exposed 1.6x, vignetted
    // cos^1.5, BT.709-encoded, black outside a circle. The fit reads them
    // back to linear (its albedo then exceeds 1 and moves into rho); the
    // categories must come out in the frames' encoding and behind their mask.
    test::TempDir dir;
    const mesh::Mesh tube = test::makeTube(9.0, 80.0, 160, 160);
    test::SyntheticOptions so;
    so.frames = 6;
    so.size = 160;
    std::filesystem::create_directories(dir / "linear");
    frames::FrameSet frames = test::renderSynthetic(tube, test::Truth{}, so, dir / "linear");
    frames.response.toneCurve = 1;
    frames.response.vignetting = 1.5;
    const double radius = 0.46 * so.size;
    auto outsideCircle = [&](int x, int y) {
        const double c = (so.size - 1) / 2.0;
        return (x - c) * (x - c) + (y - c) * (y - c) > radius * radius;
    };
    for (std::size_t i = 0; i < frames.frames.size(); ++i) {
        frames::Frame& f = frames.frames[i];
        image::Image16 px = image::readPng(f.image).pixels;
        for (int y = 0; y < px.height(); ++y)
            for (int x = 0; x < px.width(); ++x) {
                const double tx = (x - f.K.cx) / f.K.fx, ty = (y - f.K.cy) / f.K.fy;
                const double vignette = std::pow(1.0 + tx * tx + ty * ty, -0.75);
                for (int c = 0; c < 3; ++c) {
                    const double lin = std::min(1.0, 1.6 * px.at(x, y, c) / 65535.0 * vignette);
                    px.at(x, y, c) =
                        outsideCircle(x, y)
                            ? 0
                            : static_cast<std::uint16_t>(std::lround(65535.0 * shading::toneCurve(float(lin), 1)));
                }
            }
        f.image = dir / fmt::format("scope_{}.png", i);
        image::writePng(f.image, px);
    }
    fit::FitOptions fo;
    fo.textureSize = 256;
    fo.minSamples = 1000;
    const fit::FitResult r = fit::fitFrames(tube, frames, fo);
    fit::writeFitOutputs(r, dir / "fit");
    std::size_t seen = 0, above = 0;
    for (std::size_t t = 0; t < r.coverage.size(); ++t)
        if (r.coverage.data()[t] > 0)
            for (std::size_t c = 0; c < 3; ++c, ++seen) above += r.texture.data()[3 * t + c] > 1.0f;
    std::printf("albedo scale %.3f (rho(1) = %.3f), %zu of %zu seen texel channels above 1\n", r.albedoScale,
                r.brdf.rho(1.0), above, seen);
    EXPECT_GT(r.albedoScale, 1.2);
    EXPECT_NEAR(r.brdf.rho(1.0), r.albedoScale, 1e-9);
    EXPECT_LE(above, seen / 1000);
    const fit::FittedModel model = fit::readFitDirectory(dir / "fit");
    fit::renderCategories(tube, frames, model, dir / "stimuli", {});
    for (int pose = 0; pose < 6; ++pose) {
        const image::PngImage real = image::readPng(frames.frames[static_cast<std::size_t>(pose)].image);
        const image::Image8 cat3 =
            image::to8(image::readPng(dir / "stimuli" / fmt::format("pose{:03}_cat3.png", pose)));
        std::size_t used = 0;
        const double psnr = maskedPsnr(cat3, real, &used);
        std::printf("pose %d: category 3 vs the scope's frame %.1f dB over %zu pixels\n", pose, psnr, used);
        EXPECT_GT(psnr, 28.0) << pose;
        EXPECT_GT(used, 8000u);
        for (int c = 2; c <= 4; ++c) {
            const image::Image8 img =
                image::to8(image::readPng(dir / "stimuli" / fmt::format("pose{:03}_cat{}.png", pose, c)));
            std::size_t lit = 0, outside = 0;
            for (int y = 0; y < img.height(); ++y)
                for (int x = 0; x < img.width(); ++x)
                    if (outsideCircle(x, y)) {
                        ++outside;
                        lit += img.at(x, y, 0) + img.at(x, y, 1) + img.at(x, y, 2) > 0;
                    }
            EXPECT_GT(outside, 4000u);
            EXPECT_EQ(lit, 0u) << "category " << c << " pose " << pose;
        }
    }
}
