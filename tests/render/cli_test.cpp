// mucosa render / compare end to end: frame sequences are numbered, resumable
// (existing frames are kept unless --overwrite), the sheet is written.
#include <gtest/gtest.h>

#include <fstream>

#include <mucosa/core/file.hpp>
#include <mucosa/image/png.hpp>

#include "test_support.hpp"

namespace mucosa {
namespace {

TEST(RenderCli, FrameSequenceIsNumberedAndResumable) {
    test::TempDir dir;
    std::ofstream(dir / "tube.json") << R"({"mesh": "tube", "resolution": [96, 72]})";
    const std::string base =
        "render '" + (dir / "tube.json").string() + "' -o '" + (dir / "fly.png").string() + "' --frames 4";
    auto r = test::runCli(base);
    ASSERT_EQ(r.exitCode, 0) << r.err;
    for (int i = 0; i < 4; ++i) EXPECT_TRUE(std::filesystem::exists(dir / ("fly_000" + std::to_string(i) + ".png")));
    EXPECT_NE(r.out.find("wrote 4 frames"), std::string::npos) << r.out;
    const auto img = image::readPng(dir / "fly_0002.png");
    EXPECT_EQ(img.pixels.width(), 96);
    EXPECT_EQ(img.pixels.height(), 72);

    // Resume: a missing frame is rendered, the others are kept.
    std::filesystem::remove(dir / "fly_0001.png");
    const auto before = std::filesystem::last_write_time(dir / "fly_0003.png");
    r = test::runCli(base);
    ASSERT_EQ(r.exitCode, 0) << r.err;
    EXPECT_NE(r.out.find("wrote 1 frame of"), std::string::npos) << r.out;
    EXPECT_NE(r.out.find("kept 3 existing"), std::string::npos) << r.out;
    EXPECT_TRUE(std::filesystem::exists(dir / "fly_0001.png"));
    EXPECT_EQ(std::filesystem::last_write_time(dir / "fly_0003.png"), before);

    r = test::runCli(base);
    EXPECT_NE(r.out.find("nothing to do"), std::string::npos) << r.out;
    r = test::runCli(base + " --overwrite");
    EXPECT_NE(r.out.find("wrote 4 frames"), std::string::npos) << r.out;
}

TEST(RenderCli, EveryModeAndTheReferenceRenderFromTheCli) {
    test::TempDir dir;
    std::ofstream(dir / "tube.json") << R"({"mesh": "tube", "resolution": [64, 48]})";
    for (const char* mode :
         {"noise", "vertex-phong", "multitexture", "diffuse", "normals", "tangents", "uv", "depth"}) {
        const auto out = dir / (std::string(mode) + ".png");
        const auto r = test::runCli("render '" + (dir / "tube.json").string() + "' --mode " + mode + " -o '" +
                                    out.string() + "' --set material.shininess=60");
        EXPECT_EQ(r.exitCode, 0) << mode << ": " << r.err;
        EXPECT_TRUE(std::filesystem::exists(out)) << mode;
    }
    const auto r = test::runCli("render '" + (dir / "tube.json").string() + "' --reference -o '" +
                                (dir / "ref.png").string() + "'");
    EXPECT_EQ(r.exitCode, 0) << r.err;
    const auto bad = test::runCli("render --set material.shininess=abc -o '" + (dir / "x.png").string() + "'");
    EXPECT_EQ(bad.exitCode, 1);
    EXPECT_NE(bad.err.find("error: --set material.shininess"), std::string::npos) << bad.err;
}

TEST(RenderCli, CompareWritesTheLabelledSheet) {
    test::TempDir dir;
    std::ofstream(dir / "tube.json") << R"({"mesh": "tube"})";
    const auto out = dir / "sheet.png";
    const auto r =
        test::runCli("compare '" + (dir / "tube.json").string() + "' --tile 160x120 -o '" + out.string() + "'");
    ASSERT_EQ(r.exitCode, 0) << r.err;
    const auto img = image::readPng(out);
    EXPECT_GT(img.pixels.width(), 4 * 160);
    EXPECT_GT(img.pixels.height(), 4 * 120);
}

}  // namespace
}  // namespace mucosa

namespace mucosa {
namespace {

TEST(RenderCli, PhantomFileFlownAlongItsCenterlineJson) {
    test::TempDir dir;
    auto r = test::runCli("phantom -q --generations 2 --resolution 1 -o '" + (dir / "airway.glb").string() + "'");
    ASSERT_EQ(r.exitCode, 0) << r.err;
    ASSERT_TRUE(std::filesystem::exists(dir / "airway.centerline.json"));
    std::ofstream(dir / "scene.json")
        << R"({"mesh": "airway.glb", "camera": {"path": {"centerline": "airway.centerline.json", "branch": 1}},
              "resolution": [96, 72]})";
    r = test::runCli("render '" + (dir / "scene.json").string() + "' --frames 2 -o '" + (dir / "f.png").string() + "'");
    ASSERT_EQ(r.exitCode, 0) << r.err;
    EXPECT_TRUE(std::filesystem::exists(dir / "f_0001.png"));
    std::ofstream(dir / "bad.json")
        << R"({"mesh": "airway.glb", "camera": {"path": {"centerline": "airway.centerline.json", "branch": 99}}})";
    r = test::runCli("render '" + (dir / "bad.json").string() + "' -o '" + (dir / "g.png").string() + "'");
    EXPECT_EQ(r.exitCode, 1);
    EXPECT_NE(r.err.find("error: camera.path.branch"), std::string::npos) << r.err;
}

TEST(RenderCli, ProceduralRenderGeneratesNoMap) {
    test::TempDir dir;
    std::ofstream(dir / "tube.json") << R"({"mesh": "tube", "resolution": [64, 48]})";
    auto r = test::runCli("render tube.json -o p.png --mode procedural", dir.path());
    ASSERT_EQ(r.exitCode, 0) << r.err;
    EXPECT_EQ(r.out.find("reflectance map generated"), std::string::npos) << r.out;
    r = test::runCli("render tube.json -o n.png --mode noise", dir.path());
    ASSERT_EQ(r.exitCode, 0) << r.err;
    EXPECT_NE(r.out.find("reflectance map generated"), std::string::npos) << r.out;
    // The C++ reference too (it falls back to the flat map it never reads).
    r = test::runCli("render tube.json -o q.png --mode procedural --reference", dir.path());
    ASSERT_EQ(r.exitCode, 0) << r.err;
}

// A long run that will not fit on the disk is refused before it writes any
// frame: the first frame encoded is the estimate for the rest.
TEST(RenderCli, FramesThatWillNotFitOnTheDiskAreRefusedBeforeWriting) {
    test::TempDir dir;
    std::ofstream(dir / "tube.json") << R"({"mesh": "tube", "resolution": [1024, 1024]})";
    // 10^6 frames of >= 256 KiB is >= 244 GiB: more than this machine's disk.
    ASSERT_LT(availableDiskBytes(dir.path()), 1000000ull * (256u << 10)) << "the disk is too large for this test";
    const auto r = test::runCli("render '" + (dir / "tube.json").string() + "' -o '" + (dir / "fly.png").string() +
                                "' --frames 1000000");
    EXPECT_NE(r.exitCode, 0);
    EXPECT_EQ(r.err.rfind("error: 1000000 frames of ~", 0), 0u) << r.err;
    EXPECT_NE(r.err.find("of disk but only"), std::string::npos) << r.err;
    std::size_t files = 0;
    for (const auto& e : std::filesystem::directory_iterator(dir.path())) files += e.path().extension() == ".png";
    EXPECT_EQ(files, 0u);
}

}  // namespace
}  // namespace mucosa
