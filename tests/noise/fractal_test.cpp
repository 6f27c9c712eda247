#include <mucosa/noise/fractal.hpp>

#include <cmath>
#include <cstring>
#include <vector>

#include <gtest/gtest.h>

#include <mucosa/core/error.hpp>

using namespace mucosa::noise;

namespace {

FractalParams params(double f, int oct, double lac, double gain, std::uint64_t seed, bool turb, bool tile,
                     double z = 0.0) {
    FractalParams p;
    p.frequency = f;
    p.octaves = oct;
    p.lacunarity = lac;
    p.gain = gain;
    p.seed = seed;
    p.turbulence = turb;
    p.tileable = tile;
    p.z = z;
    return p;
}

const std::vector<FractalParams>& cases() {
    static const std::vector<FractalParams> c = {
        params(8, 6, 2.0, 0.5, 0, false, false),             // the benchmark job
        params(8, 6, 2.0, 0.5, 0, false, true),              // tileable
        params(5, 4, 3.0, 0.6, 0, true, true, 0.37),         // turbulence, lacunarity 3
        params(3.7, 5, 1.93, 0.45, 99, false, false, 11.5),  // irrational-ish, seeded
        params(1, 1, 2.0, 0.5, 5, false, false),             // one octave: plain noise
        params(300, 2, 2.0, 0.5, 0, false, false),           // cells narrower than a vector
        params(16, 3, 2.0, 0.5, 0, true, true, -2.25),       // negative z slice
    };
    return c;
}

}  // namespace

TEST(Fractal, OneOctaveIsPlainNoiseAtScaledCoordinates) {
    const auto p = params(6.5, 1, 2.0, 0.5, 0, false, false, 0.3);
    for (double u : {0.0, 0.1, 0.333, 0.999})
        for (double v : {0.0, 0.25, 0.77}) EXPECT_EQ(fractal(p, u, v), perlin(6.5 * u, 6.5 * v, 0.3));
}

TEST(Fractal, SumsOctavesWithGainAndLacunarity) {
    const auto p = params(2, 3, 2.5, 0.4, 0, false, false, 0.5);
    const double u = 0.3141, v = 0.2718;
    double expected = 0, f = 2, a = 1;
    for (int i = 0; i < 3; ++i, f *= 2.5, a *= 0.4) expected += a * perlin(f * u, f * v, 0.5);
    EXPECT_EQ(fractal(p, u, v), expected);
}

TEST(Fractal, TurbulenceIsNonNegativeAndBoundedByAmplitudeSum) {
    const auto p = params(4, 5, 2, 0.5, 3, true, false, 0.5);
    double bound = 0, a = 1;
    for (int i = 0; i < 5; ++i, a *= 0.5) bound += a * 1.05;
    for (int i = 0; i < 1000; ++i) {
        const double t = fractal(p, i * 0.00097, i * 0.00131);
        EXPECT_GE(t, 0.0);
        EXPECT_LE(t, bound);
    }
}

TEST(Fractal, TileableMapWrapsExactlyAtTheEdges) {
    const auto p = params(8, 5, 2, 0.5, 0, false, true, 0.5);
    for (double t : {0.0, 0.13, 0.5, 0.71}) {
        EXPECT_NEAR(fractal(p, 1.0, t), fractal(p, 0.0, t), 1e-12);
        EXPECT_NEAR(fractal(p, t, 1.0), fractal(p, t, 0.0), 1e-12);
    }
}

TEST(FastPath, DoubleEqualsScalarReferenceSampleBySample) {
    for (const FractalParams& p : cases()) {
        for (auto [w, h] : {std::pair{257, 61}, std::pair{64, 64}, std::pair{1, 5}, std::pair{1000, 3}}) {
            std::vector<double> img(static_cast<std::size_t>(w) * h);
            fillFractal(p, img, w, h, {1});
            const Permutation perm = Permutation::fromSeed(p.seed);
            for (int y = 0; y < h; ++y)
                for (int x = 0; x < w; ++x) {
                    const double ref = fractal(p, perm, static_cast<double>(x) / w, static_cast<double>(y) / h);
                    // Bit-exact up to the sign of zero (== treats -0 == +0).
                    ASSERT_EQ(img[static_cast<std::size_t>(y) * w + x], ref)
                        << "f=" << p.frequency << " " << w << "x" << h << " at " << x << "," << y;
                }
        }
    }
}

TEST(FastPath, FloatStaysWithin1e5OfScalarReference) {
    for (const FractalParams& p : cases()) {
        const int w = 512, h = 37;
        std::vector<float> img(static_cast<std::size_t>(w) * h);
        fillFractal(p, img, w, h, {2});
        const Permutation perm = Permutation::fromSeed(p.seed);
        double worst = 0;
        for (int y = 0; y < h; ++y)
            for (int x = 0; x < w; ++x) {
                const double ref = fractal(p, perm, static_cast<double>(x) / w, static_cast<double>(y) / h);
                worst = std::max(worst, std::fabs(img[static_cast<std::size_t>(y) * w + x] - ref));
            }
        EXPECT_LE(worst, 1e-5) << "f=" << p.frequency;
    }
}

// Very fine noise on a wide map: the float path's per-cell table would pass
// its memory cap (8000 cells x 256 lattice rows x 12 fields), so it hashes per
// cell instead; the values must not change.
TEST(FastPath, FloatWithoutTheCellTableStaysWithin1e5) {
    const auto p = params(8000, 2, 2.0, 0.5, 3, false, false, 0.4);
    const int w = 8192, h = 256;
    std::vector<float> img(static_cast<std::size_t>(w) * h);
    fillFractal(p, img, w, h, {2});
    const Permutation perm = Permutation::fromSeed(p.seed);
    double worst = 0;
    for (int y = 0; y < h; y += 5)
        for (int x = 0; x < w; x += 3) {
            const double ref = fractal(p, perm, static_cast<double>(x) / w, static_cast<double>(y) / h);
            worst = std::max(worst, std::fabs(img[static_cast<std::size_t>(y) * w + x] - ref));
        }
    EXPECT_LE(worst, 1e-5);
}

TEST(FastPath, OutputIsIdenticalForAnyThreadCount) {
    const auto p = params(8, 6, 2, 0.5, 0, false, true);
    const int w = 640, h = 333;
    std::vector<float> ref(static_cast<std::size_t>(w) * h);
    std::vector<double> refD(ref.size());
    fillFractal(p, ref, w, h, {1});
    fillFractal(p, refD, w, h, {1});
    for (int threads : {2, 3, 4, 7, 16}) {
        std::vector<float> img(ref.size());
        std::vector<double> imgD(ref.size());
        fillFractal(p, img, w, h, {threads});
        fillFractal(p, imgD, w, h, {threads});
        EXPECT_EQ(std::memcmp(img.data(), ref.data(), ref.size() * sizeof(float)), 0) << threads;
        EXPECT_EQ(std::memcmp(imgD.data(), refD.data(), refD.size() * sizeof(double)), 0) << threads;
    }
}

TEST(FastPath, ReportsTheDispatchedInstructionSet) {
    const std::string isa = fastPathIsa();
    EXPECT_TRUE(isa == "avx512f" || isa == "avx2" || isa == "default") << isa;
}

TEST(FractalValidation, RejectsParametersThatCannotBeEvaluated) {
    using mucosa::InputError;
    EXPECT_THROW(validate(params(NAN, 4, 2, 0.5, 0, false, false)), InputError);
    EXPECT_THROW(validate(params(-1, 4, 2, 0.5, 0, false, false)), InputError);
    EXPECT_THROW(validate(params(0, 4, 2, 0.5, 0, false, false)), InputError);
    EXPECT_THROW(validate(params(4, 0, 2, 0.5, 0, false, false)), InputError);
    EXPECT_THROW(validate(params(4, 33, 2, 0.5, 0, false, false)), InputError);
    EXPECT_THROW(validate(params(4, 4, INFINITY, 0.5, 0, false, false)), InputError);
    EXPECT_THROW(validate(params(4, 4, 2, -0.5, 0, false, false)), InputError);
    EXPECT_THROW(validate(params(4.5, 4, 2, 0.5, 0, false, true)), InputError);  // tileable needs whole cycles
    EXPECT_THROW(validate(params(4, 4, 1.5, 0.5, 0, false, true)), InputError);
    EXPECT_THROW(validate(params(3, 9, 2, 0.5, 0, false, true)), InputError);  // 384 cycles: not a multiple of 256
    EXPECT_NO_THROW(validate(params(4, 8, 2, 0.5, 0, false, true)));           // 512 cycles: fine
    try {
        validate(params(-1, 4, 2, 0.5, 0, false, false));
    } catch (const InputError& e) {
        EXPECT_EQ(e.subject(), "frequency");
    }
}

TEST(FractalValidation, CountsResolvableOctaves) {
    EXPECT_EQ(resolvableOctaves(params(8, 6, 2, 0.5, 0, false, false), 4096), 6);
    EXPECT_EQ(resolvableOctaves(params(8, 6, 2, 0.5, 0, false, false), 64), 3);  // 8, 16, 32 <= 32
    EXPECT_EQ(resolvableOctaves(params(8, 6, 2, 0.5, 0, false, false), 8), 0);
}
