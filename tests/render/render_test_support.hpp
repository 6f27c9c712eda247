#pragma once
// Shared by the renderer's tests: one headless context per test binary (the
// tests FAIL, never skip, when EGL is unavailable), image statistics, and
// failed images written next to the expected ones for a person to look at.
#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <memory>
#include <string>

#include <gtest/gtest.h>

#include <mucosa/image/png.hpp>
#include <mucosa/render/context.hpp>
#include <mucosa/shading/params.hpp>
#include <mucosa/shading/reference.hpp>

namespace mucosa::test {

// The paper's look, for tests that measure the shading model's highlights
// rather than the default camera: the material of the paper's figures
// (k_s 0.8, n 40, no sheen, wrap or scattering), and a camera that only exposes
// (auto-exposure metering the mean; linear response, no noise, softness,
// vignetting or mask).
inline void paperLook(shading::ParamSet& p) {
    using shading::Param;
    p.setColor(Param::BaseColor, {0.8f, 0.45f, 0.4f});
    p.set(Param::SpecularStrength, 0.8f);
    p.set(Param::Shininess, 40.0f);
    p.set(Param::SheenStrength, 0.0f);
    p.set(Param::Wrap, 0.0f);
    p.set(Param::ScatterShare, 0.0f);
    p.set(Param::LightSpread, 0.0f);
    shading::setCameraIdentity(p);
    p.set(Param::AutoExposure, 1.0f);
    p.set(Param::AutoPeak, 0.0f);  // mean metering: glints barely move it
    p.set(Param::AutoKey, 0.4f);
}

inline render::HeadlessContext& glContext() {
    static std::unique_ptr<render::HeadlessContext> ctx;
    if (!ctx) ctx = std::make_unique<render::HeadlessContext>();  // throws: the test fails
    ctx->makeCurrent();
    return *ctx;
}

struct DiffStats {
    int maxDiff = 0;          // largest |a - b| over channels and pixels (0..255)
    double fractionOver = 0;  // pixels with any channel differing by more than the tolerance
    double meanAbs = 0;       // mean |a - b| per channel
    std::size_t pixelsOver = 0;
};

inline DiffStats diff(const image::Image8& a, const image::Image8& b, int tolerance) {
    DiffStats s;
    const std::size_t pixels = static_cast<std::size_t>(a.width()) * a.height();
    double sum = 0;
    for (int y = 0; y < a.height(); ++y)
        for (int x = 0; x < a.width(); ++x) {
            int worst = 0;
            for (int c = 0; c < a.channels(); ++c) {
                const int d = std::abs(int(a.at(x, y, c)) - int(b.at(x, y, c)));
                worst = std::max(worst, d);
                sum += d;
            }
            s.maxDiff = std::max(s.maxDiff, worst);
            if (worst > tolerance) ++s.pixelsOver;
        }
    s.fractionOver = double(s.pixelsOver) / double(pixels);
    s.meanAbs = sum / double(pixels * a.channels());
    return s;
}

// Where failing images go: <build>/test-output/<name>_{actual,expected,diff}.png.
inline std::filesystem::path outputDir() {
    const std::filesystem::path p = std::filesystem::current_path() / "test-output";
    std::filesystem::create_directories(p);
    return p;
}

inline void writeComparison(const std::string& name, const image::Image8& actual, const image::Image8& expected) {
    const auto dir = outputDir();
    image::writePng(dir / (name + "_actual.png"), actual);
    image::writePng(dir / (name + "_expected.png"), expected);
    image::Image8 d(actual.width(), actual.height(), 3);
    for (int y = 0; y < actual.height(); ++y)
        for (int x = 0; x < actual.width(); ++x)
            for (int c = 0; c < 3; ++c)
                d.at(x, y, c) = static_cast<std::uint8_t>(
                    std::min(255, 16 * std::abs(int(actual.at(x, y, c)) - int(expected.at(x, y, c)))));
    image::writePng(dir / (name + "_diff.png"), d);
    std::fprintf(stderr, "wrote %s_{actual,expected,diff}.png in %s\n", name.c_str(), dir.string().c_str());
}

}  // namespace mucosa::test
