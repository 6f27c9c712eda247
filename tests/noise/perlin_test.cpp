#include <mucosa/noise/perlin.hpp>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <random>
#include <set>
#include <sstream>

#include <gtest/gtest.h>

#include "test_support.hpp"

using namespace mucosa::noise;

TEST(Perlin, MatchesPublishedJavaReferenceValues) {
    // tests/data/perlin/published_values.csv: values of Perlin's
    // ImprovedNoise.java published with their sources.
    std::ifstream in(mucosa::test::testdata("perlin/published_values.csv"));
    std::string line;
    std::getline(in, line);  // header
    int n = 0;
    while (std::getline(in, line)) {
        std::stringstream ss(line);
        std::string x, y, z, v;
        std::getline(ss, x, ',');
        std::getline(ss, y, ',');
        std::getline(ss, z, ',');
        std::getline(ss, v, ',');
        const double got = perlin(std::stod(x), std::stod(y), std::stod(z));
        EXPECT_NEAR(got, std::stod(v), 1e-12) << "noise(" << x << ", " << y << ", " << z << ")";
        ++n;
    }
    EXPECT_GE(n, 6);
    EXPECT_EQ(perlin(3.14, 42, 7), 0.13691995878400012);
}

TEST(Perlin, ReferenceTableIsAPermutationStoredTwice) {
    const auto& t = Permutation::reference().table();
    std::set<int> seen(t.begin(), t.begin() + 256);
    EXPECT_EQ(seen.size(), 256u);
    EXPECT_TRUE(std::equal(t.begin(), t.begin() + 256, t.begin() + 256));
    EXPECT_EQ(t[0], 151);
    EXPECT_EQ(t[255], 180);
}

TEST(Perlin, ZeroAtEveryIntegerLatticePoint) {
    const Permutation seeded = Permutation::fromSeed(7);
    for (int x = -300; x <= 300; x += 7)
        for (int y = -20; y <= 20; ++y)
            for (int z = -3; z <= 3; ++z) {
                ASSERT_EQ(perlin(x, y, z), 0.0) << x << "," << y << "," << z;
                ASSERT_EQ(perlin(seeded, x, y, z), 0.0);
                ASSERT_EQ(perlinPeriodic(seeded, x, y, z, 5, 7, 256), 0.0);
            }
}

TEST(Perlin, HasPeriod256InEveryAxis) {
    std::mt19937_64 rng(1);
    std::uniform_real_distribution<double> d(-300.0, 300.0);
    for (int i = 0; i < 2000; ++i) {
        const double x = d(rng), y = d(rng), z = d(rng);
        const double n = perlin(x, y, z);
        // x + 256 is not always exactly representable relative to x's
        // fraction, so compare with a tolerance at the rounding level.
        EXPECT_NEAR(perlin(x + 256, y, z), n, 1e-12);
        EXPECT_NEAR(perlin(x, y - 256, z), n, 1e-12);
        EXPECT_NEAR(perlin(x, y, z + 512), n, 1e-12);
    }
}

TEST(Perlin, NegativeCoordinatesUseFloorNotTruncation) {
    // noise(-4.2, 10, 6) from the published values; truncation toward zero
    // would pick the cell at -4 and give a different value.
    EXPECT_NEAR(perlin(-4.2, 10, 6), 0.14208000000000043, 1e-12);
    EXPECT_NE(perlin(-0.5, 0.25, 0.75), perlin(0.5, 0.25, 0.75));
}

TEST(Perlin, StaysInRangeAndIsFiniteForExtremeInput) {
    std::mt19937_64 rng(2);
    std::uniform_real_distribution<double> d(-1e6, 1e6);
    for (int i = 0; i < 20000; ++i) {
        const double n = perlin(d(rng), d(rng), d(rng));
        ASSERT_TRUE(std::isfinite(n));
        ASSERT_LE(std::fabs(n), 1.05);
    }
    EXPECT_EQ(perlin(NAN, 0.5, 0.5), 0.0);
    EXPECT_EQ(perlin(INFINITY, 0.5, 0.5), 0.0);
    EXPECT_TRUE(std::isfinite(perlin(1e300, 0.5, 0.5)));
}

TEST(Perlin, SeedZeroIsTheReferenceAndOtherSeedsPermuteDeterministically) {
    EXPECT_EQ(Permutation::fromSeed(0).table(), Permutation::reference().table());
    const auto a = Permutation::fromSeed(42), b = Permutation::fromSeed(42), c = Permutation::fromSeed(43);
    EXPECT_EQ(a.table(), b.table());
    EXPECT_NE(a.table(), c.table());
    EXPECT_NE(a.table(), Permutation::reference().table());
    std::set<int> seen(a.table().begin(), a.table().begin() + 256);
    EXPECT_EQ(seen.size(), 256u);
    // Different seeds give decorrelated noise.
    double dot = 0, na = 0, nc = 0;
    std::mt19937_64 rng(3);
    std::uniform_real_distribution<double> d(0.0, 64.0);
    for (int i = 0; i < 5000; ++i) {
        const double x = d(rng), y = d(rng), z = d(rng);
        const double va = perlin(a, x, y, z), vc = perlin(c, x, y, z);
        dot += va * vc;
        na += va * va;
        nc += vc * vc;
    }
    EXPECT_LT(std::fabs(dot / std::sqrt(na * nc)), 0.1);
}

TEST(Perlin, PeriodicNoiseRepeatsWithItsPeriod) {
    const Permutation& p = Permutation::reference();
    std::mt19937_64 rng(4);
    std::uniform_real_distribution<double> d(-50.0, 50.0);
    for (int period : {1, 2, 3, 8, 17, 100, 256}) {
        for (int i = 0; i < 500; ++i) {
            const double x = d(rng), y = d(rng), z = d(rng);
            const double n = perlinPeriodic(p, x, y, z, period, period, period);
            EXPECT_NEAR(perlinPeriodic(p, x + period, y, z, period, period, period), n, 1e-12) << period;
            EXPECT_NEAR(perlinPeriodic(p, x, y - period, z, period, period, period), n, 1e-12) << period;
            EXPECT_NEAR(perlinPeriodic(p, x, y, z + 3 * period, period, period, period), n, 1e-12) << period;
        }
    }
    // Period 256 is the plain noise, exactly.
    for (int i = 0; i < 500; ++i) {
        const double x = d(rng), y = d(rng), z = d(rng);
        EXPECT_EQ(perlinPeriodic(p, x, y, z, 256, 256, 256), perlin(x, y, z));
    }
}
