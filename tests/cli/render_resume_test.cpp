// `mucosa render --frames N` resumes an interrupted run by keeping the frames
// on disk, but only frames made with this run's settings: out.render.json
// records them, a run with other settings is refused, --overwrite starts over.
#include <filesystem>
#include <fstream>
#include <map>
#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <mucosa/image/png.hpp>

#include "cli_helpers.hpp"
#include "test_support.hpp"

namespace mucosa::test {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

class RenderResume : public ::testing::Test {
protected:
    void SetUp() override {
        std::ofstream(dir / "tube.json") << R"({"mesh": "tube", "resolution": [48, 36]})";
        const auto r = render("");
        ASSERT_EQ(r.exitCode, 0) << r.err;
    }

    // Three frames unless `extra` says otherwise.
    RunResult render(const std::string& extra) const {
        const std::string frames = extra.find("--frames") == std::string::npos ? "--frames 3 " : "";
        return runCli("render tube.json -o f.png " + frames + extra, dir.path());
    }

    std::map<std::string, std::string> frames() const {
        std::map<std::string, std::string> bytes;
        for (const auto& e : fs::directory_iterator(dir.path()))
            if (e.path().extension() == ".png") bytes[e.path().filename().string()] = readBytes(e.path());
        return bytes;
    }

    json manifest() const { return json::parse(readBytes(dir / "f.render.json")); }

    TempDir dir;
};

TEST_F(RenderResume, TheRecordNamesWhatChangesThePixels) {
    const json m = manifest();
    EXPECT_EQ(m["frames"], 3);
    EXPECT_EQ(m["size"], "48x36");
    EXPECT_EQ(m["mode"], "noise");
    EXPECT_EQ(m["renderer"], "opengl");
    EXPECT_EQ(m["scene_file"], (dir / "tube.json").lexically_normal().string());
    EXPECT_TRUE(m["scene_fnv1a64"].is_string());
    EXPECT_EQ(m["parameters"]["material.shininess"], 120.0);
    EXPECT_TRUE(m["reflectance_map"].contains("frequency"));
    // No temporary left behind: it was written atomically.
    for (const auto& e : fs::directory_iterator(dir.path()))
        EXPECT_EQ(e.path().filename().string().find(".tmp-"), std::string::npos) << e.path();
    // A single frame is not a sequence: no record.
    ASSERT_EQ(runCli("render tube.json -o one.png", dir.path()).exitCode, 0);
    EXPECT_FALSE(fs::exists(dir / "one.render.json"));
}

TEST_F(RenderResume, AnInterruptedRunResumesWithTheSameSettings) {
    const auto kept = readBytes(dir / "f_0002.png");
    const auto keptTime = fs::last_write_time(dir / "f_0002.png");
    fs::remove(dir / "f_0001.png");  // as if killed after frame 0
    auto r = render("");
    ASSERT_EQ(r.exitCode, 0) << r.err;
    EXPECT_NE(r.out.find("wrote 1 frame of"), std::string::npos) << r.out;
    EXPECT_NE(r.out.find("kept 2 existing"), std::string::npos) << r.out;
    EXPECT_TRUE(fs::exists(dir / "f_0001.png"));
    EXPECT_EQ(fs::last_write_time(dir / "f_0002.png"), keptTime);
    EXPECT_EQ(readBytes(dir / "f_0002.png"), kept);
    // The same settings spelled differently are the same settings.
    r = render("--size 48x36 --mode noise --set shininess=120 --specular-aa on");
    ASSERT_EQ(r.exitCode, 0) << r.err;
    EXPECT_NE(r.out.find("nothing to do"), std::string::npos) << r.out;
}

TEST_F(RenderResume, FramesMadeWithOtherSettingsAreNotMixedIn) {
    const auto before = frames();
    const json recorded = manifest();
    fs::remove(dir / "f_0001.png");  // partly done: a run with other settings would fill the gap
    const auto partial = frames();
    const std::pair<std::string, std::string> changes[] = {
        {"--size 64x48", "size 48x36 (this run: 64x48)"},
        {"--frames 4", "frames 3 (this run: 4)"},
        {"--mode vertex-phong", "mode noise (this run: vertex-phong)"},
        {"--set material.shininess=80", "material.shininess 120.0 (this run: 80.0)"},
        {"--set reflectance_map.frequency=4", "reflectance_map.frequency"},
        {"--specular-aa off", "specular anti-aliasing true (this run: false)"},
        {"--reference", "renderer opengl (this run: reference)"},
    };
    for (const auto& [extra, named] : changes) {
        const auto r = render(extra);
        expectOneErrorLine(r, "error: resume in f.render.json: 2 frames of this sequence already exist", extra);
        EXPECT_NE(r.err.find(named), std::string::npos) << extra << "\n" << r.err;
        EXPECT_NE(r.err.find("--overwrite"), std::string::npos) << r.err;
        EXPECT_EQ(frames(), partial) << extra << ": frames were written";
        EXPECT_EQ(manifest(), recorded) << extra << ": the record was changed";
    }
    // With every frame on disk a new mode is refused too, not "nothing to do".
    ASSERT_EQ(render("").exitCode, 0);
    EXPECT_EQ(frames(), before);
    expectOneErrorLine(render("--mode vertex-phong"), "mode noise (this run: vertex-phong)");
    // An edited scene file.
    std::ofstream(dir / "tube.json") << R"({"mesh": "tube", "resolution": [48, 36], "camera": {"fov_deg": 90}})";
    expectOneErrorLine(render(""), "scene file content");
    EXPECT_EQ(frames(), before);
}

TEST_F(RenderResume, FramesWithoutARecordAreNotResumed) {
    fs::remove(dir / "f.render.json");
    fs::remove(dir / "f_0001.png");
    expectOneErrorLine(render(""), "2 frames of this sequence already exist, but this file, which records");
    std::ofstream(dir / "f.render.json") << "{ not json";
    expectOneErrorLine(render(""), "is not JSON");
    EXPECT_FALSE(fs::exists(dir / "f_0001.png"));
}

TEST_F(RenderResume, OverwriteStartsOver) {
    auto r = render("--size 64x48 --overwrite");
    ASSERT_EQ(r.exitCode, 0) << r.err;
    EXPECT_NE(r.out.find("wrote 3 frames"), std::string::npos) << r.out;
    for (const char* f : {"f_0000.png", "f_0001.png", "f_0002.png"}) {
        const auto img = image::readPng(dir / f);
        EXPECT_EQ(img.pixels.width(), 64) << f;
        EXPECT_EQ(img.pixels.height(), 48) << f;
    }
    EXPECT_EQ(manifest()["size"], "64x48");
    r = render("--size 64x48");
    ASSERT_EQ(r.exitCode, 0) << r.err;
    EXPECT_NE(r.out.find("nothing to do"), std::string::npos) << r.out;
}

}  // namespace
}  // namespace mucosa::test
