// mucosa register end to end: frames in a folder, camera and pose files, the
// frames file out (resumable), the report, and every bad input as one line.
#include <gtest/gtest.h>

#include <fstream>
#include <map>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <mucosa/frames/frames.hpp>
#include <mucosa/image/png.hpp>
#include <mucosa/mesh/io.hpp>
#include <mucosa/mesh/repair.hpp>
#include <mucosa/register/register.hpp>

#include "register_scene.hpp"
#include "test_support.hpp"
#include "video_encode.hpp"

using namespace mucosa;
namespace fs = std::filesystem;
using nlohmann::json;

namespace {

constexpr int kSize = 160;

frames::Intrinsics camera() {
    frames::Intrinsics K;
    K.width = K.height = kSize;
    K.fx = K.fy = 90;
    K.cx = K.cy = (kSize - 1) / 2.0;
    return K;
}

void writeText(const fs::path& p, const std::string& s) {
    std::ofstream(p) << s;
}

json poseJson(const frames::Mat4& m) {
    json rows = json::array();
    for (const auto& r : m) rows.push_back(r);
    return json{{"camera_to_world", rows}};
}

// A patient folder: airway.ply, video/NNN.png (16-bit linear), camera.json, init.json.
struct Patient {
    test::RegisterScene scene = test::makeRegisterScene(5);
    test::TempDir dir;
    Patient() {
        mesh::save(scene.mesh, dir / "airway.ply");
        fs::create_directories(dir / "video");
        for (std::size_t i = 0; i < scene.poses.size(); ++i) {
            test::VideoOptions vo;
            vo.seed = static_cast<unsigned>(i + 3);
            vo.gain = 0.8 + 0.1 * static_cast<double>(i % 3);
            const image::ImageF f = test::renderVideoFrame(scene.truth, camera(), scene.poses[i], vo, 0);
            image::Image16 px(kSize, kSize, 3);
            for (std::size_t k = 0; k < f.size(); ++k)
                px.data()[k] = static_cast<std::uint16_t>(std::lround(65535.0 * std::clamp(f.data()[k], 0.f, 1.f)));
            image::writePng(dir / "video" / fmt::format("{:03d}.png", i), px);
        }
        const frames::Intrinsics K = camera();
        writeText(
            dir / "camera.json",
            json{{"intrinsics",
                  {{"width", K.width}, {"height", K.height}, {"fx", K.fx}, {"fy", K.fy}, {"cx", K.cx}, {"cy", K.cy}}},
                 {"gamma", 1.0}}
                .dump());
        writeText(dir / "init.json",
                  poseJson(registration::perturbPose(scene.poses[0], {0.8, -0.6, 0.5}, {0.02, -0.02, 0.01})).dump());
    }
    // The command line; `over` replaces a file option (--mesh, --video, --camera, --init).
    std::string args(const std::string& extra = "", const std::map<std::string, fs::path>& over = {}) const {
        const fs::path d = dir.path();
        std::map<std::string, fs::path> o{{"--mesh", d / "airway.ply"},
                                          {"--video", d / "video"},
                                          {"--camera", d / "camera.json"},
                                          {"--init", d / "init.json"},
                                          {"-o", d / "out" / "frames.json"}};
        for (const auto& [k, v] : over) o[k] = v;
        std::string s = "register";
        for (const auto& [k, v] : o) s += " " + k + " '" + v.string() + "'";
        return s + " " + extra;
    }
};

void expectOneErrorLine(const test::RunResult& r, const std::string& needle) {
    EXPECT_NE(r.exitCode, 0) << r.err;
    ASSERT_FALSE(r.err.empty());
    const std::string last = r.err.substr(0, r.err.find('\n'));
    EXPECT_EQ(last.rfind("error: ", 0), 0u) << r.err;
    EXPECT_NE(r.err.find(needle), std::string::npos) << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
}

}  // namespace

TEST(RegisterCli, RegistersResumesAndReports) {
    Patient p;
    fs::create_directories(p.dir / "out");
    // An earlier report in the folder: its images go, the user's files stay.
    fs::create_directories(p.dir / "report");
    writeText(p.dir / "report" / "frame00077_overlay.png", "stale");
    writeText(p.dir / "report" / "notes.txt", "mine");
    const test::RunResult r = test::runCli(p.args("--report '" + (p.dir / "report").string() + "' --report-frames 2"));
    ASSERT_EQ(r.exitCode, 0) << r.err;
    EXPECT_NE(r.out.find("registered 5 frames (5 converged) with method pq"), std::string::npos) << r.out;
    EXPECT_NE(r.out.find("pose sd, median over frames"), std::string::npos) << r.out;
    // The frames file mucosa fit reads, with the registration per frame.
    const frames::FrameSet set = frames::readFrames(p.dir / "out" / "frames.json");
    ASSERT_EQ(set.frames.size(), 5u);
    for (std::size_t i = 0; i < 5; ++i) {
        const registration::PoseError e = registration::poseError(set.frames[i].cameraToWorld, p.scene.poses[i]);
        EXPECT_LT(e.position, 0.8) << i;
        EXPECT_LT(e.degrees, 2.5) << i;
        EXPECT_FALSE(set.frames[i].flagged);
        EXPECT_TRUE(fs::equivalent(set.frames[i].image, p.dir / "video" / fmt::format("{:03d}.png", i)));
    }
    const json j = json::parse(test::readBytes(p.dir / "out" / "frames.json"));
    EXPECT_EQ(j["registration"]["method"], "pq");
    EXPECT_EQ(j["registration"]["albedo_map"], true);        // the default
    EXPECT_EQ(j["frames"][0]["image"], "../video/000.png");  // relative to the frames file
    EXPECT_GT(j["frames"][4]["registration"]["similarity"].get<double>(), 0.85);
    EXPECT_GT(j["frames"][4]["registration"]["renders"].get<int>(), 10);
    // Down this airway every frame has its lumen in view: none flagged for
    // facing the wall, none searched for.
    for (const json& f : j["frames"]) {
        EXPECT_EQ(f["registration"]["no_lumen"], false);
        EXPECT_EQ(f["registration"]["searched"], false);
        EXPECT_GT(f["registration"]["depth_range"].get<double>(), registration::RegisterOptions{}.minDepthRange);
    }
    // The pose's standard deviations per frame (camera axes): finite and
    // small on this bumpy airway, and the frame's error within a few of them.
    for (std::size_t i = 0; i < 5; ++i) {
        const json& sd = j["frames"][i]["registration"]["pose_sd"];
        ASSERT_TRUE(sd["position_mm"].is_array() && sd["position_mm"].size() == 3u) << sd.dump();
        ASSERT_TRUE(sd["rotation_deg"].is_array() && sd["rotation_deg"].size() == 3u) << sd.dump();
        for (std::size_t k = 0; k < 3; ++k) {
            ASSERT_TRUE(sd["position_mm"][k].is_number() && sd["rotation_deg"][k].is_number()) << i << sd.dump();
            EXPECT_GT(sd["position_mm"][k].get<double>(), 0.0);
            EXPECT_LT(sd["position_mm"][k].get<double>(), 1.0);
            EXPECT_GT(sd["rotation_deg"][k].get<double>(), 0.0);
            EXPECT_LT(sd["rotation_deg"][k].get<double>(), 3.0);
        }
        const registration::PoseError e = registration::poseError(set.frames[i].cameraToWorld, p.scene.poses[i]);
        const double sdMm = std::hypot(sd["position_mm"][0].get<double>(), sd["position_mm"][1].get<double>(),
                                       sd["position_mm"][2].get<double>());
        EXPECT_LT(e.position, 5 * sdMm + 0.1) << i;
    }
    // Read back as written (a resumed run keeps them).
    const registration::RegistrationRun back = registration::readRegistration(p.dir / "out" / "frames.json");
    EXPECT_NEAR(back.frames[3].r.poseSd[5], j["frames"][3]["registration"]["pose_sd"]["rotation_deg"][2].get<double>(),
                1e-12);
    // The report: the trace and the sampled frames' overlays.
    const std::string html = test::readBytes(p.dir / "report" / "index.html");
    EXPECT_NE(html.find("sd along x, y, z:"), std::string::npos);
    EXPECT_NE(html.find("<polyline"), std::string::npos);
    EXPECT_TRUE(fs::exists(p.dir / "report" / "frame00000_overlay.png"));
    EXPECT_TRUE(fs::exists(p.dir / "report" / "frame00004_pq_model.png"));
    EXPECT_FALSE(fs::exists(p.dir / "report" / "frame00077_overlay.png"));
    EXPECT_TRUE(fs::exists(p.dir / "report" / "notes.txt"));

    // Resume: cut the run to its first two frames and mark the third's image
    // as new; only frames 2..4 are registered again, 0 and 1 are kept as they
    // were (byte for byte in their poses).
    json cut = j;
    cut["frames"].erase(cut["frames"].begin() + 2, cut["frames"].end());
    cut["frames"][1]["camera_to_world"][0][3] = j["frames"][1]["camera_to_world"][0][3].get<double>() + 0.25;
    writeText(p.dir / "out" / "frames.json", cut.dump());
    const test::RunResult again = test::runCli(p.args());
    ASSERT_EQ(again.exitCode, 0) << again.err;
    EXPECT_NE(again.out.find("resuming: 2 frames already registered"), std::string::npos) << again.out;
    EXPECT_NE(again.out.find("albedo map: rebuilt from 2 registered frames"), std::string::npos) << again.out;
    const json k = json::parse(test::readBytes(p.dir / "out" / "frames.json"));
    ASSERT_EQ(k["frames"].size(), 5u);
    EXPECT_EQ(k["frames"][1]["camera_to_world"], cut["frames"][1]["camera_to_world"]);  // kept, not redone
    EXPECT_LT(registration::poseError(frames::readFrames(p.dir / "out" / "frames.json").frames[4].cameraToWorld,
                                      p.scene.poses[4])
                  .position,
              0.8);
}

// Another method, or the albedo map set otherwise, on an output already
// written is refused; --restart overwrites. --min-similarity sets the
// method's flag threshold: over any NCC here, so every frame is flagged and
// says so. (Every second frame: the three are what the checks need.)
TEST(RegisterCli, AnotherSettingOnTheSameOutputNeedsRestart) {
    Patient p;
    fs::create_directories(p.dir / "out");
    const test::RunResult first = test::runCli(p.args("--step 2"));
    ASSERT_EQ(first.exitCode, 0) << first.err;
    const test::RunResult other = test::runCli(p.args("--step 2 --method intensity"));
    expectOneErrorLine(other, "--restart");
    expectOneErrorLine(test::runCli(p.args("--step 2 --no-albedo-map")), "--restart");
    const test::RunResult restart =
        test::runCli(p.args("--step 2 --method intensity --restart --min-similarity 0.9999"));
    ASSERT_EQ(restart.exitCode, 0) << restart.err;
    EXPECT_NE(restart.err.find("3 frames not converged"), std::string::npos) << restart.err;
    const json flagged = json::parse(test::readBytes(p.dir / "out" / "frames.json"));
    EXPECT_EQ(flagged["registration"]["method"], "intensity");
    ASSERT_EQ(flagged["frames"].size(), 3u);
    for (const json& f : flagged["frames"]) EXPECT_FALSE(f["registration"]["converged"].get<bool>());
}

TEST(RegisterCli, BadInputIsOneLineAndWritesNothing) {
    Patient p;
    fs::create_directories(p.dir / "out");
    const fs::path out = p.dir / "out" / "frames.json";
    auto check = [&](const std::string& args, const std::string& needle) {
        SCOPED_TRACE(needle);
        expectOneErrorLine(test::runCli(args), needle);
        EXPECT_FALSE(fs::exists(out));
        EXPECT_TRUE(fs::is_empty(p.dir / "out"));
    };
    // Intrinsics that disagree with the frames.
    writeText(p.dir / "cam2.json",
              R"({"intrinsics": {"width": 200, "height": 160, "fx": 90, "fy": 90, "cx": 99.5, "cy": 79.5}})");
    check(p.args("", {{"--camera", p.dir / "cam2.json"}}), "is 160x160, but");
    // A principal point outside the image (pixels, not normalised).
    writeText(p.dir / "cam3.json",
              R"({"intrinsics": {"width": 160, "height": 160, "fx": 90, "fy": 90, "cx": 0.5, "cy": 240}})");
    check(p.args("", {{"--camera", p.dir / "cam3.json"}}), "principal point");
    // A frame of another size.
    image::writePng(p.dir / "video" / "999.png", image::Image8(120, 160, 3));
    check(p.args(), "999.png");
    fs::remove(p.dir / "video" / "999.png");
    // A file that is not a video; a video of another size than the camera's.
    check(p.args("", {{"--video", p.dir / "camera.json"}}), "is not a video FFmpeg can read");
    test::encodeVideo(p.dir / "small.mkv", std::vector<image::Image8>(2, image::Image8(120, 160, 3)));
    check(p.args("", {{"--video", p.dir / "small.mkv"}}), "is 120x160, but");
    EXPECT_FALSE(fs::exists(p.dir / "out" / "frames_frames"));
    // Outside the airway: 40 mm to the side of the tube, looking along it.
    const frames::Vec3d c = frames::cameraCentre(p.scene.poses[0]);
    writeText(p.dir / "outside.json",
              json{{"position", {c[0] + 40, c[1], c[2]}}, {"look_at", {c[0], c[1], c[2]}}, {"up", {0, 1, 0}}}.dump());
    check(p.args("", {{"--init", p.dir / "outside.json"}}), "initial pose");
    // Facing a wall: 0.5 mm from it, looking at it.
    const auto& v = p.scene.mesh.positions[5000];
    const auto& n = p.scene.mesh.normals[5000];
    writeText(p.dir / "wall.json", json{{"position", {v[0] + 0.5 * n[0], v[1] + 0.5 * n[1], v[2] + 0.5 * n[2]}},
                                        {"look_at", {v[0], v[1], v[2]}},
                                        {"up", {0, 0, 1}}}
                                       .dump());
    check(p.args("", {{"--init", p.dir / "wall.json"}}), "faces a wall");
    // A mesh whose normals face out of the lumen.
    mesh::Mesh flipped = p.scene.mesh;
    mesh::flipOrientation(flipped);
    mesh::save(flipped, p.dir / "flipped.ply");
    check(p.args("", {{"--mesh", p.dir / "flipped.ply"}}), "--orient lumen");
    // A pose file that is not a pose; an unknown method; not a .json output.
    writeText(p.dir / "bad.json", R"({"position": [0, 0, 0], "look_at": [0, 0, 0], "up": [0, 1, 0]})");
    check(p.args("", {{"--init", p.dir / "bad.json"}}), "look_at");
    check(p.args("--method sift"), "pq or intensity");
    // The albedo map's rules with the map off, and contradicting flags.
    check(p.args("--keep-map-pose --no-albedo-map"), "--no-albedo-map turns the map off");
    check(p.args("--paint-min 0.8 --no-albedo-map"), "--no-albedo-map turns it off");
    check(p.args("--map-agreement 2 5 --no-albedo-map"), "--no-albedo-map turns the map off");
    check(p.args("--map-reach 5 20 --no-albedo-map"), "--no-albedo-map turns the map off");
    check(p.args("--keep-map-pose --no-keep-map-pose"), "contradict");
    // Out of range: a negative depth ratio or search size.
    check(p.args("--min-depth-range -1"), "--min-depth-range");
    check(p.args("--no-lumen-search -5"), "--no-lumen-search");
    // A model shading that is not a brdf.json.
    writeText(p.dir / "brdf.json", R"({"c": [1, 0, 0], "d": [0, 0, 0], "zmin": 1, "zmax": 2})");
    check(p.args("", {{"--brdf", p.dir / "brdf.json"}}), "field 'c'");
}

namespace {

// The patient's frames as 8-bit RGB, once as a folder of PNGs (png8/) and
// once as a lossless video (FFV1 in Matroska, scope.mkv). The initial pose is
// 0.8 mm off: the first frame's search is left out (kNoSearch) to keep the
// runs short; RegistersResumesAndReports has it.
constexpr const char* kNoSearch = "--search-radius 0 --search-degrees 0";

void writeEightBitVideo(const Patient& p) {
    std::vector<image::Image8> frames;
    fs::create_directories(p.dir / "png8");
    for (std::size_t i = 0; i < p.scene.poses.size(); ++i) {
        frames.push_back(image::to8(image::readPng(p.dir / "video" / fmt::format("{:03d}.png", i))));
        image::writePng(p.dir / "png8" / fmt::format("{:03d}.png", i), frames.back());
    }
    test::encodeVideo(p.dir / "scope.mkv", frames);
    fs::create_directories(p.dir / "out");
}

}  // namespace

// A video file registers to the same poses, to the bit, as its frames in a
// folder, and its frames are written beside the frames file.
TEST(RegisterCli, AVideoFileRegistersLikeItsFrames) {
    Patient p;
    writeEightBitVideo(p);
    const test::RunResult folder =
        test::runCli(p.args(kNoSearch, {{"--video", p.dir / "png8"}, {"-o", p.dir / "out" / "a.json"}}));
    ASSERT_EQ(folder.exitCode, 0) << folder.err;
    const test::RunResult video =
        test::runCli(p.args(kNoSearch, {{"--video", p.dir / "scope.mkv"}, {"-o", p.dir / "out" / "b.json"}}));
    ASSERT_EQ(video.exitCode, 0) << video.err;
    EXPECT_NE(video.out.find("registered 5 frames (5 converged)"), std::string::npos) << video.out;
    const frames::FrameSet a = frames::readFrames(p.dir / "out" / "a.json"),
                           b = frames::readFrames(p.dir / "out" / "b.json");
    ASSERT_EQ(b.frames.size(), 5u);
    for (std::size_t i = 0; i < 5; ++i) {
        EXPECT_EQ(a.frames[i].cameraToWorld, b.frames[i].cameraToWorld) << i;
        // The video's frames are written beside the frames file, which refers to them.
        const fs::path png = p.dir / "out" / "b_frames" / fmt::format("frame_{:06}.png", i);
        EXPECT_TRUE(fs::equivalent(b.frames[i].image, png)) << b.frames[i].image;
        EXPECT_EQ(test::readBytes(png), test::readBytes(p.dir / "png8" / fmt::format("{:03d}.png", i)));
    }
}

// --step takes every Nth frame of a video; a resumed run keeps the poses
// already registered and writes a missing frame again; another step on the
// same output is refused, not mixed.
TEST(RegisterCli, AVideoFileTakesEverySecondFrameAndResumes) {
    Patient p;
    writeEightBitVideo(p);
    // Every second frame: 0, 2, 4, named by their frame number in the video.
    const std::string step = std::string(kNoSearch) + " --step 2";
    const std::map<std::string, fs::path> video{{"--video", p.dir / "scope.mkv"}, {"-o", p.dir / "out" / "c.json"}};
    const test::RunResult first = test::runCli(p.args(step, video));
    ASSERT_EQ(first.exitCode, 0) << first.err;
    const frames::FrameSet c = frames::readFrames(p.dir / "out" / "c.json");
    ASSERT_EQ(c.frames.size(), 3u);
    EXPECT_EQ(c.frames[2].image.filename(), "frame_000004.png");
    // Resume: cut c to two frames and delete one of their PNGs; the rest is
    // registered again, the kept poses stay, the missing PNG comes back.
    json cut = json::parse(test::readBytes(p.dir / "out" / "c.json"));
    cut["frames"].erase(cut["frames"].begin() + 2, cut["frames"].end());
    cut["frames"][1]["camera_to_world"][0][3] = cut["frames"][1]["camera_to_world"][0][3].get<double>() + 0.25;
    writeText(p.dir / "out" / "c.json", cut.dump());
    fs::remove(p.dir / "out" / "c_frames" / "frame_000002.png");
    const test::RunResult again = test::runCli(p.args(step, video));
    ASSERT_EQ(again.exitCode, 0) << again.err;
    EXPECT_NE(again.out.find("resuming: 2 frames already registered"), std::string::npos) << again.out;
    const json k = json::parse(test::readBytes(p.dir / "out" / "c.json"));
    ASSERT_EQ(k["frames"].size(), 3u);
    EXPECT_EQ(k["frames"][1]["camera_to_world"], cut["frames"][1]["camera_to_world"]);
    EXPECT_EQ(test::readBytes(p.dir / "out" / "c_frames" / "frame_000002.png"),
              test::readBytes(p.dir / "png8" / "002.png"));
    // The same output without the step it was made with is refused, not mixed.
    expectOneErrorLine(test::runCli(p.args(kNoSearch, video)), "--restart");
}
