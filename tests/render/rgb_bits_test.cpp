// mucosa render --rgb-bits 16: the colour frames as 16-bit PNGs.
#include <cmath>
#include <filesystem>
#include <set>
#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <mucosa/image/png.hpp>

#include "cli_helpers.hpp"
#include "test_support.hpp"

namespace mucosa {
namespace {

namespace fs = std::filesystem;

TEST(RgbBits, SixteenBitFramesAreTheEightBitFramesWithMoreLevels) {
    test::TempDir dir;
    test::RunResult r = test::runCli("render --size 96x72 -o '" + (dir / "b8.png").string() + "'");
    ASSERT_EQ(r.exitCode, 0) << r.err;
    r = test::runCli("render --size 96x72 --rgb-bits 16 -o '" + (dir / "b16.png").string() + "'");
    ASSERT_EQ(r.exitCode, 0) << r.err;
    const image::PngImage b8 = image::readPng(dir / "b8.png"), b16 = image::readPng(dir / "b16.png");
    EXPECT_EQ(b8.bitDepth, 8);
    ASSERT_EQ(b16.bitDepth, 16);
    // The same frame: the 8-bit target rounds v x 255, the float target is
    // rounded once to v x 65535 (so v16 / 257 is within half a step of v8).
    std::set<int> levels;
    double worst = 0;
    for (int y = 0; y < 72; ++y)
        for (int x = 0; x < 96; ++x)
            for (int c = 0; c < 3; ++c) {
                worst = std::max(worst, std::abs(b16.pixels.at(x, y, c) / 257.0 - b8.pixels.at(x, y, c)));
                levels.insert(b16.pixels.at(x, y, c));
            }
    EXPECT_LE(worst, 0.51);
    EXPECT_GT(levels.size(), 2000u);  // 96 x 72 x 3 values: far more levels than 8 bits have

    // A sequence records the depth; the manifest says it; resuming at 8 bits is refused.
    const std::string seq = "render --size 96x72 --frames 2 --outputs rgb -o '" + (dir / "s.png").string() + "'";
    r = test::runCli(seq + " --rgb-bits 16");
    ASSERT_EQ(r.exitCode, 0) << r.err;
    const nlohmann::json manifest = nlohmann::json::parse(test::readBytes(dir / "s.frames.json"));
    EXPECT_EQ(manifest["outputs"]["rgb"]["encoding"].get<std::string>().rfind("16-bit PNG", 0), 0u);
    EXPECT_EQ(image::readPng(dir / "s_0001.png").bitDepth, 16);
    fs::remove(dir / "s_0001.png");
    r = test::runCli(seq);
    test::expectOneErrorLine(r, "rgb bits");
    EXPECT_FALSE(fs::exists(dir / "s_0001.png"));
    // Other depths, and the reference renderer, are refused.
    r = test::runCli("render --rgb-bits 12 -o '" + (dir / "x.png").string() + "'");
    test::expectOneErrorLine(r, "--rgb-bits");
    r = test::runCli("render --rgb-bits 16 --reference -o '" + (dir / "x.png").string() + "'");
    test::expectOneErrorLine(r, "--rgb-bits");
    EXPECT_FALSE(fs::exists(dir / "x.png"));
}

}  // namespace
}  // namespace mucosa
