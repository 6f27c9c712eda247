// The outputs the renderer draws beside the colour frame, with its exposure:
// the linear signal (before the tone curve) and the specular-highlight mask.
#include <cmath>
#include <filesystem>
#include <string>

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <mucosa/dataset/ground_truth.hpp>
#include <mucosa/image/exr.hpp>
#include <mucosa/image/png.hpp>
#include <mucosa/shading/params.hpp>

#include "cli_helpers.hpp"
#include "test_support.hpp"

namespace mucosa {
namespace {

namespace fs = std::filesystem;

std::string q(const fs::path& p) {
    return "'" + p.string() + "'";
}

double bt709(double s) {
    return s < 0.018 ? 4.5 * s : 1.099 * std::pow(s, 0.45) - 0.099;
}

// The highlight knee (camera.knee, shaders/camera.glsl's kneeCurve).
double knee(double v, double k) {
    return k >= 1 || v <= k ? v : k + (1 - k) * std::tanh((v - k) / (1 - k));
}

double luminance(const image::ImageF& img, int x, int y) {
    return 0.2126 * img.at(x, y, 0) + 0.7152 * img.at(x, y, 1) + 0.0722 * img.at(x, y, 2);
}

// Without colour enhancement, the PNG is the BT.709 curve of the linear EXR,
// through the highlight knee, rounded to 8 bits: the same exposure
// (auto-exposure's), the same noise.
TEST(ColourOutputs, TheLinearSignalIsTheFrameBeforeItsToneCurve) {
    test::TempDir dir;
    const test::RunResult r = test::runCli(
        "render --frames 12 --size 96x72 --set camera.saturation=1 "
        "--outputs rgb,linear -o " +
        q(dir / "f.png"));
    ASSERT_EQ(r.exitCode, 0) << r.err;
    const double kneeLevel = shading::ParamSet()[shading::Param::Knee];
    double sumLinear = 0, sumDisplay = 0;
    for (int i : {0, 6, 11}) {
        const std::string n = "f_00" + std::string(i < 10 ? "0" : "") + std::to_string(i);
        const image::PngImage png = image::readPng(dir / (n + ".png"));
        const image::ImageF linear = image::readExr(dir / (n + ".linear.exr"));
        ASSERT_EQ(linear.width(), 96);
        ASSERT_EQ(linear.channels(), 3);
        int worst = 0;
        for (int y = 0; y < 72; ++y)
            for (int x = 0; x < 96; ++x)
                for (int c = 0; c < 3; ++c) {
                    // The scope's circular mask (radius 36 px) multiplies the
                    // display value: its soft edge is left out.
                    if (std::abs(std::hypot(x + 0.5 - 48.0, y + 0.5 - 36.0) - 36.0) < 1.5) continue;
                    const float s = linear.at(x, y, c);
                    ASSERT_GE(s, 0.0f);
                    ASSERT_LE(s, 1.0f);
                    const int expected = static_cast<int>(std::lround(knee(bt709(s), kneeLevel) * 255.0));
                    worst = std::max(worst, std::abs(expected - png.pixels.at(x, y, c)));
                    sumLinear += s;
                    sumDisplay += png.pixels.at(x, y, c) / 255.0;
                }
        EXPECT_LE(worst, 1) << n;  // float rounding at the half step
    }
    EXPECT_LT(sumLinear, 0.8 * sumDisplay);  // linear, not display values
}

// The mask marks where the specular lobe adds kHighlightMinSignal to the
// noise-free signal: against the same frames rendered without the lobe.
TEST(ColourOutputs, TheHighlightsAreWhereTheSpecularLobeAddsLight) {
    test::TempDir dir;
    const std::string common =
        " --frames 24 --size 96x72 --set camera.auto_exposure=0 --set camera.exposure_ev=-1 --set camera.full_well=0 "
        "--set camera.read_noise=0 --outputs rgb,linear,highlight";
    ASSERT_EQ(test::runCli("render" + common + " -o " + q(dir / "a.png")).exitCode, 0);
    ASSERT_EQ(test::runCli("render" + common + " --set material.specular_strength=0 -o " + q(dir / "b.png")).exitCode,
              0);
    long marked = 0, pixels = 0, disagree = 0, emptyWithout = 0;
    for (int i = 0; i < 24; ++i) {
        const std::string n = fmt::format("_{:04d}", i);
        const image::ImageF a = image::readExr(dir / ("a" + n + ".linear.exr"));
        const image::ImageF b = image::readExr(dir / ("b" + n + ".linear.exr"));
        const image::PngImage mask = image::readPng(dir / ("a" + n + ".highlight.png"));
        const image::PngImage none = image::readPng(dir / ("b" + n + ".highlight.png"));
        for (int y = 0; y < 72; ++y)
            for (int x = 0; x < 96; ++x) {
                const double added = luminance(a, x, y) - luminance(b, x, y);
                const bool expected = added >= dataset::kHighlightMinSignal;
                const bool got = mask.pixels.at(x, y) == 255;
                ASSERT_TRUE(mask.pixels.at(x, y) == 0 || got);
                if (got != expected && std::abs(added - dataset::kHighlightMinSignal) > 1e-5) ++disagree;
                marked += got;
                emptyWithout += none.pixels.at(x, y) != 0;
                ++pixels;
            }
    }
    EXPECT_EQ(disagree, 0);
    EXPECT_EQ(emptyWithout, 0);      // no specular lobe, no highlights
    EXPECT_GT(marked, 20);           // the fly-through passes glints ...
    EXPECT_LT(marked, pixels / 20);  // ... which are small
}

// camera.noise_seed: the same seed, the same bytes; another, another
// realisation of the same noise (same mean, same spread).
TEST(ColourOutputs, TheNoiseSeedGivesAnotherRealisationOfTheSameNoise) {
    test::TempDir dir;
    auto render = [&](const std::string& name, int seed) {
        const std::string args = fmt::format(
            "render --size 96x72 --set camera.auto_exposure=0 --set camera.read_noise=0.02 --set "
            "camera.noise_seed={} --outputs rgb,linear -o {}",
            seed, q(dir / name));
        EXPECT_EQ(test::runCli(args).exitCode, 0) << args;
        return image::readExr(dir / (fs::path(name).stem().string() + ".linear.exr"));
    };
    const image::ImageF a = render("a.png", 0), b = render("b.png", 5), c = render("c.png", 5);
    EXPECT_EQ(test::readBytes(dir / "b.png"), test::readBytes(dir / "c.png"));
    double sumA = 0, sumB = 0, sumDiff2 = 0;
    long n = 0;
    for (int y = 0; y < 72; ++y)
        for (int x = 0; x < 96; ++x) {
            const double va = a.at(x, y, 1), vb = b.at(x, y, 1);
            if (va <= 0.05 || va >= 0.95 || vb <= 0.05 || vb >= 0.95) continue;  // unclipped
            sumA += va, sumB += vb, sumDiff2 += (va - vb) * (va - vb);
            ++n;
        }
    ASSERT_GT(n, 1000);
    // Two independent draws of read noise 0.02 (plus shot noise): their
    // difference has a deviation of at least 0.02 x sqrt(2).
    EXPECT_GT(std::sqrt(sumDiff2 / static_cast<double>(n)), 0.02 * std::sqrt(2.0) * 0.9);
    EXPECT_NEAR(sumA / static_cast<double>(n), sumB / static_cast<double>(n), 0.003);
}

TEST(ColourOutputs, NeedOpenGlAndAPhotographicMode) {
    test::TempDir dir;
    test::expectOneErrorLine(
        test::runCli("render --reference --size 32x24 --outputs rgb,linear -o " + q(dir / "r.png")), "--reference");
    test::expectOneErrorLine(
        test::runCli("render --mode normals --size 32x24 --outputs rgb,highlight -o " + q(dir / "n.png")),
        "debug view");
    EXPECT_FALSE(fs::exists(dir / "r.png"));
    EXPECT_FALSE(fs::exists(dir / "n.png"));
}

}  // namespace
}  // namespace mucosa
