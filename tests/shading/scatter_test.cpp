// Sub-surface scattering (docs/theory.md, "Light under the mucosa";
// shaders/scatter.glsl): Burley's diffusion profile and its marginal, the
// taps of the screen-space passes, and the passes of the C++ reference on
// images whose answer is known.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <numbers>
#include <vector>

#include <mucosa/shading/scatter.hpp>

namespace mucosa {
namespace {

constexpr double kPi = std::numbers::pi;

// Midpoint rule over [a, b] in t with x = a + (b - a) t^2 (the profiles' 1/r
// and log singularities at a = 0 vanish).
template <class F>
double integrate(F f, double a, double b, int steps = 20000) {
    double sum = 0.0;
    for (int i = 0; i < steps; ++i) {
        const double t = (i + 0.5) / steps;
        sum += f(a + (b - a) * t * t) * 2.0 * (b - a) * t;
    }
    return sum / steps;
}

TEST(Scatter, TheDiffusionProfileAndItsMarginalEachIntegrateToOne) {
    for (double d : {0.05, 0.2, 1.0}) {
        // Over the plane: 2 pi r R(r) dr; the tail beyond 60 d is e^-20.
        const double plane =
            integrate([&](double r) { return 2.0 * kPi * r * shading::diffusionProfile(r, d); }, 0.0, 60.0 * d);
        EXPECT_NEAR(plane, 1.0, 1e-4) << d;
        const double line = 2.0 * integrate([&](double x) { return shading::diffusionMarginal(x, d); }, 0.0, 60.0 * d);
        EXPECT_NEAR(line, 1.0, 1e-4) << d;
    }
}

TEST(Scatter, TheMarginalIsTheProfileIntegratedAlongALine) {
    const double d = 0.3;
    for (double x : {0.02, 0.1, 0.3, 1.0, 2.5}) {
        // y from 0 out: twice the half line.
        const double direct =
            2.0 * integrate([&](double y) { return shading::diffusionProfile(std::hypot(x, y), d); }, 0.0, 60.0 * d);
        EXPECT_NEAR(shading::diffusionMarginal(x, d) / direct, 1.0, 1e-3) << x;
    }
}

TEST(Scatter, TheTapsAreSymmetricNormalisedAndWidestInRed) {
    const shading::ScatterKernel k = shading::scatterKernel({0.2f, 0.1f, 0.06f});
    constexpr int side = shading::kScatterTaps / 2;
    EXPECT_EQ(k.offsetMm[side], 0.0f);
    EXPECT_NEAR(k.offsetMm[shading::kScatterTaps - 1], 2.0f, 1e-5f);  // out to 10 d of the widest
    std::array<double, 3> sum{}, second{};
    for (int i = 0; i < shading::kScatterTaps; ++i) {
        EXPECT_EQ(k.offsetMm[i], -k.offsetMm[shading::kScatterTaps - 1 - i]);
        if (i > 0) EXPECT_LT(k.offsetMm[i - 1], k.offsetMm[i]);
        for (int c = 0; c < 3; ++c) {
            EXPECT_EQ(k.weight[i][c], k.weight[shading::kScatterTaps - 1 - i][c]);
            EXPECT_GE(k.weight[i][c], 0.0f);
            sum[c] += k.weight[i][c];
            second[c] += k.weight[i][c] * k.offsetMm[i] * k.offsetMm[i];
        }
    }
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(sum[c], 1.0, 1e-5) << c;
    // The spread orders like d: red > green > blue.
    EXPECT_GT(second[0], second[1]);
    EXPECT_GT(second[1], second[2]);
    // A channel that does not scatter keeps its light where it is.
    const shading::ScatterKernel off = shading::scatterKernel({0.2f, 0.0f, 0.06f});
    EXPECT_EQ(off.weight[side][1], 1.0f);
}

// A frontal plane at depth z in a w x h frame seen through a pinhole of focal
// length f pixels; the window depth of the plane for near 1, far 100 mm.
struct Plane {
    int w = 400, h = 40;
    float f = 500.0f, z = 5.0f;
    std::array<float, 16> projection() const {
        const float n = 1.0f, fa = 100.0f;
        std::array<float, 16> p{};
        p[0] = 2.0f * f / static_cast<float>(w);
        p[5] = 2.0f * f / static_cast<float>(h);
        p[10] = -(fa + n) / (fa - n);
        p[11] = -1.0f;
        p[14] = -2.0f * fa * n / (fa - n);
        return p;
    }
    float windowDepth(float zz) const {
        const auto p = projection();
        const float ndc = (p[10] * -zz + p[14]) / zz;
        return 0.5f * ndc + 0.5f;
    }
};

TEST(Scatter, AStepOfLightSpreadsAsTheProfilesEdgeResponse) {
    // Body light 1 left of x = 200, 0 right of it, no specular: across the
    // edge the scattered share follows the profile's edge response, the
    // integral of the marginal up to the pixel; the kept share stays a step.
    const Plane s;
    const float d = 0.2f, share = 0.6f;
    const int n = s.w * s.h;
    std::vector<float> in(4 * static_cast<std::size_t>(n), 0.0f), depth(n, s.windowDepth(s.z));
    for (int y = 0; y < s.h; ++y)
        for (int x = 0; x < 200; ++x)
            for (int c = 0; c < 3; ++c) in[4 * (static_cast<std::size_t>(y) * s.w + x) + c] = 1.0f;
    const std::vector<float> out =
        shading::applyScatter(in, depth, s.w, s.h, s.projection(), shading::scatterKernel({d, d, d}), share);
    const double mmPerPx = s.z / s.f;  // 0.01 mm: d is 20 pixels
    double worst = 0.0, mean = 0.0;
    for (int x = 150; x < 250; ++x) {
        // Pixel centre x + 0.5 lies (x + 0.5 - 200) px from the edge.
        const double u = (x + 0.5 - 200.0) * mmPerPx;
        const double beyond = integrate([&](double t) { return shading::diffusionMarginal(t, d); }, 0.0, std::abs(u));
        const double response = u < 0 ? 0.5 + beyond : 0.5 - beyond;
        const double expected = share * response + (1.0 - share) * (u < 0 ? 1.0 : 0.0);
        const double error = std::abs(out[3 * (static_cast<std::size_t>(20) * s.w + x)] - expected);
        worst = std::max(worst, error);
        mean += error / 100.0;
    }
    std::printf("edge response: worst %.4f, mean %.4f of the step\n", worst, mean);
    // The taps make the response a staircase about the smooth curve, which
    // the half-size diffusion's upsampling joins linearly (measured: worst
    // 0.058, mean 0.021 of the step). A wrong width is off by more: half the
    // distance (d 0.1) moves the response by 0.048 on average.
    EXPECT_LT(worst, 0.07);
    EXPECT_LT(mean, 0.03);
    // Light is neither made nor lost: the row's total stays 200.
    double total = 0.0;
    for (int x = 0; x < s.w; ++x) total += out[3 * (static_cast<std::size_t>(20) * s.w + x)];
    EXPECT_NEAR(total, 200.0, 0.5);
}

TEST(Scatter, AnEvenlyLitSurfaceKeepsItsLightAndTheSpecularStaysSharp) {
    const Plane s;
    const int n = s.w * s.h;
    std::vector<float> in(4 * static_cast<std::size_t>(n)), depth(n, s.windowDepth(s.z));
    for (int i = 0; i < n; ++i) in[4 * i] = 0.8f, in[4 * i + 1] = 0.4f, in[4 * i + 2] = 0.3f, in[4 * i + 3] = 0.0f;
    const std::size_t glint = static_cast<std::size_t>(20) * s.w + 100;
    in[4 * glint + 3] = 5.0f;  // one pixel of the film's specular
    const std::vector<float> out =
        shading::applyScatter(in, depth, s.w, s.h, s.projection(), shading::scatterKernel({0.3f, 0.1f, 0.05f}), 1.0f);
    for (int i = 0; i < n; ++i) {
        const float spec = static_cast<std::size_t>(i) == glint ? 5.0f : 0.0f;
        ASSERT_NEAR(out[3 * i], 0.8f + spec, 1e-5f);
        ASSERT_NEAR(out[3 * i + 1], 0.4f + spec, 1e-5f);
        ASSERT_NEAR(out[3 * i + 2], 0.3f + spec, 1e-5f);
    }
}

TEST(Scatter, LightDoesNotDiffuseAcrossASilhouette) {
    // A bright near surface (5 mm) left of x = 200 in front of a dark far one
    // (40 mm): the near pixels by the edge keep their light, the far ones
    // gain none (light scatters under one surface, not between two).
    const Plane s;
    const int n = s.w * s.h;
    std::vector<float> in(4 * static_cast<std::size_t>(n), 0.0f), depth(n);
    for (int y = 0; y < s.h; ++y)
        for (int x = 0; x < s.w; ++x) {
            const std::size_t i = static_cast<std::size_t>(y) * s.w + x;
            const bool nearSide = x < 200;
            depth[i] = s.windowDepth(nearSide ? 5.0f : 40.0f);
            for (int c = 0; c < 3; ++c) in[4 * i + c] = nearSide ? 1.0f : 0.0f;
        }
    const std::vector<float> out =
        shading::applyScatter(in, depth, s.w, s.h, s.projection(), shading::scatterKernel({0.3f, 0.3f, 0.3f}), 1.0f);
    for (int x = 180; x < 220; ++x)
        EXPECT_NEAR(out[3 * (static_cast<std::size_t>(20) * s.w + x)], x < 200 ? 1.0f : 0.0f, 1e-5f) << x;
    // Where no surface was drawn (window depth 1) the pixel stays as it is.
    std::vector<float> empty(n, 1.0f);
    const std::vector<float> none =
        shading::applyScatter(in, empty, s.w, s.h, s.projection(), shading::scatterKernel({0.3f, 0.3f, 0.3f}), 1.0f);
    EXPECT_EQ(none[3 * 199], 1.0f);
    EXPECT_EQ(none[3 * 200], 0.0f);
}

}  // namespace
}  // namespace mucosa
