// Highlight statistics (tune/highlight_stats.hpp): synthetic frames with known
// blobs, the resize, the summaries and distance of the realism tool, reading
// targets; and rendered frames checked against the numbers the realism tool
// itself (realism_stats.py) gives for them.
#include <mucosa/tune/highlight_stats.hpp>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <numbers>

#include <gtest/gtest.h>

#include <mucosa/core/error.hpp>
#include <mucosa/image/png.hpp>

#include "test_support.hpp"

namespace {

using namespace mucosa;
using tune::HighlightStat;
namespace fs = std::filesystem;

constexpr std::array<std::uint8_t, 3> kTissue{200, 120, 110};  // salmon: never a highlight
constexpr std::array<std::uint8_t, 3> kWhite{255, 255, 255};

image::Image8 canvas(int w = 320, int h = 320) {
    image::Image8 img(w, h, 3);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x)
            for (int c = 0; c < 3; ++c) img.at(x, y, c) = kTissue[static_cast<std::size_t>(c)];
    return img;
}

// Fills the pixels whose centres lie inside the ellipse (semi-axes a, b,
// major axis at `angle`); returns how many.
int ellipse(image::Image8& img, double cx, double cy, double a, double b, double angle,
            std::array<std::uint8_t, 3> color = kWhite) {
    int n = 0;
    const double c = std::cos(angle), s = std::sin(angle);
    for (int y = 0; y < img.height(); ++y)
        for (int x = 0; x < img.width(); ++x) {
            const double dx = x - cx, dy = y - cy;
            const double u = (dx * c + dy * s) / a, v = (-dx * s + dy * c) / b;
            if (u * u + v * v > 1) continue;
            for (int k = 0; k < 3; ++k) img.at(x, y, k) = color[static_cast<std::size_t>(k)];
            ++n;
        }
    return n;
}

void put(image::Image8& img, int x, int y, std::array<std::uint8_t, 3> color = kWhite) {
    for (int k = 0; k < 3; ++k) img.at(x, y, k) = color[static_cast<std::size_t>(k)];
}

// Pixels inside the analysis disk (radius 152 about (159.5, 159.5)).
int diskPixels() {
    int n = 0;
    for (int y = 0; y < 320; ++y)
        for (int x = 0; x < 320; ++x) n += std::hypot(y - 159.5, x - 159.5) / 152.0 < 1.0;
    return n;
}

TEST(HighlightStats, EllipsesGiveTheirCountAreaAndElongation) {
    image::Image8 img = canvas();
    // Three ellipses with known axes, away from the disk's edge.
    const int a1 = ellipse(img, 100, 120, 12, 4, 0.5);   // elongation 3
    const int a2 = ellipse(img, 200, 200, 8, 8, 0.0);    // a disc: 1
    const int a3 = ellipse(img, 220, 100, 15, 6, -1.0);  // 2.5
    const tune::FrameHighlights h = tune::measureHighlights(img);
    const int nvalid = diskPixels();
    EXPECT_EQ(h[HighlightStat::Count], 3);
    // Each digitised area is within 3 % of pi a b.
    EXPECT_NEAR(a1, std::numbers::pi * 12 * 4, 0.03 * std::numbers::pi * 12 * 4);
    EXPECT_NEAR(a3, std::numbers::pi * 15 * 6, 0.03 * std::numbers::pi * 15 * 6);
    EXPECT_DOUBLE_EQ(h[HighlightStat::AreaMedian], std::max(std::min(a1, a2), std::min(std::max(a1, a2), a3)));
    EXPECT_DOUBLE_EQ(h[HighlightStat::Fraction], static_cast<double>(a1 + a2 + a3) / nvalid);
    EXPECT_DOUBLE_EQ(h[HighlightStat::Largest], static_cast<double>(std::max({a1, a2, a3})) / nvalid);
    // Median elongation of {3, 1, 2.5}: the 15 x 6 ellipse's, within 4 % (digitisation).
    EXPECT_NEAR(h[HighlightStat::Elongation], 2.5, 0.04 * 2.5);
    EXPECT_DOUBLE_EQ(h[HighlightStat::Clipped], 1.0);  // pure white is clipped
}

TEST(HighlightStats, ElongationOfAPixelLineUsesTheUnitPixelVariance) {
    image::Image8 img = canvas();
    for (int x = 0; x < 9; ++x) put(img, 150 + x, 160);
    const tune::FrameHighlights h = tune::measureHighlights(img);
    // var(0..8) = 7.5 (unbiased) along x; 0 across, plus 1/12 each way.
    EXPECT_NEAR(h[HighlightStat::Elongation], std::sqrt((7.5 + 1.0 / 12) / (1.0 / 12)), 1e-9);
    EXPECT_EQ(h[HighlightStat::Count], 1);
    EXPECT_EQ(h[HighlightStat::AreaMedian], 9);
}

TEST(HighlightStats, SmallComponentsDiagonalsAndTheDisk) {
    image::Image8 img = canvas();
    put(img, 100, 100);  // 1 px: highlight, but not a component
    put(img, 120, 120);  // two diagonal neighbours: one 8-connected component of 2
    put(img, 121, 121);
    put(img, 2, 2);  // outside the disk
    put(img, 3, 2);
    // A 4 px square: counted, but too small for elongation (>= 5 px).
    for (int d = 0; d < 4; ++d) put(img, 200 + d % 2, 150 + d / 2);
    const tune::FrameHighlights h = tune::measureHighlights(img);
    EXPECT_EQ(h[HighlightStat::Count], 2);
    EXPECT_DOUBLE_EQ(h[HighlightStat::AreaMedian], 3.0);  // median of {2, 4}
    EXPECT_NEAR(h[HighlightStat::AreaP90], 2 + 0.9 * 2, 1e-12);
    EXPECT_TRUE(std::isnan(h[HighlightStat::Elongation]));
    EXPECT_DOUBLE_EQ(h[HighlightStat::Fraction], 7.0 / diskPixels());
    // Mean radius over all 7 highlight pixels (the single one too).
    double r = 0;
    for (auto [x, y] : {std::pair{100, 100}, {120, 120}, {121, 121}, {200, 150}, {201, 150}, {200, 151}, {201, 151}})
        r += std::hypot(y - 159.5, x - 159.5) / 152.0;
    EXPECT_NEAR(h[HighlightStat::Radius], r / 7, 1e-12);
}

TEST(HighlightStats, ThresholdsAreTheToolsValueAndSaturation) {
    auto one = [](std::array<std::uint8_t, 3> color) {
        image::Image8 img = canvas();
        ellipse(img, 160, 160, 5, 5, 0, color);
        return tune::measureHighlights(img);
    };
    EXPECT_EQ(one({235, 235, 235})[HighlightStat::Count], 1);  // V = 0.9216 > 0.92
    EXPECT_EQ(one({234, 234, 234})[HighlightStat::Count], 0);  // V = 0.9176
    EXPECT_EQ(one({255, 200, 200})[HighlightStat::Count], 1);  // S = 0.216
    EXPECT_EQ(one({255, 180, 180})[HighlightStat::Count], 0);  // S = 0.294
    const tune::FrameHighlights none = one({100, 100, 100});
    EXPECT_EQ(none[HighlightStat::Largest], 0.0);
    EXPECT_TRUE(std::isnan(none[HighlightStat::AreaMedian]));
    EXPECT_TRUE(std::isnan(none[HighlightStat::Radius]));
    EXPECT_DOUBLE_EQ(one({250, 250, 252})[HighlightStat::Clipped], 1.0);
    EXPECT_DOUBLE_EQ(one({249, 250, 252})[HighlightStat::Clipped], 0.0);
}

TEST(HighlightStats, LargerAndNonSquareFramesAreCroppedAndAveraged) {
    // The same ellipses drawn at twice the size, in a wider frame: the
    // centred 640 x 640 square averaged 2 x 2 gives back the 320 picture's
    // statistics (edges differ by a pixel where 2 x 2 blocks straddle them).
    image::Image8 small = canvas(), big = canvas(800, 640);
    ellipse(small, 100, 120, 12, 4, 0.5);
    ellipse(small, 220, 100, 15, 6, -1.0);
    ellipse(big, 80 + 2 * 100 + 0.5, 2 * 120 + 0.5, 24, 8, 0.5);
    ellipse(big, 80 + 2 * 220 + 0.5, 2 * 100 + 0.5, 30, 12, -1.0);
    const tune::FrameHighlights a = tune::measureHighlights(small), b = tune::measureHighlights(big);
    EXPECT_EQ(b[HighlightStat::Count], 2);
    EXPECT_NEAR(b[HighlightStat::AreaMedian], a[HighlightStat::AreaMedian], 0.08 * a[HighlightStat::AreaMedian]);
    EXPECT_NEAR(b[HighlightStat::Elongation], a[HighlightStat::Elongation], 0.08 * a[HighlightStat::Elongation]);
    EXPECT_NEAR(b[HighlightStat::Radius], a[HighlightStat::Radius], 0.01);
    const image::Image8 r = tune::squareResize(big);
    EXPECT_EQ(r.width(), 320);
    EXPECT_EQ(r.height(), 320);
    // A uniform picture stays uniform through the resize, down and up.
    const image::Image8 up = tune::squareResize(canvas(100, 90));
    EXPECT_EQ(up.at(0, 0, 0), kTissue[0]);
    EXPECT_EQ(up.at(319, 319, 2), kTissue[2]);
}

TEST(HighlightStats, AMaskLeavesTooFewPixelsForStatistics) {
    image::Image8 img = canvas();
    ellipse(img, 160, 160, 10, 10, 0);
    image::Image8 mask(320, 320, 1);  // all zero: nothing valid
    const tune::FrameHighlights h = tune::measureHighlights(img, &mask);
    for (double v : h.values) EXPECT_TRUE(std::isnan(v));
    // Half the frame masked: the blob there no longer counts.
    for (int y = 0; y < 320; ++y)
        for (int x = 0; x < 160; ++x) mask.at(x, y) = 255;
    image::Image8 right = canvas();
    ellipse(right, 240, 160, 10, 10, 0);
    EXPECT_EQ(tune::measureHighlights(right, &mask)[HighlightStat::Count], 0);
    EXPECT_EQ(tune::measureHighlights(right)[HighlightStat::Count], 1);
}

TEST(HighlightStats, PercentilesSummariesAndDistanceAreNumpysAndTheTools) {
    EXPECT_DOUBLE_EQ(tune::percentile({4, 1, 3, 2}, 50), 2.5);
    EXPECT_DOUBLE_EQ(tune::percentile({4, 1, 3, 2}, 90), 3.7);
    EXPECT_DOUBLE_EQ(tune::percentile({4, 1, 3, 2}, 25), 1.75);
    EXPECT_TRUE(std::isnan(tune::percentile({}, 50)));
    std::vector<tune::FrameHighlights> frames(5);
    const double counts[] = {2, 0, 5, NAN, 1};
    for (std::size_t i = 0; i < 5; ++i) {
        frames[i].values.fill(NAN);
        frames[i][HighlightStat::Count] = counts[i];
    }
    const tune::HighlightSummary s = tune::summarise(frames);
    EXPECT_EQ(s[HighlightStat::Count].n, 4);
    EXPECT_DOUBLE_EQ(s[HighlightStat::Count].median, 1.5);
    EXPECT_DOUBLE_EQ(s[HighlightStat::Count].iqr(), 2.75 - 0.75);
    EXPECT_EQ(s[HighlightStat::Fraction].n, 0);
    // distance(): |6 - 1.5| / 2 = 2.25; capped at 10; the IQR floored at 5 % of the median.
    tune::StatSummary ours{6, 6, 6, 3};
    EXPECT_DOUBLE_EQ(tune::statDistance(ours, s[HighlightStat::Count]), 2.25);
    EXPECT_DOUBLE_EQ(tune::statDistance(tune::StatSummary{100, 100, 100, 1}, s[HighlightStat::Count]), 10.0);
    EXPECT_DOUBLE_EQ(tune::statDistance(tune::StatSummary{}, s[HighlightStat::Count]), 10.0);  // ours has none
    EXPECT_TRUE(std::isnan(tune::statDistance(ours, s[HighlightStat::Fraction])));             // target has none
    EXPECT_DOUBLE_EQ(tune::statDistance(tune::StatSummary{11, 11, 11, 1}, tune::StatSummary{10, 10, 10, 3}), 2.0);
    const tune::Distance d =
        tune::distance(tune::summarise({frames[0]}), s, {HighlightStat::Count, HighlightStat::Fraction});
    EXPECT_EQ(d.terms, 1);
    EXPECT_DOUBLE_EQ(d.total, 0.25);
}

void writeText(const fs::path& p, const std::string& s) {
    std::ofstream(p) << s;
}

TEST(HighlightStats, TargetsAreReadFromAStatisticsFileOrAFolderOfFrames) {
    test::TempDir t;
    writeText(t / "stats.json",
              R"({"about": "x", "frames": [
                   {"name": "a", "stats": {"hl_count": 2.0, "hl_area_med": null, "L_mean": 50}},
                   {"name": "b", "stats": {"hl_count": 4, "hl_area_med": 15.5}}]})");
    const auto frames = tune::readTargetFrames(t / "stats.json");
    ASSERT_EQ(frames.size(), 2u);
    EXPECT_EQ(frames[1][HighlightStat::Count], 4);
    EXPECT_TRUE(std::isnan(frames[0][HighlightStat::AreaMedian]));
    EXPECT_TRUE(std::isnan(frames[0][HighlightStat::Elongation]));  // absent = null
    EXPECT_DOUBLE_EQ(tune::summarise(frames)[HighlightStat::Count].median, 3.0);

    fs::create_directories(t / "frames");
    image::Image8 img = canvas();
    ellipse(img, 160, 160, 10, 10, 0);
    image::writePng(t / "frames" / "f1.png", img);
    image::Image8 mask(320, 320, 1);  // masks f1 entirely
    image::writePng(t / "frames" / "f1.mask.png", mask);
    image::writePng(t / "frames" / "f2.png", img);
    const auto measured = tune::readTargetFrames(t / "frames");
    ASSERT_EQ(measured.size(), 2u);  // the mask is not a frame
    EXPECT_TRUE(std::isnan(measured[0][HighlightStat::Count]));
    EXPECT_EQ(measured[1][HighlightStat::Count], 1);
}

TEST(HighlightStats, BadTargetsAreOneClearError) {
    test::TempDir t;
    EXPECT_THROW(tune::readTargetFrames(t / "missing.json"), IoError);
    writeText(t / "bad.json", R"({"frames": [ {"stats": {"hl_count": 1}}, ]})");
    EXPECT_THROW(tune::readTargetFrames(t / "bad.json"), InputError);
    writeText(t / "nofr.json", R"({"about": "no frames"})");
    EXPECT_THROW(tune::readTargetFrames(t / "nofr.json"), InputError);
    writeText(t / "str.json", R"({"frames": [{"name": "a", "stats": {"hl_count": "two"}}]})");
    try {
        tune::readTargetFrames(t / "str.json");
        FAIL() << "a string statistic was accepted";
    } catch (const InputError& e) {
        EXPECT_EQ(e.subject(), "frames[0].stats.hl_count");
        EXPECT_EQ(e.file(), (t / "str.json").string());
    }
    fs::create_directories(t / "empty");
    EXPECT_THROW(tune::readTargetFrames(t / "empty"), InputError);
}

}  // namespace

namespace {

// Two frames of the phantom's fly-through (320 x 320, material.specular_strength
// 2.5, rendered on this branch) and what realism_stats.py's frame_stats()
// says of them (numpy 1.24, scipy 1.10; printed to 10 digits).
struct Reference {
    const char* file;
    std::array<double, tune::kHighlightStatCount> values;
};
const Reference kReferences[] = {
    {"phantom_ks2.5_view1.png", {0.01365389915, 51, 5, 50, 2.058663459, 0.5151264885, 0.002493799945, 0.4369323915}},
    {"phantom_ks2.5_view2.png", {0.004036924773, 17, 3, 27.8, 2.083339656, 0.3138449994, 0.002356020942, 0.1911262799}},
};

TEST(HighlightStats, RenderedFramesGiveTheRealismToolsNumbers) {
    for (const Reference& ref : kReferences) {
        const fs::path p = fs::path(MUCOSA_TUNE_TESTDATA) / ref.file;
        const tune::FrameHighlights h = tune::measureFrameFile(p);
        for (int k = 0; k < tune::kHighlightStatCount; ++k) {
            const auto i = static_cast<std::size_t>(k);
            EXPECT_NEAR(h.values[i], ref.values[i], 1e-8 * std::abs(ref.values[i]) + 1e-12)
                << ref.file << " " << tune::statName(static_cast<HighlightStat>(k));
        }
        // The same frame at twice the size (each pixel a 2 x 2 block): area
        // averaging gives back the frame exactly, so the same numbers.
        const image::Image8 img = image::to8(image::readPng(p));
        image::Image8 big(640, 640, 3);
        for (int y = 0; y < 640; ++y)
            for (int x = 0; x < 640; ++x)
                for (int c = 0; c < 3; ++c) big.at(x, y, c) = img.at(x / 2, y / 2, c);
        EXPECT_EQ(tune::squareResize(big), img);
        EXPECT_EQ(tune::measureHighlights(big).values, h.values);
    }
}

}  // namespace
