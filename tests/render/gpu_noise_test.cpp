// GLSL noise on the GPU (rendered to a 32-bit float target) against the
// noise module at the same points: |diff| <= 1e-4.
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <random>

#include <mucosa/noise/gradient.hpp>
#include <mucosa/reflectance/map.hpp>
#include <mucosa/render/gpu_noise.hpp>

#include "render_test_support.hpp"

namespace mucosa {
namespace {

using render::GpuNoiseFunction;

std::vector<std::array<float, 3>> randomPoints(std::size_t n, float lo, float hi, std::uint64_t seed) {
    std::mt19937_64 rng(seed);
    std::uniform_real_distribution<float> d(lo, hi);
    std::vector<std::array<float, 3>> p(n);
    for (auto& q : p) q = {d(rng), d(rng), d(rng)};
    return p;
}

struct Worst {
    double value = 0, gradient = 0;
};

TEST(GpuNoise, ImprovedNoiseOnTheGpuEqualsTheReference) {
    test::glContext();
    for (std::uint64_t seed : {0ull, 1234ull}) {
        render::GpuNoiseRequest req;
        req.params.seed = seed;
        const auto points = randomPoints(50000, -200.0f, 200.0f, seed + 3);
        const auto gpu = render::evaluateNoiseOnGpu(req, points);
        const noise::Permutation perm = noise::Permutation::fromSeed(seed);
        Worst w;
        for (std::size_t i = 0; i < points.size(); ++i) {
            const auto& p = points[i];
            const noise::NoiseGradient r = noise::perlinGradient(perm, p[0], p[1], p[2]);
            w.value = std::max(w.value, std::fabs(gpu[i][0] - r.value));
            w.gradient = std::max(
                {w.gradient, std::fabs(gpu[i][1] - r.dx), std::fabs(gpu[i][2] - r.dy), std::fabs(gpu[i][3] - r.dz)});
        }
        std::printf("GPU noise, seed %llu, 50000 points in [-200, 200]^3: max |value diff| %.3g, gradient %.3g\n",
                    static_cast<unsigned long long>(seed), w.value, w.gradient);
        EXPECT_LE(w.value, 1e-4);
        EXPECT_LE(w.gradient, 1e-3);
        // The published value, through the GPU.
        const auto pub = render::evaluateNoiseOnGpu({}, std::vector<std::array<float, 3>>{{3.14f, 42.0f, 7.0f}});
        EXPECT_NEAR(pub[0][0], noise::perlin(3.14f, 42.0f, 7.0f), 1e-6);
    }
}

TEST(GpuNoise, PeriodicLatticeOnTheGpuEqualsPerlinPeriodic) {
    test::glContext();
    // Wraps to 0 in x and y, period 1 included (the texture-space sums'
    // slice path is checked against the map's sums below).
    const std::array<int, 3> periods[] = {{16, 5, 256}, {1, 256, 256}, {255, 3, 256}, {16, 5, 7}};
    for (const std::array<int, 3>& period : periods) {
        render::GpuNoiseRequest req;
        req.period = period;
        const auto points = randomPoints(20000, -64.0f, 64.0f, 9);
        const auto gpu = render::evaluateNoiseOnGpu(req, points);
        for (std::size_t i = 0; i < points.size(); ++i) {
            const auto& p = points[i];
            const noise::NoiseGradient r = noise::perlinPeriodicGradient(noise::Permutation::reference(), p[0], p[1],
                                                                         p[2], period[0], period[1], period[2]);
            ASSERT_NEAR(gpu[i][0], r.value, 1e-4) << p[0] << " " << p[1] << " " << p[2];
            ASSERT_NEAR(gpu[i][1], r.dx, 1e-3);
            ASSERT_NEAR(gpu[i][2], r.dy, 1e-3);
            ASSERT_NEAR(gpu[i][3], r.dz, 1e-3);
        }
    }
}

TEST(GpuNoise, FractalSumsOnTheGpuEqualTheMapAndTheSolidSums) {
    test::glContext();
    for (const char* preset : {"bronchial", "serosa", "rough", "fine"}) {
        const noise::FractalParams fp = reflectance::findPreset(preset).params.noise;
        const noise::Permutation perm = noise::Permutation::fromSeed(fp.seed);
        render::GpuNoiseRequest uv;
        uv.function = GpuNoiseFunction::FractalUv;
        uv.params = fp;
        auto points = randomPoints(20000, 0.0f, 1.0f, 21);
        const auto gpu = render::evaluateNoiseOnGpu(uv, points);
        double worst = 0;
        for (std::size_t i = 0; i < points.size(); ++i)
            worst = std::max(worst,
                             std::fabs(gpu[i][0] - noise::fractalGradient(fp, perm, points[i][0], points[i][1]).value));
        render::GpuNoiseRequest solid = uv;
        solid.function = GpuNoiseFunction::FractalSolid;
        points = randomPoints(20000, -5.0f, 5.0f, 22);
        const auto gpuSolid = render::evaluateNoiseOnGpu(solid, points);
        double worstSolid = 0;
        for (std::size_t i = 0; i < points.size(); ++i) {
            const auto& p = points[i];
            worstSolid = std::max(
                worstSolid, std::fabs(gpuSolid[i][0] - noise::solidFractalGradient(fp, perm, p[0], p[1], p[2]).value));
        }
        std::printf("GPU fractal '%s': map sum max |diff| %.3g, solid sum %.3g\n", preset, worst, worstSolid);
        EXPECT_LE(worst, 1e-4) << preset;
        EXPECT_LE(worstSolid, 1e-4) << preset;
    }
    // Other z slices (the texture-space sum reads a table made for its slice),
    // tileable and not.
    for (const double z : {37.25, -300.5, 255.75})
        for (const bool tileable : {true, false}) {
            render::GpuNoiseRequest uv;
            uv.function = GpuNoiseFunction::FractalUv;
            uv.params = reflectance::findPreset("bronchial").params.noise;
            uv.params.z = z;
            uv.params.tileable = tileable;
            uv.params.seed = 9;
            const noise::Permutation perm = noise::Permutation::fromSeed(uv.params.seed);
            const auto points = randomPoints(5000, 0.0f, 1.0f, 23);
            const auto gpu = render::evaluateNoiseOnGpu(uv, points);
            for (std::size_t i = 0; i < points.size(); ++i)
                ASSERT_NEAR(gpu[i][0], noise::fractalGradient(uv.params, perm, points[i][0], points[i][1]).value, 1e-4)
                    << "z " << z << (tileable ? " tileable" : " plain");
        }
}

}  // namespace
}  // namespace mucosa
