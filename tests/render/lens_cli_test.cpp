// mucosa render --lens / the scene's camera.lens: frames through a fisheye.
#include <filesystem>
#include <fstream>
#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <mucosa/core/error.hpp>
#include <mucosa/dataset/lens.hpp>
#include <mucosa/frames/frames.hpp>
#include <mucosa/image/png.hpp>

#include "cli_helpers.hpp"
#include "test_support.hpp"

namespace mucosa {
namespace {

namespace fs = std::filesystem;

constexpr const char* kFisheye =
    R"({"model": "fisheye", "width": 96, "height": 72, "fx": 40, "fy": 40, "cx": 47.5, "cy": 35.5, "k1": -0.01})";

TEST(LensCli, RenderDrawsThroughTheLensAndRecordsIt) {
    test::TempDir dir;
    std::ofstream(dir / "fisheye.json") << kFisheye;
    const std::string lens = (dir / "fisheye.json").string();
    test::RunResult r = test::runCli("render -o '" + (dir / "pin.png").string() + "' --size 96x72");
    ASSERT_EQ(r.exitCode, 0) << r.err;
    r = test::runCli("render -o '" + (dir / "fish.png").string() + "' --size 96x72 --lens '" + lens + "'");
    ASSERT_EQ(r.exitCode, 0) << r.err;
    EXPECT_NE(r.out.find("lens: fisheye 96x72"), std::string::npos) << r.out;
    const image::PngImage pin = image::readPng(dir / "pin.png"), fish = image::readPng(dir / "fish.png");
    ASSERT_EQ(fish.pixels.width(), 96);
    ASSERT_EQ(fish.pixels.height(), 72);
    // The same view through another lens: a different picture, and a lit one.
    long differ = 0, lit = 0;
    for (int y = 0; y < 72; ++y)
        for (int x = 0; x < 96; ++x) {
            int d = 0, s = 0;
            for (int c = 0; c < 3; ++c)
                d += std::abs(int(pin.pixels.at(x, y, c)) - int(fish.pixels.at(x, y, c))), s += fish.pixels.at(x, y, c);
            differ += d > 30;
            lit += s > 30;
        }
    EXPECT_GT(differ, 96 * 72 / 10);
    EXPECT_GT(lit, 96 * 72 / 3);

    // The scene's camera.lens (an object) gives the same bytes as --lens.
    std::ofstream(dir / "scene.json") << R"({"mesh": "phantom", "resolution": [96, 72], "camera": {"lens": )"
                                      << kFisheye << "}}";
    r = test::runCli("render '" + (dir / "scene.json").string() + "' -o '" + (dir / "scene.png").string() + "'");
    ASSERT_EQ(r.exitCode, 0) << r.err;
    EXPECT_EQ(test::readBytes(dir / "scene.png"), test::readBytes(dir / "fish.png"));

    // A sequence records its lens: resuming with another is refused.
    const std::string seq = "render -o '" + (dir / "seq.png").string() + "' --size 96x72 --frames 2 --lens '";
    r = test::runCli(seq + lens + "'");
    ASSERT_EQ(r.exitCode, 0) << r.err;
    const nlohmann::json record = nlohmann::json::parse(test::readBytes(dir / "seq.render.json"));
    EXPECT_EQ(record["lens"]["model"], "fisheye");
    EXPECT_DOUBLE_EQ(record["lens"]["k1"].get<double>(), -0.01);
    fs::remove(dir / "seq_0001.png");
    std::ofstream(dir / "other.json") << R"({"model": "fisheye", "width": 96, "height": 72, "fx": 41, "fy": 41,
                                            "cx": 47.5, "cy": 35.5})";
    r = test::runCli(seq + (dir / "other.json").string() + "'");
    test::expectOneErrorLine(r, "lens");
    EXPECT_FALSE(fs::exists(dir / "seq_0001.png"));

    // The dataset manifest carries the lens, and the tools that read pinhole frames refuse it.
    r = test::runCli("render -o '" + (dir / "ds.png").string() +
                     "' --size 96x72 --frames 2 --outputs rgb,depth,mask --lens '" + lens + "'");
    ASSERT_EQ(r.exitCode, 0) << r.err;
    // Its ground truth goes through the lens: the mask is the colour frame's lit field of view.
    const image::PngImage mask = image::readPng(dir / "ds_0001.mask.png"), rgb = image::readPng(dir / "ds_0001.png");
    EXPECT_GE(test::maskAgreesWithLitPixels(rgb, mask), 0.97);
    const nlohmann::json manifest = nlohmann::json::parse(test::readBytes(dir / "ds.frames.json"));
    EXPECT_EQ(manifest["lens"]["model"], "fisheye");
    EXPECT_DOUBLE_EQ(manifest["frames"][1]["intrinsics"]["fx"].get<double>(), 40.0);
    EXPECT_THROW(frames::readFrames(dir / "ds.frames.json"), InputError);
    // The exporters write the fisheye as OPENCV_FISHEYE with its k1..k4 (pixel centres at +0.5).
    r = test::runCli("dataset export '" + (dir / "ds.frames.json").string() + "' --format colmap -o '" +
                     (dir / "colmap").string() + "'");
    ASSERT_EQ(r.exitCode, 0) << r.err;
    EXPECT_NE(test::readBytes(dir / "colmap" / "cameras.txt").find("1 OPENCV_FISHEYE 96 72 40 40 48 36 -0.01 0 0 0"),
              std::string::npos)
        << test::readBytes(dir / "colmap" / "cameras.txt");
    r = test::runCli("dataset export '" + (dir / "ds.frames.json").string() + "' --format nerfstudio -o '" +
                     (dir / "transforms.json").string() + "'");
    ASSERT_EQ(r.exitCode, 0) << r.err;
    const nlohmann::json ns = nlohmann::json::parse(test::readBytes(dir / "transforms.json"));
    EXPECT_EQ(ns["camera_model"], "OPENCV_FISHEYE");
    EXPECT_DOUBLE_EQ(ns["k1"].get<double>(), -0.01);
    EXPECT_DOUBLE_EQ(ns["cx"].get<double>(), 48.0);
}

// The bronchoscope preset: an equidistant fisheye at the frame's size whose
// image circle (the default mask: half the smaller side) spans 120 degrees,
// or the degrees given; drawn in one wide face, its ground truth through the
// same lens; the scene's form gives the same bytes.
TEST(LensCli, TheEquidistantPresetIsABronchoscopesFisheyeAtTheFramesSize) {
    test::TempDir dir;
    test::RunResult r = test::runCli("render -o '" + (dir / "e.png").string() +
                                     "' --size 96x72 --frames 2 --outputs rgb,mask --lens equidistant");
    ASSERT_EQ(r.exitCode, 0) << r.err;
    EXPECT_NE(r.out.find("lens: fisheye 96x72, drawn through one wide face"), std::string::npos) << r.out;
    const nlohmann::json manifest = nlohmann::json::parse(test::readBytes(dir / "e.frames.json"));
    EXPECT_EQ(manifest["lens"]["model"], "fisheye");
    EXPECT_NEAR(manifest["lens"]["fx"].get<double>(), 36.0 / (M_PI / 3.0), 1e-9);
    EXPECT_DOUBLE_EQ(manifest["lens"]["cx"].get<double>(), 47.5);
    const image::PngImage mask = image::readPng(dir / "e_0001.mask.png"), rgb = image::readPng(dir / "e_0001.png");
    EXPECT_GE(test::maskAgreesWithLitPixels(rgb, mask), 0.97);
    std::ofstream(dir / "scene.json")
        << R"({"mesh": "phantom", "resolution": [96, 72], "camera": {"lens": {"model": "equidistant", "fov_deg": 140}}})";
    r = test::runCli("render '" + (dir / "scene.json").string() + "' -o '" + (dir / "s.png").string() + "'");
    ASSERT_EQ(r.exitCode, 0) << r.err;
    r = test::runCli("render -o '" + (dir / "c.png").string() + "' --size 96x72 --lens equidistant:140");
    ASSERT_EQ(r.exitCode, 0) << r.err;
    EXPECT_EQ(test::readBytes(dir / "s.png"), test::readBytes(dir / "c.png"));
    r = test::runCli("render -o '" + (dir / "bad.png").string() + "' --size 96x72 --lens equidistant:wide");
    test::expectOneErrorLine(r, "--lens");
    std::ofstream(dir / "bad.json")
        << R"({"mesh": "phantom", "camera": {"lens": {"model": "equidistant", "fov_deg": 120, "fx": 3}}})";
    r = test::runCli("render '" + (dir / "bad.json").string() + "' -o '" + (dir / "bad.png").string() + "'");
    test::expectOneErrorLine(r, "camera.lens.fx");
    EXPECT_FALSE(fs::exists(dir / "bad.png"));
}

TEST(LensCli, AnOmnidirectionalDatasetExportsItsTrajectoryOnly) {
    test::TempDir dir;
    std::ofstream(dir / "ocam.json")
        << R"({"model": "omnidirectional", "width": 96, "height": 72, "pol": [-40, 0, 0.005], "xc": 35.5, "yc": 47.5})";
    test::RunResult r =
        test::runCli("render -o '" + (dir / "o.png").string() + "' --size 96x72 --frames 2 --outputs rgb --lens '" +
                     (dir / "ocam.json").string() + "'");
    ASSERT_EQ(r.exitCode, 0) << r.err;
    EXPECT_EQ(nlohmann::json::parse(test::readBytes(dir / "o.frames.json"))["lens"]["model"], "omnidirectional");
    r = test::runCli("dataset export '" + (dir / "o.frames.json").string() + "' --format colmap -o '" +
                     (dir / "colmap").string() + "'");
    test::expectOneErrorLine(r, "omnidirectional");
    EXPECT_FALSE(fs::exists(dir / "colmap"));
    r = test::runCli("dataset export '" + (dir / "o.frames.json").string() + "' --format tum -o '" +
                     (dir / "t.txt").string() + "'");
    ASSERT_EQ(r.exitCode, 0) << r.err;
    EXPECT_TRUE(fs::exists(dir / "t.txt"));
}

TEST(LensCli, BadLensesAreOneLine) {
    test::TempDir dir;
    std::ofstream(dir / "fisheye.json") << kFisheye;
    const std::string out = " -o '" + (dir / "x.png").string() + "'";
    const std::string lens = " --lens '" + (dir / "fisheye.json").string() + "'";
    // Another size than the frames'.
    test::RunResult r = test::runCli("render --size 64x48" + out + lens);
    test::expectOneErrorLine(r, "--size 96x72");
    // The reference renderer draws pinholes only.
    r = test::runCli("render --size 96x72 --reference" + out + lens);
    test::expectOneErrorLine(r, "--reference");
    // A missing file, a bad field, a scene whose camera.lens is neither an object nor a file.
    r = test::runCli("render --size 96x72 --lens '" + (dir / "none.json").string() + "'" + out);
    test::expectOneErrorLine(r, "no such file");
    std::ofstream(dir / "bad.json") << R"({"model": "fisheye", "width": 96, "height": 72, "fx": -1, "fy": 40,
                                          "cx": 47.5, "cy": 35.5})";
    r = test::runCli("render --size 96x72 --lens '" + (dir / "bad.json").string() + "'" + out);
    test::expectOneErrorLine(r, "fx");
    std::ofstream(dir / "scene.json") << R"({"mesh": "phantom", "camera": {"lens": 3}})";
    r = test::runCli("render '" + (dir / "scene.json").string() + "'" + out);
    test::expectOneErrorLine(r, "camera.lens");
    EXPECT_FALSE(fs::exists(dir / "x.png"));
}

}  // namespace
}  // namespace mucosa
