// mucosa dataset plan / run / verify: every frame a function of (plan, frame
// index), whatever the sharding; checksums that find missing and damaged
// frames; a rerun that fills them.
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <mucosa/frames/frames.hpp>
#include <mucosa/image/exr.hpp>
#include <mucosa/image/png.hpp>

#include "cli_helpers.hpp"
#include "test_support.hpp"

namespace mucosa {
namespace {

namespace fs = std::filesystem;

std::string q(const fs::path& p) {
    return "'" + p.string() + "'";
}

// Every file under dir/frames, by name, with its bytes.
std::vector<std::pair<std::string, std::string>> framesOf(const fs::path& dir) {
    std::vector<std::pair<std::string, std::string>> files;
    for (const auto& e : fs::directory_iterator(dir / "frames"))
        files.emplace_back(e.path().filename().string(), test::readBytes(e.path()));
    std::sort(files.begin(), files.end());
    return files;
}

void expectSameFrames(const fs::path& a, const fs::path& b) {
    const auto fa = framesOf(a), fb = framesOf(b);
    ASSERT_EQ(fa.size(), fb.size());
    for (std::size_t i = 0; i < fa.size(); ++i) {
        EXPECT_EQ(fa[i].first, fb[i].first);
        EXPECT_TRUE(fa[i].second == fb[i].second) << fa[i].first << " differs";
    }
}

test::RunResult ok(const std::string& args) {
    test::RunResult r = test::runCli(args);
    EXPECT_EQ(r.exitCode, 0) << args << "\n" << r.err;
    return r;
}

TEST(DatasetPlan, AnyShardingGivesTheBytesOfOneRun) {
    test::TempDir dir;
    const fs::path a = dir / "a", b = dir / "b";
    // Auto-exposure on (the default): each 2-frame segment restarts it, warmed
    // up over the 48 frames before; flow needs each shard's frame before.
    ok("dataset plan --frames 7 --size 96x72 --outputs rgb,depth,normals,flow --segment-frames 2 -o " + q(a));
    const nlohmann::json plan = nlohmann::json::parse(test::readBytes(a / "plan.json"));
    EXPECT_EQ(plan["frames"], 7);
    EXPECT_EQ(plan["segment_frames"], 2);
    EXPECT_EQ(plan["warm_frames"], 48);  // ceil(8 x 0.2 s x 30/s)
    // Shards out of order, one run twice (it finds its frames done).
    for (const char* shard : {"2/3", "0/3", "2/3", "1/3"}) ok("dataset run " + q(a) + " --shard " + shard);
    const test::RunResult again = ok("dataset run " + q(a) + " --shard 2/3");
    EXPECT_NE(again.out.find("nothing to do"), std::string::npos) << again.out;
    fs::create_directories(b);
    fs::copy_file(a / "plan.json", b / "plan.json");
    ok("dataset run " + q(b));
    expectSameFrames(a, b);
    // png, depth and normals (exr, png), flow, occlusion, the frame's record
    // (its exposure: the same bytes too), .sha256
    EXPECT_EQ(framesOf(a).size(), 7u * 9u);
    // More shards than segments (4): some have nothing to do.
    const test::RunResult empty = ok("dataset run " + q(a) + " --shard 5/10");
    EXPECT_NE(empty.out.find("no frames"), std::string::npos) << empty.out;
}

TEST(DatasetPlan, WithFixedExposureTheFramesAreMucosaRendersFrames) {
    test::TempDir dir;
    const std::string common = " --size 96x72 --set camera.auto_exposure=0 --outputs rgb,depth";
    ok("dataset plan --frames 4" + common + " -o " + q(dir / "plan"));
    const nlohmann::json plan = nlohmann::json::parse(test::readBytes(dir / "plan" / "plan.json"));
    EXPECT_EQ(plan["warm_frames"], 0);
    EXPECT_EQ(plan["segment_frames"], 1);
    ok("dataset run " + q(dir / "plan") + " --shard 1/2");
    ok("dataset run " + q(dir / "plan") + " --shard 0/2");
    ok("render --frames 4" + common + " -o " + q(dir / "fly.png"));
    for (int i = 0; i < 4; ++i)
        for (const char* suffix : {".png", ".depth.exr", ".depth.png", ".frame.json"}) {
            const std::string n = "_000" + std::to_string(i) + suffix;
            EXPECT_TRUE(test::readBytes(dir / "plan" / "frames" / ("frame" + n)) == test::readBytes(dir / ("fly" + n)))
                << n;
        }
}

TEST(DatasetPlan, VerifyFindsMissingAndDamagedFramesAndARerunFillsThem) {
    test::TempDir dir;
    const fs::path a = dir / "a";
    ok("dataset plan --frames 5 --size 64x48 --outputs rgb,depth --set camera.auto_exposure=0 -o " + q(a));
    ok("dataset run " + q(a));
    const std::string good = test::readBytes(a / "frames" / "frame_0003.depth.exr");
    fs::remove(a / "frames" / "frame_0001.sha256");  // as if killed before the frame was done
    {
        std::ofstream damage(a / "frames" / "frame_0003.depth.exr", std::ios::binary | std::ios::in);
        damage.seekp(200);
        damage.put('\x5a');
    }
    fs::remove(a / "frames" / "frame_0004.png");
    const test::RunResult bad = test::runCli("dataset verify " + q(a));
    test::expectOneErrorLine(bad, "1 frame of 5 missing (1)");
    EXPECT_NE(bad.err.find("2 frames of 5 damaged (3-4"), std::string::npos) << bad.err;
    EXPECT_NE(bad.err.find("frame_0003.depth.exr does not match its checksum"), std::string::npos) << bad.err;
    EXPECT_FALSE(fs::exists(a / "frames.json"));
    EXPECT_FALSE(fs::exists(a / "frames" / "frame_0003.sha256"));  // a rerun renders it again
    ok("dataset run " + q(a));
    EXPECT_TRUE(test::readBytes(a / "frames" / "frame_0003.depth.exr") == good);
    ok("dataset verify " + q(a));
    // Complete: SHA256SUMS, which sha256sum checks, and the manifest `mucosa
    // fit` reads (paths relative to it).
    const std::string check = "cd " + q(a) + " && sha256sum --quiet -c SHA256SUMS";
    EXPECT_EQ(std::system(check.c_str()), 0);
    const frames::FrameSet set = frames::readFrames(a / "frames.json");
    ASSERT_EQ(set.frames.size(), 5u);
    EXPECT_EQ(set.frames[4].image, a / "frames" / "frame_0004.png");
    const nlohmann::json j = nlohmann::json::parse(test::readBytes(a / "frames.json"));
    EXPECT_EQ(j["outputs"]["depth"]["file"], "frames/frame_{frame:04}.depth.exr");
}

TEST(DatasetPlan, BadRequestsGetOneLineAndChangeNothing) {
    test::TempDir dir;
    const fs::path a = dir / "a";
    test::expectOneErrorLine(test::runCli("dataset run " + q(a)), "plan.json");
    test::expectOneErrorLine(test::runCli("dataset verify " + q(a)), "plan.json");
    const fs::path scene = dir / "scene.json";
    { std::ofstream(scene) << R"({"mesh": "tube", "camera": {"fov_deg": 90}})"; }
    ok("dataset plan " + q(scene) + " --frames 3 --size 64x48 -o " + q(a));
    const std::string planBytes = test::readBytes(a / "plan.json");
    for (const char* shard : {"3/3", "1/0", "x", "1/", "-1/2"})
        test::expectOneErrorLine(test::runCli("dataset run " + q(a) + " --shard " + shard), "--shard", shard);
    // The same plan again is nothing to do; another one is refused.
    ok("dataset plan " + q(scene) + " --frames 3 --size 64x48 -o " + q(a));
    test::expectOneErrorLine(test::runCli("dataset plan " + q(scene) + " --frames 4 --size 64x48 -o " + q(a)),
                             "plans something else");
    EXPECT_EQ(test::readBytes(a / "plan.json"), planBytes);
    // The scene edited after planning: no shard renders from it.
    { std::ofstream(scene) << R"({"mesh": "tube", "camera": {"fov_deg": 80}})"; }
    test::expectOneErrorLine(test::runCli("dataset run " + q(a)), "no longer matches its scene");
    // The plan edited by hand: refused.
    std::string edited = planBytes;
    edited.replace(edited.find("\"size\": \"64x48\""), 15, "\"size\": \"64x40\"");
    { std::ofstream(a / "plan.json") << edited; }
    test::expectOneErrorLine(test::runCli("dataset run " + q(a)), "was edited");
    EXPECT_FALSE(fs::exists(a / "frames" / "frame_0000.png"));
}

}  // namespace
}  // namespace mucosa
