// Bad input to the fit: one clear error, nothing half-written.
#include <fstream>

#include <gtest/gtest.h>

#include <mucosa/core/error.hpp>
#include <mucosa/fit/fit.hpp>
#include <mucosa/image/png.hpp>
#include <mucosa/mesh/io.hpp>

#include "synthetic.hpp"
#include "test_support.hpp"

using namespace mucosa;

namespace {

void writeJson(const std::filesystem::path& p, const std::string& text) {
    std::ofstream(p) << text;
}

}  // namespace

TEST(FitInput, FramesFileErrorsNameTheField) {
    test::TempDir dir;
    writeJson(dir / "a.json", R"({"frames": []})");
    EXPECT_THROW(frames::readFrames(dir / "a.json"), InputError);
    writeJson(
        dir / "b.json",
        R"({"frames": [{"image": "f.png", "intrinsics": {"width": 32, "height": 32, "fx": -1, "fy": 1, "cx": 16, "cy": 16},
                 "camera_to_world": [[1,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]]}]})");
    try {
        frames::readFrames(dir / "b.json");
        FAIL();
    } catch (const InputError& e) {
        EXPECT_NE(std::string(e.what()).find("frames[0].intrinsics.fx"), std::string::npos) << e.what();
    }
    writeJson(
        dir / "c.json",
        R"({"frames": [{"image": "f.png", "intrinsics": {"width": 32, "height": 32, "fx": 1, "fy": 1, "cx": 16, "cy": 16},
                 "camera_to_world": [[2,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]]}]})");
    EXPECT_THROW(frames::readFrames(dir / "c.json"), InputError);  // not rigid
    writeJson(dir / "d.json", R"({"units": "m", "frames": [1]})");
    EXPECT_THROW(frames::readFrames(dir / "d.json"), InputError);
}

TEST(FitInput, MismatchedImageSizeFramesThatMissTheMeshAndInsideOutCamerasAreRefused) {
    test::TempDir dir;
    const mesh::Mesh tube = test::makeTube(9, 80, 64, 64);
    test::SyntheticOptions so;
    so.frames = 3;
    so.size = 64;
    frames::FrameSet set = test::renderSynthetic(tube, test::Truth{}, so, dir.path());
    fit::FitOptions o;
    o.minSamples = 100;

    frames::FrameSet wrongSize = set;
    wrongSize.frames[1].K.width = 80;
    EXPECT_THROW(fit::fitFrames(tube, wrongSize, o), InputError);

    frames::FrameSet away = set;  // camera far outside, looking away
    away.frames[0].cameraToWorld[0][3] = 1000;
    away.frames[0].cameraToWorld[2][3] = -1000;
    EXPECT_THROW(fit::fitFrames(tube, away, o), InputError);

    mesh::Mesh flipped = tube;  // normals pointing out of the lumen
    for (auto& n : flipped.normals)
        for (float& c : n) c = -c;
    try {
        fit::fitFrames(flipped, set, o);
        FAIL();
    } catch (const InputError& e) {
        EXPECT_NE(std::string(e.what()).find("back of the surface"), std::string::npos) << e.what();
    }

    mesh::Mesh noUv = tube;
    noUv.uvs.clear();
    EXPECT_THROW(fit::fitFrames(noUv, set, o), InputError);

    o.minSamples = 100000000;  // too few samples
    EXPECT_THROW(fit::fitFrames(tube, set, o), InputError);
}

TEST(FitInput, CliPrintsOneErrorLineAndWritesNothing) {
    test::TempDir dir;
    const mesh::Mesh tube = test::makeTube(9, 80, 64, 64);
    mesh::save(tube, dir / "tube.ply");
    test::SyntheticOptions so;
    so.frames = 2;
    so.size = 48;
    frames::FrameSet set = test::renderSynthetic(tube, test::Truth{}, so, dir.path());
    // Make the second image the wrong size.
    image::writePng(dir / "frame_1.png", image::Image8(40, 48, 3));
    const auto r = test::runCli("fit --mesh tube.ply --frames frames.json -o out", dir.path());
    EXPECT_NE(r.exitCode, 0);
    // Progress lines may come first; the error is one line, the last.
    const std::string last = r.err.substr(r.err.rfind('\n', r.err.size() - 2) + 1);
    EXPECT_EQ(last.rfind("error: ", 0), 0u) << r.err;
    EXPECT_EQ(r.err.find("error: "), r.err.rfind("error: ")) << r.err;
    EXPECT_NE(r.err.find("frame_1.png"), std::string::npos) << r.err;
    EXPECT_FALSE(std::filesystem::exists(dir / "out" / "brdf.json"));
    const auto missing = test::runCli("fit --mesh nope.ply --frames frames.json -o out", dir.path());
    EXPECT_NE(missing.exitCode, 0);
    EXPECT_NE(missing.err.find("nope.ply"), std::string::npos) << missing.err;
}
