// Every statistic of the realism tool (tune/frame_stats.hpp): rendered frames
// checked against the numbers realism_stats.py gives for them, and synthetic
// frames whose colour, noise, dark lumen and light profile are known.
#include <mucosa/tune/frame_stats.hpp>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <random>

#include <gtest/gtest.h>

#include <mucosa/core/error.hpp>
#include <mucosa/image/png.hpp>

#include "test_support.hpp"

namespace {

using namespace mucosa;
using tune::FrameStat;
namespace fs = std::filesystem;

// The two phantom frames of tests/tune/data and realism_stats.py's
// frame_stats() of them, in the tool's STATS order (numpy 1.24, scipy 1.10,
// OpenCV 4.6; printed to 10 digits).
struct Reference {
    const char* file;
    std::array<double, tune::kFrameStatCount> values;
};
const Reference kReferences[] = {
    {"phantom_ks2.5_view1.png",
     {45.52021408,    10.71831894,   23.43272781,   5.403728962, 15.62150478, 3.183017015,  28.17997551, 33.85218908,
      1.906207663,    38.90809274,   0.01365389915, 51,          5,           50,           2.058663459, 0.5151264885,
      0.002493799945, 0.4369323915,  0.05883163406, 43.30832291, 1.509348775, 24.17658615,  35.66410446, 51.09439087,
      -3.180091153,   0.05578899392, 2.25424552,    5.709165812, 9.346121925, 0.5963791478, 26.38368797, 24.28329659,
      23.67350388,    25.47177505,   34.13801193,   40.55699539, 38.20832443, 45.91388321,  51.75949478, 54.59792709}},
    {"phantom_ks2.5_view2.png",
     {50.40523529,
      7.321589947,
      25.18021202,
      4.379262924,
      16.9340744,
      2.216664553,
      30.36113548,
      34.09701957,
      1.725448263,
      36.79837037,
      0.004036924773,
      17,
      3,
      27.8,
      2.083339656,
      0.3138449994,
      0.002356020942,
      0.1911262799,
      0,
      50.72898102,
      1.515382988,
      49.90062332,
      44.99156952,
      55.0529213,
      -3.748269016,
      0.002819802144,
      1.429894447,
      3.387267923,
      5.606109616,
      0.4634255296,
      77.85123444,
      56.04309464,
      42.20494461,
      35.52035904,
      42.37320709,
      47.08712769,
      50.12701416,
      52.62091827,
      55.08371735,
      56.95554352}},
};

TEST(FrameStats, RenderedFramesGiveTheRealismToolsNumbers) {
    for (const Reference& ref : kReferences) {
        const tune::FrameStats s = tune::measureFrameStatsFile(fs::path(MUCOSA_TUNE_TESTDATA) / ref.file);
        for (std::size_t k = 0; k < tune::kFrameStatCount; ++k) {
            // The tool sums in float32 (numpy's pairwise sums): a few 1e-6 of
            // the value; thresholds on float32 L* are computed as it does.
            // Its hue spread, sqrt(-2 ln R) with R a float32 mean of cosines
            // near 1, carries about 1e-4 deg of that rounding.
            const bool hue = static_cast<FrameStat>(k) == FrameStat::HueStd;
            EXPECT_NEAR(s.values[k], ref.values[k], hue ? 3e-4 : 2e-5 * std::abs(ref.values[k]) + 1e-6)
                << ref.file << " " << tune::info(static_cast<FrameStat>(k)).name;
        }
    }
}

image::Image8 uniform(std::array<std::uint8_t, 3> rgb) {
    image::Image8 img(320, 320, 3);
    for (int y = 0; y < 320; ++y)
        for (int x = 0; x < 320; ++x)
            for (int c = 0; c < 3; ++c) img.at(x, y, c) = rgb[static_cast<std::size_t>(c)];
    return img;
}

TEST(FrameStats, AUniformPatchHasItsCielabColourAndNoSpread) {
    // sRGB (200, 120, 110): CIELAB (D65) L* 58.827, a* 30.138, b* 18.895 (the CIE formulas).
    const tune::FrameStats s = tune::measureFrame(uniform({200, 120, 110}));
    EXPECT_NEAR(s[FrameStat::LMean], 58.827, 0.002);
    EXPECT_NEAR(s[FrameStat::AMean], 30.138, 0.002);
    EXPECT_NEAR(s[FrameStat::BMean], 18.895, 0.002);
    EXPECT_NEAR(s[FrameStat::ChromaMean], std::hypot(30.138, 18.895), 0.003);
    EXPECT_NEAR(s[FrameStat::HueMean], std::atan2(18.895, 30.138) * 180 / std::numbers::pi, 0.005);
    EXPECT_NEAR(s[FrameStat::LStd], 0.0, 1e-4);
    EXPECT_NEAR(s[FrameStat::HueStd], 0.0, 0.05);
    // Hasler-Suesstrunk: no spread, so 0.3 |(R - G, (R + G) / 2 - B)|.
    EXPECT_NEAR(s[FrameStat::Colourfulness], 0.3 * std::hypot(80.0, 50.0), 1e-3);
    EXPECT_EQ(s[FrameStat::HlCount], 0);
    EXPECT_EQ(s[FrameStat::HlLargest], 0);
    EXPECT_TRUE(std::isnan(s[FrameStat::HlAreaMed]));
    EXPECT_EQ(s[FrameStat::DarkFrac], 0);
    EXPECT_NEAR(s[FrameStat::RingRatio], 1.0, 1e-6);
    EXPECT_NEAR(s[FrameStat::NoiseSigma], 0.0, 1e-9);
    EXPECT_NEAR(s[FrameStat::LapVar], 0.0, 1e-9);
    EXPECT_NEAR(s[FrameStat::Lc16Med], 0.0, 1e-4);
    // A flat tile has no spectrum to fit: no slope.
    EXPECT_TRUE(std::isnan(s[FrameStat::PsdSlope]));
}

TEST(FrameStats, ImmerkaersEstimateRecoversTheAddedNoise) {
    // Grey 128 with Gaussian noise of sigma 3 (grey levels): the estimator is
    // unbiased for white noise on a flat image (rounding adds 1/12).
    std::mt19937 rng(5);
    std::normal_distribution<double> noise(0.0, 3.0);
    image::Image8 img(320, 320, 3);
    for (int y = 0; y < 320; ++y)
        for (int x = 0; x < 320; ++x) {
            const auto v = static_cast<std::uint8_t>(std::lround(std::clamp(128 + noise(rng), 0.0, 255.0)));
            for (int c = 0; c < 3; ++c) img.at(x, y, c) = v;
        }
    const tune::FrameStats s = tune::measureFrame(img);
    EXPECT_NEAR(s[FrameStat::NoiseSigma], std::sqrt(9.0 + 1.0 / 12), 0.1);
    // White noise: a flat spectrum (slope about 0 after the window's
    // low-frequency leak), most of the power at high frequencies.
    EXPECT_NEAR(s[FrameStat::PsdSlope], 0.0, 0.3);
    EXPECT_GT(s[FrameStat::PsdHfFrac], 0.6);
}

TEST(FrameStats, ADarkLumenAndARadialFallOffShowInTheIlluminationStatistics) {
    // Bright at the rim, dark inside r < 0.5 of the disk: the lumen's
    // fraction is the inner disk's share, the outer band brighter than the
    // inner one, the brightest ring over the median ring > 1.
    image::Image8 img(320, 320, 3);
    for (int y = 0; y < 320; ++y)
        for (int x = 0; x < 320; ++x) {
            const double r = std::hypot(x - 159.5, y - 159.5) / 152.0;
            const std::uint8_t v = r < 0.5 ? 4 : static_cast<std::uint8_t>(std::lround(80 + 150 * (r - 0.5)));
            img.at(x, y, 0) = v;
            img.at(x, y, 1) = static_cast<std::uint8_t>(v * 0.6);
            img.at(x, y, 2) = static_cast<std::uint8_t>(v * 0.5);
        }
    const tune::FrameStats s = tune::measureFrame(img);
    EXPECT_NEAR(s[FrameStat::DarkFrac], 0.25, 0.01);
    EXPECT_LT(s[FrameStat::BandInner], 5);
    EXPECT_GT(s[FrameStat::BandOuter], s[FrameStat::BandMid]);
    EXPECT_GT(s[FrameStat::Ring9], s[FrameStat::Ring6]);
    EXPECT_GT(s[FrameStat::RingRatio], 1.2);
    EXPECT_GT(s[FrameStat::LAllMean], 0.5 * s[FrameStat::BandOuter]);
}

void write(const fs::path& p, const std::string& text) {
    std::ofstream(p) << text;
}

TEST(FrameStats, ScoresSummariesAndStatisticsFiles) {
    // A set against itself: distance 0 for every scored statistic.
    std::vector<tune::FrameStats> frames;
    for (const Reference& ref : kReferences) {
        tune::FrameStats f;
        f.values = ref.values;
        frames.push_back(f);
    }
    const tune::FrameStatsSummary a = tune::summarise(frames);
    const tune::RealismScore self = tune::realismScore(a, a);
    EXPECT_EQ(self.terms, tune::kScoredStatCount);
    EXPECT_EQ(self.overall, 0);
    // One statistic moved by twice its IQR: that term is 2, the mean 2/30.
    tune::FrameStatsSummary b = a;
    auto& l = b.stats[static_cast<std::size_t>(FrameStat::LMean)];
    l.median += 2 * a[FrameStat::LMean].iqr();
    const tune::RealismScore moved = tune::realismScore(b, a);
    EXPECT_NEAR(moved.perStat[static_cast<std::size_t>(FrameStat::LMean)], 2.0, 1e-9);
    EXPECT_NEAR(moved.overall, 2.0 / 30, 1e-9);
    EXPECT_NEAR(moved.perGroup[static_cast<std::size_t>(tune::StatGroup::Colour)], 0.2, 1e-9);
    EXPECT_EQ(moved.perGroup[static_cast<std::size_t>(tune::StatGroup::Texture)], 0);

    // A statistics file as the tool exports it: a missing key and null are no value.
    test::TempDir dir;
    const fs::path json = dir.path() / "real.json";
    write(json, R"({"frames": [{"name": "a", "stats": {"L_mean": 50.5, "hl_count": null}},
                                         {"name": "b", "stats": {"L_mean": 60, "psd_slope": -3.2}}]})");
    const std::vector<tune::FrameStats> read = tune::readFrameStats(json);
    ASSERT_EQ(read.size(), 2u);
    EXPECT_EQ(read[0][FrameStat::LMean], 50.5);
    EXPECT_TRUE(std::isnan(read[0][FrameStat::HlCount]));
    EXPECT_TRUE(std::isnan(read[0][FrameStat::PsdSlope]));
    EXPECT_EQ(read[1][FrameStat::PsdSlope], -3.2);
    write(json, R"({"frames": [{"name": "a", "stats": {"L_mean": "pale"}}]})");
    try {
        tune::readFrameStats(json);
        FAIL() << "a string statistic was read";
    } catch (const InputError& e) {
        EXPECT_EQ(std::string(e.what()),
                  "frames[0].stats.L_mean in " + json.string() + ": must be a number or null, not string");
    }
    FrameStat found{};
    EXPECT_TRUE(tune::findFrameStat("noise_sigma", found));
    EXPECT_EQ(found, FrameStat::NoiseSigma);
    EXPECT_FALSE(tune::findFrameStat("noise", found));
}

}  // namespace
