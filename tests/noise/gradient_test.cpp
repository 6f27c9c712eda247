// Analytic gradients of improved noise and of the fractal sums (the reference
// for the run-time procedural path): values equal the plain functions
// exactly, gradients match central differences of the double reference.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include <mucosa/noise/gradient.hpp>

namespace mucosa::noise {
namespace {

constexpr double kH = 1e-6;  // central-difference step: truncation ~1e-10, rounding ~1e-10

template <class F>
std::array<double, 3> centralDifferences(F f, double x, double y, double z) {
    return {(f(x + kH, y, z) - f(x - kH, y, z)) / (2 * kH), (f(x, y + kH, z) - f(x, y - kH, z)) / (2 * kH),
            (f(x, y, z + kH) - f(x, y, z - kH)) / (2 * kH)};
}

TEST(NoiseGradient, ValueIsThePlainNoiseBitForBitAndTheGradientMatchesDifferences) {
    std::mt19937_64 rng(7);
    std::uniform_real_distribution<double> d(-300.0, 300.0);
    const Permutation& ref = Permutation::reference();
    const Permutation seeded = Permutation::fromSeed(42);
    double worst = 0;
    for (int i = 0; i < 20000; ++i) {
        const double x = d(rng), y = d(rng), z = d(rng);
        for (const Permutation* p : {&ref, &seeded}) {
            const NoiseGradient g = perlinGradient(*p, x, y, z);
            ASSERT_EQ(g.value, perlin(*p, x, y, z)) << x << " " << y << " " << z;
            const auto fd =
                centralDifferences([&](double a, double b, double c) { return perlin(*p, a, b, c); }, x, y, z);
            worst = std::max({worst, std::fabs(g.dx - fd[0]), std::fabs(g.dy - fd[1]), std::fabs(g.dz - fd[2])});
        }
    }
    std::printf("noise gradient vs central differences: max |diff| %.3g over 40000 points\n", worst);
    EXPECT_LT(worst, 1e-6);
    // The published point (Perlin 2002) and a lattice point, where n = 0 and
    // the gradient is the corner's own gradient vector (one of the 12 edges).
    EXPECT_EQ(perlinGradient(ref, 3.14, 42, 7).value, 0.13691995878400012);
    const NoiseGradient lattice = perlinGradient(ref, 3, 5, 11);
    EXPECT_EQ(lattice.value, 0.0);
    EXPECT_EQ(std::fabs(lattice.dx) + std::fabs(lattice.dy) + std::fabs(lattice.dz), 2.0);
}

TEST(NoiseGradient, PeriodicVariantWrapsAndMatchesDifferences) {
    std::mt19937_64 rng(11);
    std::uniform_real_distribution<double> d(-40.0, 40.0);
    const Permutation& p = Permutation::reference();
    for (int i = 0; i < 5000; ++i) {
        const double x = d(rng), y = d(rng), z = d(rng);
        const NoiseGradient g = perlinPeriodicGradient(p, x, y, z, 16, 8, 256);
        ASSERT_EQ(g.value, perlinPeriodic(p, x, y, z, 16, 8, 256));
        const NoiseGradient shifted = perlinPeriodicGradient(p, x + 16, y - 8, z, 16, 8, 256);
        EXPECT_NEAR(shifted.value, g.value, 1e-12);
        EXPECT_NEAR(shifted.dx, g.dx, 1e-9);
        const auto fd = centralDifferences(
            [&](double a, double b, double c) { return perlinPeriodic(p, a, b, c, 16, 8, 256); }, x, y, z);
        EXPECT_NEAR(g.dx, fd[0], 1e-6);
        EXPECT_NEAR(g.dy, fd[1], 1e-6);
        EXPECT_NEAR(g.dz, fd[2], 1e-6);
    }
}

TEST(NoiseGradient, FractalSumsMatchTheMapSumAndItsDifferences) {
    std::mt19937_64 rng(3);
    std::uniform_real_distribution<double> d(0.0, 1.0);
    for (bool tileable : {true, false})
        for (bool turbulence : {false, true}) {
            FractalParams fp;
            fp.frequency = 8;
            fp.octaves = 5;
            fp.tileable = tileable;
            fp.turbulence = turbulence;
            fp.seed = 9;
            const Permutation perm = Permutation::fromSeed(fp.seed);
            for (int i = 0; i < 2000; ++i) {
                const double u = d(rng), v = d(rng);
                const NoiseGradient g = fractalGradient(fp, perm, u, v);
                ASSERT_EQ(g.value, fractal(fp, perm, u, v));
                EXPECT_EQ(g.dz, 0.0);
                const auto fd =
                    centralDifferences([&](double a, double b, double) { return fractal(fp, perm, a, b); }, u, v, 0.0);
                // |n| has a kink at n = 0: skip points within a step of one.
                if (turbulence && std::fabs(fd[0] - g.dx) > 1e-3) continue;
                EXPECT_NEAR(g.dx, fd[0], 1e-4 * (1 + std::fabs(g.dx)));
                EXPECT_NEAR(g.dy, fd[1], 1e-4 * (1 + std::fabs(g.dy)));
            }
        }
}

TEST(NoiseGradient, SolidFractalIsTheOctaveSumOfNoiseAndMatchesDifferences) {
    FractalParams fp;
    fp.frequency = 3;
    fp.octaves = 4;
    fp.lacunarity = 2.1;
    fp.gain = 0.45;
    const Permutation& perm = Permutation::reference();
    std::mt19937_64 rng(5);
    std::uniform_real_distribution<double> d(-20.0, 20.0);
    for (int i = 0; i < 2000; ++i) {
        const double x = d(rng), y = d(rng), z = d(rng);
        const NoiseGradient g = solidFractalGradient(fp, perm, x, y, z);
        double sum = 0, f = fp.frequency, a = 1;
        for (int k = 0; k < fp.octaves; ++k, f *= fp.lacunarity, a *= fp.gain) sum += a * perlin(f * x, f * y, f * z);
        EXPECT_NEAR(g.value, sum, 1e-12);
        const auto fd = centralDifferences(
            [&](double a0, double b0, double c0) { return solidFractalGradient(fp, perm, a0, b0, c0).value; }, x, y, z);
        EXPECT_NEAR(g.dx, fd[0], 1e-5);
        EXPECT_NEAR(g.dy, fd[1], 1e-5);
        EXPECT_NEAR(g.dz, fd[2], 1e-5);
    }
}

TEST(NoiseGradient, SlopeVarianceOfOneOctaveIsStable) {
    const double v = perlinGradientComponentVariance();
    std::printf("Var(dn/dx) = %.5f\n", v);
    // Improved noise: |grad n| is bounded by ~ sqrt(3) * 1.875 per axis; its
    // variance is of order one, and the measure is deterministic.
    EXPECT_GT(v, 0.3);
    EXPECT_LT(v, 3.0);
    EXPECT_EQ(v, perlinGradientComponentVariance());
}

}  // namespace
}  // namespace mucosa::noise
