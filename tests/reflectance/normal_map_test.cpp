#include <mucosa/reflectance/normal_map.hpp>

#include <cmath>

#include <gtest/gtest.h>

#include <mucosa/reflectance/map.hpp>

using namespace mucosa;
using namespace mucosa::reflectance;

namespace {

image::ImageF bronchialHeight(int size, bool tileable) {
    MapParams p = findPreset("bronchial").params;
    p.size = size;
    p.noise.tileable = tileable;
    return heightField(p, 2);
}

double length(const std::array<double, 3>& v) {
    return std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
}

}  // namespace

TEST(NormalMap, MapPixelsAreTheEncodedNormalsOfTheHeightField) {
    const image::ImageF H = bronchialHeight(128, true);
    const double B = 0.004;
    const image::Image8 m8 = encodeNormals8(H, B, Edges::Wrap);
    const image::Image16 m16 = encodeNormals16(H, B, Edges::Wrap);
    for (int y = 0; y < 128; ++y)
        for (int x = 0; x < 128; ++x) {
            const auto N = normalAt(H, x, y, B, Edges::Wrap);
            const auto e8 = encode8(N);
            const auto e16 = encode16(N);
            for (int c = 0; c < 3; ++c) {
                ASSERT_EQ(m8.at(x, y, c), e8[c]) << x << "," << y;
                ASSERT_EQ(m16.at(x, y, c), e16[c]) << x << "," << y;
            }
        }
}

TEST(NormalMap, NormalFollowsThePaperEquation) {
    // H = a u + b v (v up, i.e. growing toward the first row): the normal is
    // (-B a, -B b, 1) / |.| everywhere inside (paper eq. 1-2).
    const int w = 64, h = 32;
    image::ImageF H(w, h, 1);
    const double a = 0.5, b = -0.25;
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            const double u = static_cast<double>(x) / w, v = 1.0 - static_cast<double>(y) / h;
            H.at(x, y) = static_cast<float>(a * u + b * v);
        }
    const double B = 2.0;
    const double n = std::sqrt(B * a * B * a + B * b * B * b + 1);
    const auto N = normalAt(H, 10, 10, B, Edges::Clamp);
    EXPECT_NEAR(N[0], -B * a / n, 1e-5);
    EXPECT_NEAR(N[1], -B * b / n, 1e-5);
    EXPECT_NEAR(N[2], 1.0 / n, 1e-5);
    // Green up: N.y = -B dH/dv with v growing toward the top row, so a height
    // that falls toward the top (b < 0) gives green > 128.
    const auto top = encode8(normalAt(H, 5, 5, B, Edges::Clamp));
    EXPECT_GT(top[1], 128);
}

TEST(NormalMap, DecodedNormalsAreUnitLengthWithinQuantisation) {
    const image::ImageF H = bronchialHeight(256, true);
    const image::Image8 m = encodeNormals8(H, 0.01, Edges::Wrap);
    const image::Image16 m16 = encodeNormals16(H, 0.01, Edges::Wrap);
    double worst8 = 0, worst16 = 0;
    for (int y = 0; y < 256; ++y)
        for (int x = 0; x < 256; ++x) {
            // Raw decode 2c - 1 without renormalising: |N| = 1 up to rounding
            // of each component by half a step.
            std::array<double, 3> n8{}, n16{};
            for (int c = 0; c < 3; ++c) {
                n8[c] = 2.0 * m.at(x, y, c) / 255.0 - 1.0;
                n16[c] = 2.0 * m16.at(x, y, c) / 65535.0 - 1.0;
            }
            worst8 = std::max(worst8, std::fabs(length(n8) - 1.0));
            worst16 = std::max(worst16, std::fabs(length(n16) - 1.0));
        }
    EXPECT_LE(worst8, std::sqrt(3.0) / 255.0);
    EXPECT_LE(worst16, std::sqrt(3.0) / 65535.0);
}

TEST(NormalMap, BlueIsAtLeast128EverywhereEvenForSteepMaps) {
    for (double B : {0.004, 0.05, 10.0}) {
        const image::ImageF H = bronchialHeight(128, true);
        const image::Image8 m = encodeNormals8(H, B, Edges::Wrap);
        for (int y = 0; y < 128; ++y)
            for (int x = 0; x < 128; ++x) ASSERT_GE(m.at(x, y, 2), 128) << "strength " << B;
    }
}

TEST(NormalMap, EncodeDecodeRoundTripsWithinHalfAStep) {
    for (double theta = 0; theta < 1.5; theta += 0.05)
        for (double phi = 0; phi < 6.28; phi += 0.3) {
            const std::array<double, 3> N{std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi),
                                          std::cos(theta)};
            const auto e8 = encode8(N);
            const auto d8 = decode8(e8[0], e8[1], e8[2]);
            const auto e16 = encode16(N);
            const auto d16 = decode16(e16[0], e16[1], e16[2]);
            const double dot8 = N[0] * d8[0] + N[1] * d8[1] + N[2] * d8[2];
            const double dot16 = N[0] * d16[0] + N[1] * d16[1] + N[2] * d16[2];
            EXPECT_GT(dot8, std::cos(1.0 * M_PI / 180.0));     // < 1 degree at 8 bits
            EXPECT_GT(dot16, std::cos(0.005 * M_PI / 180.0));  // < 0.005 degree at 16 bits
            EXPECT_NEAR(length(d8), 1.0, 1e-12);
        }
}

TEST(NormalMap, TileableMapHasNoSeam) {
    // Across the wrap (last column -> first, last row -> first) the height and
    // the normals change no more than between typical neighbours.
    const int n = 256;
    const image::ImageF H = bronchialHeight(n, true);
    const image::Image8 m = encodeNormals8(H, 0.004, Edges::Wrap);
    auto meanDiff = [&](auto value, int x0, int y0, int x1, int y1, bool rows) {
        double s = 0;
        for (int i = 0; i < n; ++i)
            s += rows ? std::fabs(value(i, y0) - value(i, y1)) : std::fabs(value(x0, i) - value(x1, i));
        return s / n;
    };
    auto h = [&](int x, int y) { return static_cast<double>(H.at(x, y)); };
    auto g = [&](int x, int y) { return static_cast<double>(m.at(x, y, 0)) + m.at(x, y, 1); };
    for (auto value : {std::function<double(int, int)>(h), std::function<double(int, int)>(g)}) {
        double typical = 0;
        for (int x = 0; x + 1 < n; x += 17) typical += meanDiff(value, x, 0, x + 1, 0, false);
        typical /= static_cast<double>((n - 2) / 17 + 1);
        const double seamX = meanDiff(value, n - 1, 0, 0, 0, false);
        const double seamY = meanDiff(value, 0, n - 1, 0, 0, true);
        EXPECT_LT(seamX, 1.5 * typical);
        EXPECT_LT(seamY, 1.5 * typical);
        EXPECT_GT(seamX, 0.3 * typical);  // and the seam is not artificially flat
    }
    // A non-tileable map does have a seam.
    const image::ImageF Hn = bronchialHeight(n, false);
    double seam = 0, typical = 0;
    for (int y = 0; y < n; ++y) {
        seam += std::fabs(Hn.at(n - 1, y) - Hn.at(0, y));
        typical += std::fabs(Hn.at(n / 2, y) - Hn.at(n / 2 + 1, y));
    }
    EXPECT_GT(seam, 3 * typical);
}
