// The procedural path's GLSL (shaders/procedural_noise.glsl, compiled here as
// C++) against the noise module's double reference, and the specular
// anti-aliasing equations (Toksvig lobe, the map's mip chain).
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include <mucosa/noise/gradient.hpp>
#include <mucosa/reflectance/map.hpp>
#include <mucosa/reflectance/normal_map.hpp>
#include <mucosa/reflectance/specular_mips.hpp>

#include "shading/glsl.hpp"

namespace mucosa {
namespace {

using namespace shading::glsl;

TEST(ProceduralNoise, GlslNoiseEqualsTheReferenceToFloatPrecision) {
    for (std::uint64_t seed : {0ull, 77ull}) {
        const noise::Permutation perm = noise::Permutation::fromSeed(seed);
        const PermutationScope scope(perm.table().data());
        std::mt19937_64 rng(seed + 1);
        std::uniform_real_distribution<float> d(-100.0f, 100.0f);
        double worstValue = 0, worstGrad = 0;
        for (int i = 0; i < 20000; ++i) {
            const glm::vec3 p(d(rng), d(rng), d(rng));
            const glm::vec4 g = perlinNoiseGradient(p, glm::vec3(256.0f));
            // The plain lattice's cheaper indexing gives the same numbers.
            const glm::vec4 plain = perlinNoiseGradient(p);
            ASSERT_EQ(plain.x, g.x);
            ASSERT_EQ(plain.y, g.y);
            ASSERT_EQ(plain.z, g.z);
            ASSERT_EQ(plain.w, g.w);
            const noise::NoiseGradient r = noise::perlinGradient(perm, p.x, p.y, p.z);
            worstValue = std::max(worstValue, std::fabs(g.x - r.value));
            worstGrad = std::max({worstGrad, std::fabs(g.y - r.dx), std::fabs(g.z - r.dy), std::fabs(g.w - r.dz)});
        }
        std::printf("seed %llu: GLSL-as-C++ noise vs double: value %.3g, gradient %.3g\n",
                    static_cast<unsigned long long>(seed), worstValue, worstGrad);
        EXPECT_LT(worstValue, 2e-5);
        EXPECT_LT(worstGrad, 2e-4);
    }
}

TEST(ProceduralNoise, PeriodicLatticeMatchesPerlinPeriodic) {
    const noise::Permutation& perm = noise::Permutation::reference();
    const PermutationScope scope(perm.table().data());
    std::mt19937_64 rng(2);
    std::uniform_real_distribution<float> d(-50.0f, 50.0f);
    for (int i = 0; i < 5000; ++i) {
        const glm::vec3 p(d(rng), d(rng), d(rng));
        const glm::vec4 g = perlinNoiseGradient(p, glm::vec3(16.0f, 7.0f, 256.0f));
        const noise::NoiseGradient r = noise::perlinPeriodicGradient(perm, p.x, p.y, p.z, 16, 7, 256);
        ASSERT_NEAR(g.x, r.value, 2e-5);
        ASSERT_NEAR(g.y, r.dx, 2e-4);
        ASSERT_NEAR(g.z, r.dy, 2e-4);
    }
}

TEST(ProceduralNoise, PairedLookupsGiveTheSameNoise) {
    // A z slice through perlinNoiseGradientSlice's paired lookups and
    // composed slice table: bit for bit the general periodic path (periodic
    // in x and y, 256 along z; wraps to 0 and period 1 included) and plain
    // noise, z from -300 to 300.
    for (std::uint64_t seed : {0ull, 5ull}) {
        const noise::Permutation perm = noise::Permutation::fromSeed(seed);
        const PermutationScope scope(perm.table().data());
        std::mt19937_64 rng(seed + 11);
        std::uniform_real_distribution<float> d(-300.0f, 300.0f);
        for (const glm::vec2 period : {glm::vec2(16.0f, 5.0f), glm::vec2(1.0f, 256.0f), glm::vec2(255.0f, 2.0f)})
            for (int i = 0; i < 20000; ++i) {
                const glm::vec3 p(d(rng), d(rng), d(rng));
                const glm::vec4 general = perlinNoiseGradient(p, glm::vec3(period.x, period.y, 256.0f));
                const glm::vec4 slice = perlinNoiseGradientSlice(p, period);
                ASSERT_EQ(slice.x, general.x) << p.x << " " << p.y << " " << p.z;
                ASSERT_EQ(slice.y, general.y);
                ASSERT_EQ(slice.z, general.z);
                ASSERT_EQ(slice.w, general.w);
                const glm::vec4 plainSlice = perlinNoiseGradientSlice(p, glm::vec2(256.0f));
                const glm::vec4 plain = perlinNoiseGradient(p);
                ASSERT_EQ(plainSlice.x, plain.x);
                ASSERT_EQ(plainSlice.y, plain.y);
                ASSERT_EQ(plainSlice.z, plain.z);
                ASSERT_EQ(plainSlice.w, plain.w);
            }
    }
}

// The settings the renderer would pack for these noise parameters: unit
// strength and scale, no anti-aliasing, no map response.
Procedural settings(const noise::FractalParams& n, int space) {
    shading::FrameSetup f;
    f.procedural.noise = n;
    f.procedural.strength = 1.0f;
    f.procedural.space = space == kSpaceObject ? shading::NoiseSpace::Object : shading::NoiseSpace::Uv;
    f.procedural.texels = 0;
    f.params.set(shading::Param::NoiseScale, 1.0f);
    f.specularAA = false;
    return packProcedural(f);
}

TEST(ProceduralNoise, FractalSumsAreTheMapsAndTheSolidSum) {
    for (const char* preset : {"bronchial", "rough", "serosa"}) {
        const noise::FractalParams n = reflectance::findPreset(preset).params.noise;
        const noise::Permutation perm = noise::Permutation::fromSeed(n.seed);
        const PermutationScope scope(perm.table().data());
        std::mt19937_64 rng(4);
        std::uniform_real_distribution<float> d(0.0f, 1.0f);
        for (int i = 0; i < 3000; ++i) {
            const float u = d(rng), v = d(rng);
            const FractalSample s = fractalNoise(glm::vec3(u, v, 0.0f), 0.0f, settings(n, kSpaceUv));
            const noise::NoiseGradient r = noise::fractalGradient(n, perm, u, v);
            ASSERT_NEAR(s.h.x, r.value, 1e-4) << preset;
            // Gradients scale with the top octave's frequency (up to 512).
            ASSERT_NEAR(s.h.y, r.dx, 2e-2) << preset;
            ASSERT_NEAR(s.h.z, r.dy, 2e-2) << preset;
            EXPECT_EQ(s.fadedVariance, 0.0f);
            const glm::vec3 q(d(rng) * 10, d(rng) * 10, d(rng) * 10);
            const FractalSample o = fractalNoise(q, 0.0f, settings(n, kSpaceObject));
            const noise::NoiseGradient ro = noise::solidFractalGradient(n, perm, q.x, q.y, q.z);
            ASSERT_NEAR(o.h.x, ro.value, 2e-4) << preset;
            ASSERT_NEAR(o.h.w, ro.dz, 5e-2) << preset;
        }
    }
}

TEST(ProceduralNoise, SlopeVarianceConstantIsTheMeasuredOne) {
    EXPECT_NEAR(kNoiseSlopeVariance, noise::perlinGradientComponentVariance(), 1e-4);
}

TEST(ProceduralNoise, OctavesFadeAtThePixelFootprintAndTheirVarianceIsKept) {
    noise::FractalParams n;
    n.frequency = 4;
    n.octaves = 6;  // 4 .. 128 cycles per unit
    n.tileable = true;
    const noise::Permutation& perm = noise::Permutation::reference();
    const PermutationScope scope(perm.table().data());
    Procedural pr = settings(n, kSpaceUv);
    pr.antialias = 1;
    const glm::vec3 q(0.3f, 0.6f, 0.0f);
    // Footprint 1/1024: every octave (<= 128 cycles) is below 0.35 cycles per pixel.
    EXPECT_EQ(fractalNoise(q, 1.0f / 1024.0f, pr).fadedVariance, 0.0f);
    // Footprint 1/64: 64 and 128 cycles reach 1 and 2 cycles per pixel and
    // fade completely, 32 (0.5 c/px) partly, 16 (0.25 c/px) not at all.
    const FractalSample s = fractalNoise(q, 1.0f / 64.0f, pr);
    float full = 0, faded = 0, f = 4, a = 1;
    for (int i = 0; i < 6; ++i, f *= 2, a *= 0.5f) {
        full += (a * f) * (a * f);
        if (f >= 64) faded += (a * f) * (a * f);
    }
    EXPECT_GT(s.fadedVariance, faded * kNoiseSlopeVariance);
    EXPECT_LT(s.fadedVariance, (faded + 16.0f) * kNoiseSlopeVariance);  // + octave 32: (a f)^2 = 16
    // A footprint wider than the base octave's period fades every octave.
    const FractalSample all = fractalNoise(q, 1.0f, pr);
    EXPECT_EQ(all.h, glm::vec4(0.0f));
    EXPECT_NEAR(all.fadedVariance, full * kNoiseSlopeVariance, 1e-3);
}

TEST(SpecularAA, ToksvigWidensTheLobeAndKeepsItsEnergy) {
    EXPECT_EQ(toksvigShininess(40.0f, 0.0f), 40.0f);
    EXPECT_NEAR(toksvigShininess(40.0f, 0.01f), 40.0f / 2.6f, 1e-5);
    // Energy: integral of (cos t)^n over the hemisphere is 2 pi / (n + 1);
    // methodSpecular scales the wider lobe by (n' + 1) / (n + 1).
    const float n = 60.0f, sigma2 = 0.02f;
    const float nEff = toksvigShininess(n, sigma2);
    auto integral = [](auto lobe) {
        double sum = 0;
        const int steps = 20000;
        for (int i = 0; i < steps; ++i) {
            const double t = (i + 0.5) / steps * 1.5707963267948966;
            sum += lobe(t) * std::sin(t) * (1.5707963267948966 / steps);
        }
        return 2 * 3.141592653589793 * sum;
    };
    const glm::vec3 N(0, 0, 1), L(0, 0, 1);
    const double sharp =
        integral([&](double t) { return methodSpecular(N, L, glm::vec3(std::sin(t), 0, std::cos(t)), 0.0f, n); });
    const double wide =
        integral([&](double t) { return methodSpecular(N, L, glm::vec3(std::sin(t), 0, std::cos(t)), sigma2, n); });
    EXPECT_LT(methodSpecular(N, L, N, sigma2, n), 1.0f);  // lower peak
    EXPECT_NEAR(wide / sharp, 1.0, 0.02);                 // same energy
    EXPECT_GT(nEff, 1.0f);
}

TEST(SpecularAA, MipChainStoresTheAveragedDirectionAndToksvigVariance) {
    reflectance::MapParams p = reflectance::findPreset("bronchial").params;
    p.size = 256;
    const image::ImageF h = reflectance::heightField(p);
    const image::Image8 map = reflectance::encodeNormals8(h, p.strength, reflectance::Edges::Wrap);
    const std::vector<image::Image8> chain = reflectance::specularMipChain(map);
    ASSERT_EQ(chain.size(), 9u);  // 256 .. 1
    EXPECT_EQ(chain[0].channels(), 4);
    EXPECT_EQ(chain.back().width(), 1);
    for (int y = 0; y < 256; y += 17)
        for (int x = 0; x < 256; x += 13) {
            EXPECT_EQ(chain[0].at(x, y, 0), map.at(x, y, 0));
            EXPECT_EQ(chain[0].at(x, y, 3), 0);
        }
    // Variance grows with the level (more texels averaged) and the coarsest
    // level's equals Toksvig's estimate from the mean of all unit normals.
    double mean[3] = {0, 0, 0};
    for (int y = 0; y < 256; ++y)
        for (int x = 0; x < 256; ++x) {
            double n[3], len = 0;
            for (int c = 0; c < 3; ++c) n[c] = map.at(x, y, c) / 127.5 - 1, len += n[c] * n[c];
            for (int c = 0; c < 3; ++c) mean[c] += n[c] / std::sqrt(len) / 65536.0;
        }
    const double len = std::sqrt(mean[0] * mean[0] + mean[1] * mean[1] + mean[2] * mean[2]);
    const double toksvig = (1 - len) / len;
    const double top = reflectance::mipSlopeVariance(chain.back(), 0, 0);
    std::printf("bronchial 256: Toksvig variance of the whole map %.5f, stored %.5f\n", toksvig, top);
    EXPECT_NEAR(top, toksvig, 0.1 * toksvig + 1e-4);
    double prev = 0;
    for (std::size_t k = 1; k < chain.size(); ++k) {
        double sum = 0;
        for (int y = 0; y < chain[k].height(); ++y)
            for (int x = 0; x < chain[k].width(); ++x) sum += reflectance::mipSlopeVariance(chain[k], x, y);
        const double m = sum / (chain[k].width() * chain[k].height());
        EXPECT_GE(m, prev * 0.98) << "level " << k;
        prev = m;
    }
}

TEST(ProceduralNoise, MapSlopeResponseIsTheMeasuredCentralDifferenceGain) {
    // RMS of the central difference over +-s against the true slope, improved
    // noise on the slice z = 0.5 (what a map stores), at s cells per texel.
    for (double s : {0.5, 0.4, 0.25, 0.125, 0.0625}) {
        double truth = 0, differenced = 0;
        for (int i = 0; i < 256; ++i)
            for (int j = 0; j < 256; ++j) {
                const double x = i * 0.0731 + 0.013, y = j * 0.0517 + 0.29;
                const double g = noise::perlinGradient(noise::Permutation::reference(), x, y, 0.5).dx;
                const double cd = (noise::perlin(x + s, y, 0.5) - noise::perlin(x - s, y, 0.5)) / (2 * s);
                truth += g * g;
                differenced += cd * cd;
            }
        const double measured = std::sqrt(differenced / truth);
        const float model = mapSlopeResponse(static_cast<float>(s * 1024), 1024.0f);
        std::printf("s = %.4f cells/texel: measured gain %.4f, model %.4f\n", s, measured, model);
        EXPECT_NEAR(model, measured, 0.015) << s;
    }
    EXPECT_EQ(mapSlopeResponse(512.0f, 0.0f), 1.0f);  // no map: the analytic surface
}

}  // namespace
}  // namespace mucosa
